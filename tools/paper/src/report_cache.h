#pragma once
// The report's cache of its slow intermediate results (trained models, Table 1): each entry is a
// file named by a hash of everything it was made from (inputs' sizes and times, options, the
// posekit binary), so a changed input makes a new entry and a stale one is never read.
#include <nlohmann/json.hpp>
#include <string>

#include "posekit/deformation/pose_fitting.h"
#include "posekit/paper/registration_table.h"

namespace posekit::report_detail {

class ResultCache {
 public:
  /// `dir` empty: no cache (every path() is empty).
  explicit ResultCache(std::string dir);
  bool enabled() const { return !dir_.empty(); }
  /// The file of `what` made from `inputs` (a description of every input and option), or empty.
  std::string path(const std::string& what, const std::string& inputs, const std::string& extension) const;

 private:
  std::string dir_;
};

/// The relative path, size and modification time of every file under `dir` (not their bytes): it
/// changes when any of them does.
std::string folder_fingerprint(const std::string& dir);
/// The same for one file.
std::string file_fingerprint(const std::string& path);
/// The binary holding posekit's code: another build is another fingerprint.
std::string binary_fingerprint();

/// A pose fit (its pose, fitted vertices and warnings) kept exactly: the pose as JSON (doubles to 17
/// digits), the vertices as raw doubles. read_pose_fit returns false for a file it cannot take.
void write_pose_fit(const std::string& path, const PoseFitResult& fit);
bool read_pose_fit(const std::string& path, PoseFitResult* fit);

nlohmann::json registration_table_to_json(const RegistrationTable& t);
RegistrationTable registration_table_from_json(const nlohmann::json& j);

}  // namespace posekit::report_detail
