#pragma once
// Runs the posekit executable as a user does (POSEKIT_EXE, set by CMake) and collects its output.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace posekit::test {

struct CommandResult {
  int code;
  std::string out;
};

/// `posekit <args>` through the shell: stdout (and stderr with `merge_stderr`), and the exit code.
/// `prefix` goes before the executable (e.g. "ulimit -f 0;" or an environment assignment).
inline CommandResult run_posekit(const std::string& args, bool merge_stderr = false, const std::string& prefix = "") {
  const std::string cmd = prefix + std::string(POSEKIT_EXE) + " " + args + (merge_stderr ? " 2>&1" : " 2>/dev/null");
  FILE* pipe = ::popen(cmd.c_str(), "r");
  std::string out;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = std::fread(buf.data(), 1, buf.size(), pipe)) > 0) out.append(buf.data(), n);
  const int status = ::pclose(pipe);
  return {WEXITSTATUS(status), out};
}

}  // namespace posekit::test
