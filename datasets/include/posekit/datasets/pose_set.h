#pragma once
// The registered pose dataset's poses: each joint on its own over its range, and whole-body
// combinations, as 16-part poses (the stand-in for SCAPE's ~70 poses, section 3.3.2 of Zhu & Mok).
#include <string>
#include <vector>

#include "posekit/body/parts.h"

namespace posekit {

struct NamedPose {
  std::string name;  ///< file-name safe, e.g. "left_elbow_flex_105"
  PartPose pose;
  bool test = false;  ///< held out of training
};

/// Anatomical rotation axes of a body's joints in its rest frame, from its joint centres
/// (#joints x 3, m): flexion axes follow the limbs of that body.
struct JointAxes {
  Eigen::Vector3d left_elbow_flex, right_elbow_flex;  ///< brings the forearm forward and up
  Eigen::Vector3d left_arm_raise, right_arm_raise;    ///< abduction (sideways up)
};
JointAxes joint_axes(const Eigen::MatrixXd& joint_centres);

/// The pose set: single-joint sweeps (shoulder raise/forward/back to 150 degrees, elbow flexion to
/// 140, hip flexion to 100, knee flexion to 130, torso bend and twist, head turns, wrists, ankles)
/// and combinations (walking, reaching, squatting, sitting-like), plus `num_random` random
/// plausible combinations drawn from `seed`. About a fifth is marked `test`, spread over the kinds.
std::vector<NamedPose> standard_pose_set(const Eigen::MatrixXd& joint_centres, unsigned seed, int num_random = 10, bool small = false);

/// A natural standing rest against the template's A-pose: both arms 25 degrees closer to the body
/// and both elbows bent 25 degrees (a body scanner's or a person's own rest, not MakeHuman's).
PartPose natural_rest_pose(const Eigen::MatrixXd& joint_centres);

/// `pose` taken from the rest `rest` instead of from the template's: each part turned by `pose`'s
/// world rotation of it after the rest's (posekit poses a subject so, about the subject's own rest),
/// as joint rotations from the template's rest. The root translations add: exact for a rest that
/// does not move the pelvis (natural_rest_pose), not for one that turns it and moves it too.
PartPose pose_from_rest(const PartPose& pose, const PartPose& rest);

}  // namespace posekit
