#include "posekit/core/data_root.h"

#include <cstdlib>
#include <filesystem>
#include <vector>

#include "posekit/core/error.h"

#ifndef POSEKIT_DEFAULT_DATA_ROOT
#define POSEKIT_DEFAULT_DATA_ROOT ""
#endif

namespace posekit {
namespace fs = std::filesystem;

namespace {
bool is_data_root(const fs::path& dir) {
  std::error_code ec;
  return fs::is_regular_file(dir / "3dobjs" / "base.obj", ec);
}
}  // namespace

std::string find_data_root(const std::string& explicit_dir) {
  if (!explicit_dir.empty()) {
    if (is_data_root(explicit_dir)) return fs::absolute(explicit_dir).lexically_normal().string();
    throw IoError("data root '" + explicit_dir + "' (from --data) has no 3dobjs/base.obj: expected the MakeHuman assets folder");
  }
  if (const char* env = std::getenv("POSEKIT_DATA"); env && *env) {
    if (is_data_root(env)) return fs::absolute(env).lexically_normal().string();
    throw IoError(std::string("data root '") + env + "' (from POSEKIT_DATA) has no 3dobjs/base.obj: expected the MakeHuman assets folder");
  }
  std::vector<fs::path> tried;
  std::error_code ec;
  fs::path dir = fs::current_path(ec);
  for (int up = 0; up < 4 && !dir.empty(); ++up) {
    const fs::path candidate = dir / ".." / "shared" / "datasets" / "makehuman";
    tried.push_back(candidate.lexically_normal());
    if (is_data_root(candidate)) return candidate.lexically_normal().string();
    if (dir == dir.parent_path()) break;
    dir = dir.parent_path();
  }
  const fs::path built_in = POSEKIT_DEFAULT_DATA_ROOT;
  if (!built_in.empty()) {
    tried.push_back(built_in.lexically_normal());
    if (is_data_root(built_in)) return built_in.lexically_normal().string();
  }
  std::string msg = "no MakeHuman data root found (looked in";
  for (const auto& t : tried) msg += " " + t.string();
  msg +=
      "). Pass --data DIR or set POSEKIT_DATA to a folder holding the CC0 MakeHuman assets "
      "(3dobjs/base.obj, targets/, rigs/, poses/): the makehuman/data folder of the "
      "makehumancommunity/makehuman repository, as in ../shared/datasets/makehuman";
  throw IoError(msg);
}

}  // namespace posekit
