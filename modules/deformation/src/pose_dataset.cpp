#include "posekit/deformation/pose_dataset.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"

namespace posekit {

namespace fs = std::filesystem;

int find_rest_example(const PoseDataset& data) {
  for (size_t i = 0; i < data.names.size(); ++i)
    if (!data.rest_name.empty() && data.names[i] == data.rest_name) return static_cast<int>(i);
  for (size_t i = 0; i < data.names.size(); ++i) {
    bool zero = data.has_pose[i] && data.poses[i].root_rotation.norm() < 1e-12;
    for (int j = 0; j < kNumJoints && zero; ++j) zero = data.poses[i].joint(j).norm() < 1e-12;
    if (zero) return static_cast<int>(i);
  }
  return -1;
}

PoseDataset load_pose_dataset(const std::string& dir, Unit unit) {
  PoseDataset ds;
  fs::path base = dir;
  std::vector<fs::path> meshes;
  std::map<std::string, bool> split;
  const fs::path manifest = fs::path(dir) / "manifest.json";
  if (fs::is_regular_file(manifest)) {
    const nlohmann::json j = read_json_file(manifest.string());
    if (!j.contains("pose_dataset")) throw IoError(manifest.string() + ": no 'pose_dataset' section");
    for (const auto& p : j["pose_dataset"]["poses"]) {
      meshes.push_back(fs::path(dir) / p["mesh"].get<std::string>());
      split[fs::path(p["mesh"].get<std::string>()).stem().string()] = p.value("split", "train") == "test";
    }
    ds.rest_name = j["pose_dataset"].value("rest", "");
  } else {
    if (fs::is_directory(fs::path(dir) / "pose_dataset")) base = fs::path(dir) / "pose_dataset";
    if (!fs::is_directory(base)) throw IoError(dir + ": not a folder of registered meshes");
    for (const auto& e : fs::directory_iterator(base)) {
      const MeshFormat f = mesh_format_from_path(e.path().string());
      if (e.is_regular_file() && (f == MeshFormat::kPly || f == MeshFormat::kObj || f == MeshFormat::kOff)) meshes.push_back(e.path());
    }
    std::sort(meshes.begin(), meshes.end());
  }
  if (meshes.empty()) throw IoError(dir + ": no registered meshes (.ply, .obj, .off) found");
  for (const fs::path& p : meshes) {
    TriangleMesh m = read_mesh(p.string(), {unit});
    if (ds.V.empty()) {
      ds.F = m.F;
    } else if (m.V.rows() != ds.V.front().rows() || m.F.rows() != ds.F.rows() || m.F != ds.F) {
      throw InvalidInput(p.string() + ": " + std::to_string(m.V.rows()) + " vertices / " + std::to_string(m.F.rows()) +
                         " triangles disagree with " + meshes.front().string() + " (" + std::to_string(ds.V.front().rows()) + " / " +
                         std::to_string(ds.F.rows()) + "): a pose dataset's meshes must share one topology");
    }
    const std::string stem = p.stem().string();
    ds.names.push_back(stem);
    ds.V.push_back(std::move(m.V));
    const fs::path pose = p.parent_path() / (stem + ".json");
    const bool has = fs::is_regular_file(pose);
    ds.has_pose.push_back(has);
    ds.poses.push_back(has ? read_part_pose(pose.string()) : PartPose{});
    ds.test.push_back(split.count(stem) ? split[stem] : false);
  }
  return ds;
}

Eigen::MatrixXd read_joint_centres(const std::string& path) {
  const nlohmann::json jj = read_json_file(path);
  Eigen::MatrixXd J(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) {
    try {
      const auto v = jj.at("joints").at(joint_name(j)).get<std::vector<double>>();
      if (v.size() != 3) throw IoError(path + ": joint '" + joint_name(j) + "' needs 3 coordinates");
      J.row(j) << v[0], v[1], v[2];
    } catch (const nlohmann::json::exception& e) {
      throw IoError(path + ": missing or malformed joint '" + joint_name(j) + "' (" + e.what() + ")");
    }
  }
  if (!J.allFinite()) throw IoError(path + ": a joint coordinate is not finite");
  return J;
}

TemplateAnnotations load_template_annotations(const std::string& dir, bool* found) {
  TemplateAnnotations out;
  const fs::path parts = fs::path(dir) / "template" / "parts.json", joints = fs::path(dir) / "template" / "joints.json";
  if (found) *found = fs::is_regular_file(parts) && fs::is_regular_file(joints);
  if (!fs::is_regular_file(parts) || !fs::is_regular_file(joints)) return out;
  try {
    const nlohmann::json pj = read_json_file(parts.string());
    const std::vector<int> labels = pj.at("triangle_part").get<std::vector<int>>();
    out.triangle_part = Eigen::Map<const Eigen::VectorXi>(labels.data(), static_cast<Eigen::Index>(labels.size()));
    if (labels.empty() || out.triangle_part.minCoeff() < 0 || out.triangle_part.maxCoeff() >= kNumParts)
      throw IoError(parts.string() + ": 'triangle_part' must hold labels in [0, 16)");
  } catch (const nlohmann::json::exception& e) {
    throw IoError(parts.string() + ": expected an array 'triangle_part' of integers (" + e.what() + ")");
  }
  out.joint_centres = read_joint_centres(joints.string());
  return out;
}

}  // namespace posekit
