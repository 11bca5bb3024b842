#include "posekit/body/pose_units.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"

namespace posekit {
namespace {

std::string replace_all(std::string s, const std::string& from, const std::string& to) {
  for (size_t pos = s.find(from); pos != std::string::npos; pos = s.find(from, pos + to.size())) s.replace(pos, from.size(), to);
  return s;
}

/// ".L" <-> ".R" at the end of a bone name.
std::string mirror_bone_name(const std::string& name) {
  if (name.size() > 2 && name.compare(name.size() - 2, 2, ".L") == 0) return name.substr(0, name.size() - 2) + ".R";
  if (name.size() > 2 && name.compare(name.size() - 2, 2, ".R") == 0) return name.substr(0, name.size() - 2) + ".L";
  return name;
}

}  // namespace

PoseUnits read_pose_units(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  if (!j.contains("poses") || !j["poses"].is_object()) throw IoError(path + ": expected 'poses' (MakeHuman pose units)");
  PoseUnits out;
  for (auto u = j["poses"].begin(); u != j["poses"].end(); ++u)
    for (auto b = u->begin(); b != u->end(); ++b) {
      if (!b->is_array() || b->size() != 4) throw IoError(path + ": unit '" + u.key() + "' bone '" + b.key() + "': expected [w, x, y, z]");
      Eigen::Quaterniond q((*b)[0].get<double>(), (*b)[1].get<double>(), (*b)[2].get<double>(), (*b)[3].get<double>());
      if (!std::isfinite(q.norm()) || q.norm() < 1e-6)
        throw IoError(path + ": unit '" + u.key() + "' bone '" + b.key() + "' is not a rotation");
      out.units[u.key()][b.key()] = q.normalized();
    }
  return out;
}

BonePose bone_pose_from_pose_units(const Rig& rig, const Body& body, const PoseUnits& units,
                                   const std::vector<std::pair<std::string, double>>& weighted, std::vector<std::string>* skipped) {
  if (static_cast<int>(body.bone_frames.size()) != rig.num_bones())
    throw InvalidInput("bone_pose_from_pose_units: the body has no bone frames for this rig");
  const Eigen::Matrix3d M = Eigen::Vector3d(-1, 1, 1).asDiagonal();  // sagittal mirror x -> -x
  BonePose pose = BonePose::identity(rig.num_bones());
  for (const auto& [name, weight] : weighted) {
    if (!std::isfinite(weight) || weight < 0 || weight > 1)
      throw InvalidInput("pose unit '" + name + "': weight " + std::to_string(weight) + " outside [0, 1]");
    bool mirrored = false;
    auto it = units.units.find(name);
    if (it == units.units.end() && name.find("Right") != std::string::npos) {
      it = units.units.find(replace_all(name, "Right", "Left"));
      mirrored = it != units.units.end();
    }
    if (it == units.units.end()) throw InvalidInput("unknown pose unit '" + name + "' (see 'posekit body --list-pose-units')");
    for (const auto& [bone_name, q] : it->second) {
      const Eigen::Quaterniond scaled = Eigen::Quaterniond::Identity().slerp(weight, q);
      const int left = rig.find_bone(bone_name);
      if (left < 0) {
        if (skipped) skipped->push_back(bone_name);
        continue;
      }
      // The bone-space rotation as a rotation of the rest frame, then mirrored if asked.
      Eigen::Matrix3d world = body.bone_frames[left] * scaled.toRotationMatrix() * body.bone_frames[left].transpose();
      int target = left;
      if (mirrored) {
        target = rig.find_bone(mirror_bone_name(bone_name));
        if (target < 0) {
          if (skipped) skipped->push_back(mirror_bone_name(bone_name));
          continue;
        }
        world = M * world * M;
      }
      pose.local[target] = pose.local[target] * world;
    }
  }
  return pose;
}

}  // namespace posekit
