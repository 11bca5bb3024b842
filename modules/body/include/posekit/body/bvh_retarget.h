#pragma once
// Motion from any humanoid BVH (CMU's namings, Mixamo, generic Hips/Spine/...): its joints mapped
// to the 16-part skeleton by name and structure, each frame retargeted as 16-part poses.
#include <Eigen/Core>
#include <array>
#include <map>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/io/bvh.h"

namespace posekit {

/// Which BVH joint starts each of the 16 parts: its origin is the part's joint centre and its
/// rotation turns the part. -1 for a part the file has no joint for (it then follows its parent).
struct BvhPartMap {
  std::array<int, kNumParts> joint;
  int head_top = -1;               ///< the file's head joint, above the neck joint that starts our head part
  std::vector<std::string> notes;  ///< how ambiguous names were settled
  BvhPartMap() { joint.fill(-1); }
};

/// Maps a BVH skeleton: the hands (or wrists) and feet (or ankles) by name, the elbow and upper
/// arm, knee and thigh as their parents (so that "LeftShoulder", a clavicle in one CMU conversion
/// and an upper arm in another, is read right); the pelvis is the root, the head by name, the neck
/// the first neck joint above the arms' branching, chest and abdomen along the spine.
/// `overrides` (our part or joint name -> BVH joint name, e.g. {"left_shoulder": "L_UpArm"}) come
/// first. Throws InvalidInput listing the parts that could not be mapped and how to supply them.
BvhPartMap map_bvh_skeleton(const BvhMotion& motion, const std::map<std::string, std::string>& overrides = {});

struct RetargetOptions {
  enum class RootMotion { kNone, kVertical, kAll };
  /// Root translation. Vertical (default): the lower ankle is as high above the floor as the file's
  /// above its floor (its lowest ankle over the frames), scaled by the legs' lengths, so feet stay
  /// on the ground in squats and leave it in jumps; no travel. All: the same, and the file's
  /// horizontal travel from the first frame. None: the pelvis stays in place.
  RootMotion root_motion = RootMotion::kVertical;
  int first = 0, last = -1;  ///< frames [first, last); -1: to the end
};

/// The 16-part poses of the motion's frames for a body with these rest joint centres (#joints x 3,
/// posekit's frame). The file's rest is its zero-rotation skeleton (T-pose, A-pose or any other):
/// each part's rest direction (to its child joint) is turned onto the file's before the file's
/// rotations are applied, so bones point where the file's do. Axes come from the file's rest
/// (up: hips to head; left: right hip to left hip), units do not matter.
std::vector<PartPose> retarget_bvh(const BvhMotion& motion, const BvhPartMap& map, const Eigen::MatrixXd& rest_joints,
                                   const RetargetOptions& options = {});

/// Joint positions of frame `frame` in posekit's frame, scaled to a body with these rest joints
/// (#BVH joints x 3, about the root's rest position): to check a retargeted pose against the
/// file's own forward kinematics.
Eigen::MatrixXd bvh_joints_in_body_frame(const BvhMotion& motion, const BvhPartMap& map, const Eigen::MatrixXd& rest_joints, int frame);

}  // namespace posekit
