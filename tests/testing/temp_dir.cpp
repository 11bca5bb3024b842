#include "testing/temp_dir.h"

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>

namespace posekit::test {
namespace fs = std::filesystem;

TempDir::TempDir() {
  static std::atomic<int> counter{0};
  path_ = (fs::temp_directory_path() / ("posekit-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++))).string();
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

std::string TempDir::write(const std::string& name, const std::string& bytes) const {
  const std::string p = file(name);
  std::ofstream(p, std::ios::binary) << bytes;
  return p;
}

int TempDir::count() const {
  int n = 0;
  for (auto it = fs::directory_iterator(path_); it != fs::directory_iterator(); ++it) ++n;
  return n;
}

std::string test_data_root() {
  const char* env = std::getenv("POSEKIT_DATA");
  if (env && fs::exists(fs::path(env) / "3dobjs" / "base.obj")) return env;
  return "";
}

}  // namespace posekit::test
