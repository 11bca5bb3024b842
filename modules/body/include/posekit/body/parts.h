#pragma once
// The 16-part SCAPE-style skeleton the toolkit speaks (section 3.3.1 of Zhu & Mok): parts,
// the 15 joints of their tree, the mapping from the 163 MakeHuman bones, and 16-part poses.
#include <Eigen/Core>
#include <array>
#include <string>
#include <utility>
#include <vector>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/skinning.h"

namespace posekit {

constexpr int kNumParts = 16;
constexpr int kNumJoints = 15;

enum Part : int {
  kPelvis,
  kAbdomen,
  kChest,
  kHead,
  kLeftUpperArm,
  kLeftForearm,
  kLeftHand,
  kRightUpperArm,
  kRightForearm,
  kRightHand,
  kLeftThigh,
  kLeftShank,
  kLeftFoot,
  kRightThigh,
  kRightShank,
  kRightFoot
};

/// "pelvis", "abdomen", ..., "right_foot".
const std::string& part_name(int part);
/// Parent part in the tree rooted at the pelvis (-1 for the pelvis).
int part_parent(int part);
/// The part on the other side (itself for the midline parts).
int mirror_part(int part);
/// Joint j connects part j+1 to its parent; its name ("lower_back", "upper_back", "neck",
/// "left_shoulder", "left_elbow", "left_wrist", ..., "right_ankle").
const std::string& joint_name(int joint);
/// The names of the joints whose flag is set, in joint order.
std::vector<std::string> joint_names_where(const std::array<bool, kNumJoints>& flags);
/// Index of a joint by name, -1 when unknown.
int find_joint_index(const std::string& name);

/// For each rig bone, its part (the nearest ancestor that starts a part).
std::vector<int> bone_parts(const Rig& rig);
/// The bone that starts each part (its head is the part's joint centre), #parts.
std::array<int, kNumParts> part_root_bones(const Rig& rig);

/// Per-vertex part labels from the skinning weights (largest summed weight per part), #V.
Eigen::VectorXi vertex_part_labels(const MakeHumanModel& model);
/// Each vertex's parts and their weights (summing to 1): the rig's bone weights summed by part, parts
/// under 1e-4 of the vertex's total left out. #V lists of (part, weight).
std::vector<std::vector<std::pair<int, double>>> vertex_part_weights(const MakeHumanModel& model);
/// Per-triangle labels: the label most of its three vertices carry (ties: the first vertex's), #F.
Eigen::VectorXi triangle_part_labels(const Eigen::MatrixXi& F, const Eigen::VectorXi& vertex_labels);

/// The 15 joint centres of a shaped body, #joints x 3 (m): heads of the part-starting bones.
Eigen::MatrixXd joint_centres(const Rig& rig, const Body& body);

/// A pose of the 16-part skeleton: each joint's rotation of the child part relative to its parent,
/// axis-angle (radians, axis in the rest frame: X to the subject's left, Y up, Z forward), rest = 0.
struct PartPose {
  std::array<Eigen::Vector3d, kNumJoints> joint_rotation;
  Eigen::Vector3d root_rotation = Eigen::Vector3d::Zero();     ///< axis-angle of the pelvis
  Eigen::Vector3d root_translation = Eigen::Vector3d::Zero();  ///< m
  PartPose() { joint_rotation.fill(Eigen::Vector3d::Zero()); }
  /// Joint j's rotation (axis-angle, radians), j in [0, kNumJoints): joint_rotation[j].
  Eigen::Vector3d& joint(int j) { return joint_rotation[static_cast<size_t>(j)]; }
  const Eigen::Vector3d& joint(int j) const { return joint_rotation[static_cast<size_t>(j)]; }
};

/// Rotation matrix of an axis-angle vector (angle = norm).
Eigen::Matrix3d rotation_from_axis_angle(const Eigen::Vector3d& axis_angle);
/// The axis-angle vector of a rotation matrix (angle in [0, pi]).
Eigen::Vector3d axis_angle_from_rotation(const Eigen::Matrix3d& rotation);
/// The joints of a part: the one to its parent (none for the pelvis), then those to its children.
std::vector<int> joints_of_part(int part);

/// JSON form: {"joints": {"left_elbow": [rx, ry, rz], ...}, "root_rotation": [...],
/// "root_translation": [...], "units": "radians, metres"}. Unknown joints, NaN, or wrong array
/// sizes throw InvalidInput naming the key and `context`.
PartPose part_pose_from_json(const std::string& json_text, const std::string& context);
std::string part_pose_to_json(const PartPose& pose);
PartPose read_part_pose(const std::string& path);
void write_part_pose(const std::string& path, const PartPose& pose);

/// Bone rotations of the 163-bone rig realising a 16-part pose: each joint's rotation goes to the
/// bone that starts the child part; every other bone keeps its rest orientation relative to its parent.
BonePose bone_pose_from_part_pose(const Rig& rig, const PartPose& pose);

}  // namespace posekit
