#pragma once
#include <string>

namespace posekit {

/// Locates the MakeHuman data root. Order: `explicit_dir` (from --data) when not empty, the
/// POSEKIT_DATA environment variable, ../shared/datasets/makehuman relative to the working
/// directory and its parents, then the build-time default. The chosen folder must contain
/// 3dobjs/base.obj. Throws IoError that says where the assets come from when none is found.
std::string find_data_root(const std::string& explicit_dir = "");

}  // namespace posekit
