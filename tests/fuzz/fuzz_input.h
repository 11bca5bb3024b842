#pragma once
// Shared by the libFuzzer targets: the input as a file (posekit's readers take paths), and the
// rule every reader must keep: read, or throw a posekit::Error. Anything else aborts, so the
// fuzzer reports it (std::bad_alloc, a library's own exception, a crash, a sanitizer report).
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <fstream>
#include <string>

#include "posekit/core/error.h"

namespace posekit::fuzz {

/// Writes the input to a file of this process with extension `ext` and returns its path.
inline std::string write_input(const std::uint8_t* data, std::size_t size, const std::string& ext) {
  const char* dir = std::getenv("TMPDIR");
  const std::string path = std::string(dir && *dir ? dir : "/tmp") + "/posekit-fuzz-" + std::to_string(::getpid()) + ext;
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  return path;
}

template <typename Read>
void expect_clean(Read&& read) {
  try {
    read();
  } catch (const posekit::Error&) {
    // a clear error: what a bad file must get
  } catch (const std::exception& e) {
    std::fprintf(stderr, "fuzz: not a posekit::Error: %s\n", e.what());
    std::abort();
  }
}

}  // namespace posekit::fuzz
