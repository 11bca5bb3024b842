#pragma once
// Poses from a file: a 16-part pose JSON, or a BVH motion, either of MakeHuman's own skeleton
// (read through its rig) or of any other humanoid skeleton (retargeted, body/bvh_retarget.h).
#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "posekit/body/bvh_retarget.h"
#include "posekit/body/parts.h"
#include "posekit/io/bvh.h"

namespace posekit {

struct PoseSequenceOptions {
  int first = 0, last = -1;                      ///< a BVH's frames [first, last); -1: to the end
  std::string data_root;                         ///< MakeHuman's assets, for a BVH of its skeleton ("": find_data_root's default)
  std::map<std::string, std::string> joint_map;  ///< map_bvh_skeleton's overrides (read_bvh_joint_map)
  RetargetOptions::RootMotion root_motion = RetargetOptions::RootMotion::kVertical;
};

struct PoseSequence {
  std::vector<std::string> names;  ///< the file's stem, with _NNNN per BVH frame when several
  std::vector<PartPose> poses;
  std::vector<std::string> notes;  ///< how a BVH skeleton was mapped
};

/// The poses of a pose JSON or BVH file (by its extension) for a body with these rest joint centres
/// (#joints x 3, posekit's frame; used only to retarget a BVH of another skeleton). `motion`: the
/// BVH already read from `path`, or null to read it. Throws InvalidInput (no frames, frames outside
/// the motion, a skeleton that cannot be mapped) or IoError naming the file.
PoseSequence load_pose_sequence(const std::string& path, const Eigen::MatrixXd& rest_joints, const PoseSequenceOptions& options = {},
                                const BvhMotion* motion = nullptr);

/// A joint map file for map_bvh_skeleton: {"left_shoulder": "<BVH joint>", ...}. Throws
/// InvalidInput naming the file when it is not such an object.
std::map<std::string, std::string> read_bvh_joint_map(const std::string& path);

}  // namespace posekit
