#pragma once
// The dataset's manifest.json, read once per call site of this module (internal header).
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit {

/// Parses DIR/manifest.json; IoError naming the file when it is missing or not JSON.
inline nlohmann::json read_dataset_manifest(const std::string& dir) {
  const std::string path = (std::filesystem::path(dir) / "manifest.json").string();
  try {
    return nlohmann::json::parse(read_file_bytes(path));
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path + ": not valid JSON (" + e.what() + ")");
  }
}

}  // namespace posekit
