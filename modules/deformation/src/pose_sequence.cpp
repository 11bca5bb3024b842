#include "posekit/deformation/pose_sequence.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <sstream>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/skinning.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/io/atomic_file.h"

namespace posekit {

namespace fs = std::filesystem;

PoseSequence load_pose_sequence(const std::string& path, const Eigen::MatrixXd& rest_joints, const PoseSequenceOptions& options,
                                const BvhMotion* motion) {
  PoseSequence out;
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const std::string stem = fs::path(path).stem().string();
  if (ext != ".bvh") {
    out.names.push_back(stem);
    out.poses.push_back(read_part_pose(path));
    return out;
  }
  BvhMotion read;
  if (!motion) read = read_bvh(path, Unit::kMetre), motion = &read;
  if (motion->num_frames() == 0) throw InvalidInput(path + ": the motion has no frames");
  const long first = options.first, last = options.last < 0 ? motion->num_frames() : options.last;
  if (first < 0 || last > motion->num_frames() || first >= last)
    throw InvalidInput(path + ": frames " + std::to_string(first) + ":" + std::to_string(last) + " are outside its " +
                       std::to_string(motion->num_frames()) + " frames");
  for (long i = first; i < last; ++i) {
    std::ostringstream name;
    name << stem << "_" << std::setw(4) << std::setfill('0') << i;
    out.names.push_back(last - first > 1 ? name.str() : stem);
  }
  if (motion->find_joint("upperarm01.L") >= 0) {  // MakeHuman's own skeleton: through its rig, bone by bone
    const auto mh = load_makehuman_model(find_data_root(options.data_root));
    for (long i = first; i < last; ++i)
      out.poses.push_back(part_pose_from_bone_pose(mh->rig, bone_pose_from_bvh(mh->rig, *motion, static_cast<int>(i))));
    return out;
  }
  const BvhPartMap map = map_bvh_skeleton(*motion, options.joint_map);
  RetargetOptions o;
  o.first = static_cast<int>(first);
  o.last = static_cast<int>(last);
  o.root_motion = options.root_motion;
  out.poses = retarget_bvh(*motion, map, rest_joints, o);
  std::string mapped;
  for (int p = 0; p < kNumParts; ++p)
    if (map.joint[p] >= 0)
      mapped += (mapped.empty() ? "" : ", ") + part_name(p) + "=" + motion->joints[static_cast<size_t>(map.joint[p])].name;
  out.notes.push_back(path + ": retargeted from its own skeleton (" + mapped + ")");
  out.notes.insert(out.notes.end(), map.notes.begin(), map.notes.end());
  return out;
}

std::map<std::string, std::string> read_bvh_joint_map(const std::string& path) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(read_file_bytes(path));
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput(path + ": not JSON (" + e.what() + ")");
  }
  if (!j.is_object()) throw InvalidInput(path + ": expected an object {\"left_shoulder\": \"<BVH joint>\", ...}");
  std::map<std::string, std::string> map;
  for (const auto& [key, value] : j.items()) {
    if (!value.is_string()) throw InvalidInput(path + ": the value of '" + key + "' must be a BVH joint name");
    map[key] = value.get<std::string>();
  }
  return map;
}

}  // namespace posekit
