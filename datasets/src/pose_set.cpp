#include "posekit/datasets/pose_set.h"

#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <random>

#include "json_helpers.h"

namespace posekit {
using datasets_detail::kDeg;
namespace {

int J(const char* name) { return find_joint_index(name); }

std::string fmt(const char* base, double degrees) {
  return std::string(base) + "_" + std::to_string(static_cast<int>(std::lround(degrees)));
}

}  // namespace

JointAxes joint_axes(const Eigen::MatrixXd& C) {
  JointAxes a;
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  for (bool left : {true, false}) {
    const Eigen::Vector3d shoulder = C.row(J(left ? "left_shoulder" : "right_shoulder")).transpose();
    const Eigen::Vector3d elbow = C.row(J(left ? "left_elbow" : "right_elbow")).transpose();
    const Eigen::Vector3d upper = (elbow - shoulder).normalized();
    (left ? a.left_elbow_flex : a.right_elbow_flex) = upper.cross(z).normalized();
    (left ? a.left_arm_raise : a.right_arm_raise) = left ? z : Eigen::Vector3d(-z);
  }
  return a;
}

std::vector<NamedPose> standard_pose_set(const Eigen::MatrixXd& C, unsigned seed, int num_random, bool small) {
  const JointAxes ax = joint_axes(C);
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Y = Eigen::Vector3d::UnitY(), Z = Eigen::Vector3d::UnitZ();
  std::vector<NamedPose> poses;
  auto single = [&](const std::string& name, const char* joint, const Eigen::Vector3d& axis, double degrees) {
    NamedPose p;
    p.name = name;
    p.pose.joint_rotation[J(joint)] = degrees * kDeg * axis;
    poses.push_back(p);
  };
  auto both_sides = [&](const char* what, const char* left_joint, const char* right_joint, const Eigen::Vector3d& left_axis,
                        const Eigen::Vector3d& right_axis, std::initializer_list<double> degrees) {
    for (double d : degrees) {
      single(fmt((std::string("left_") + what).c_str(), d), left_joint, left_axis, d);
      single(fmt((std::string("right_") + what).c_str(), d), right_joint, right_axis, d);
    }
  };
  // Single joints over their ranges (rest frame: X to the subject's left, Y up, Z forward).
  both_sides("shoulder_raise", "left_shoulder", "right_shoulder", ax.left_arm_raise, ax.right_arm_raise, {30, 60, 90, 120, 150});
  both_sides("shoulder_forward", "left_shoulder", "right_shoulder", -X, -X, {45, 90, 150});
  both_sides("shoulder_back", "left_shoulder", "right_shoulder", X, X, {30, 50});
  both_sides("elbow_flex", "left_elbow", "right_elbow", ax.left_elbow_flex, ax.right_elbow_flex, {35, 70, 105, 140});
  both_sides("hip_flex", "left_hip", "right_hip", -X, -X, {25, 50, 75, 100});
  both_sides("hip_abduct", "left_hip", "right_hip", Z, -Z, {20, 40});
  both_sides("hip_extend", "left_hip", "right_hip", X, X, {20});
  both_sides("knee_flex", "left_knee", "right_knee", X, X, {30, 65, 100, 130});
  both_sides("wrist_flex", "left_wrist", "right_wrist", ax.left_elbow_flex, ax.right_elbow_flex, {40});
  both_sides("wrist_extend", "left_wrist", "right_wrist", -ax.left_elbow_flex, -ax.right_elbow_flex, {40});
  both_sides("ankle_up", "left_ankle", "right_ankle", -X, -X, {20});
  both_sides("ankle_down", "left_ankle", "right_ankle", X, X, {30});
  for (double d : {20.0, 40.0}) single(fmt("torso_bend_forward", d), "lower_back", X, d);
  single("torso_bend_back_15", "lower_back", -X, 15);
  single("torso_bend_left_20", "upper_back", -Z, 20);
  single("torso_bend_right_20", "upper_back", Z, 20);
  single("torso_twist_left_30", "upper_back", Y, 30);
  single("torso_twist_right_30", "upper_back", -Y, 30);
  single("head_turn_left_40", "neck", Y, 40);
  single("head_turn_right_40", "neck", -Y, 40);
  single("head_down_30", "neck", X, 30);
  single("head_up_25", "neck", -X, 25);
  single("head_tilt_left_20", "neck", -Z, 20);
  single("head_tilt_right_20", "neck", Z, 20);

  // Whole-body combinations.
  auto combo = [&](const std::string& name, std::initializer_list<std::pair<const char*, Eigen::Vector3d>> joints) {
    NamedPose p;
    p.name = name;
    for (const auto& [joint, aa] : joints) p.pose.joint_rotation[J(joint)] = aa;
    poses.push_back(p);
  };
  for (int phase = 0; phase < 4; ++phase) {  // a walking cycle
    const double s = std::sin(phase * M_PI / 2), c = std::cos(phase * M_PI / 2);
    combo("walk_phase_" + std::to_string(phase), {{"left_hip", -30 * s * kDeg * X},
                                                  {"right_hip", 30 * s * kDeg * X},
                                                  {"left_knee", (10 + 25 * std::max(0.0, -c)) * kDeg * X},
                                                  {"right_knee", (10 + 25 * std::max(0.0, c)) * kDeg * X},
                                                  {"left_shoulder", 25 * s * kDeg * X},
                                                  {"right_shoulder", -25 * s * kDeg * X},
                                                  {"left_elbow", 20 * kDeg * ax.left_elbow_flex},
                                                  {"right_elbow", 20 * kDeg * ax.right_elbow_flex},
                                                  {"upper_back", 6 * s * kDeg * Y}});
  }
  combo("reach_forward", {{"left_shoulder", -90 * kDeg * X}, {"right_shoulder", -90 * kDeg * X}, {"lower_back", 15 * kDeg * X}});
  combo("reach_up", {{"left_shoulder", 150 * kDeg * ax.left_arm_raise}, {"right_shoulder", 150 * kDeg * ax.right_arm_raise}});
  combo("reach_left_low", {{"right_shoulder", -110 * kDeg * X}, {"lower_back", 30 * kDeg * X}, {"upper_back", 25 * kDeg * Y}});
  for (double depth : {0.5, 1.0}) {
    combo(depth < 1 ? "squat_half" : "squat_deep", {{"left_hip", -100 * depth * kDeg * X},
                                                    {"right_hip", -100 * depth * kDeg * X},
                                                    {"left_knee", 130 * depth * kDeg * X},
                                                    {"right_knee", 130 * depth * kDeg * X},
                                                    {"left_ankle", -25 * depth * kDeg * X},
                                                    {"right_ankle", -25 * depth * kDeg * X},
                                                    {"lower_back", 20 * depth * kDeg * X},
                                                    {"left_shoulder", -60 * depth * kDeg * X},
                                                    {"right_shoulder", -60 * depth * kDeg * X}});
  }
  combo("sitting", {{"left_hip", -90 * kDeg * X},
                    {"right_hip", -90 * kDeg * X},
                    {"left_knee", 90 * kDeg * X},
                    {"right_knee", 90 * kDeg * X},
                    {"left_elbow", 60 * kDeg * ax.left_elbow_flex},
                    {"right_elbow", 60 * kDeg * ax.right_elbow_flex}});
  combo("t_pose", {{"left_shoulder", 45 * kDeg * ax.left_arm_raise}, {"right_shoulder", 45 * kDeg * ax.right_arm_raise}});
  combo("guard", {{"left_shoulder", -40 * kDeg * X},
                  {"right_shoulder", -40 * kDeg * X},
                  {"left_elbow", 120 * kDeg * ax.left_elbow_flex},
                  {"right_elbow", 120 * kDeg * ax.right_elbow_flex}});
  combo("lunge", {{"left_hip", -70 * kDeg * X}, {"left_knee", 80 * kDeg * X}, {"right_hip", 25 * kDeg * X}, {"right_knee", 20 * kDeg * X}});

  // Random plausible combinations: every joint within a third of its range.
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int r = 0; r < num_random; ++r) {
    NamedPose p;
    p.name = "random_" + std::to_string(r);
    auto set = [&](const char* joint, const Eigen::Vector3d& axis, double lo, double hi) {
      p.pose.joint_rotation[J(joint)] += (lo + (hi - lo) * 0.5 * (u(rng) + 1)) * kDeg * axis;
    };
    set("left_shoulder", ax.left_arm_raise, 0, 90);
    set("right_shoulder", ax.right_arm_raise, 0, 90);
    set("left_shoulder", -X, -30, 60);
    set("right_shoulder", -X, -30, 60);
    set("left_elbow", ax.left_elbow_flex, 0, 110);
    set("right_elbow", ax.right_elbow_flex, 0, 110);
    set("left_hip", -X, -15, 60);
    set("right_hip", -X, -15, 60);
    set("left_knee", X, 0, 80);
    set("right_knee", X, 0, 80);
    set("lower_back", X, -10, 25);
    set("upper_back", Y, -20, 20);
    set("neck", Y, -30, 30);
    poses.push_back(p);
  }
  if (small) {  // a quick subset keeping every kind: each third pose
    std::vector<NamedPose> subset;
    for (size_t i = 0; i < poses.size(); i += 3) subset.push_back(poses[i]);
    poses = std::move(subset);
  }
  // Every fifth pose, and every walking/squat variant after the first, is held out.
  for (size_t i = 0; i < poses.size(); ++i) poses[i].test = (i % 5 == 2);
  return poses;
}

PartPose natural_rest_pose(const Eigen::MatrixXd& C) {
  const JointAxes ax = joint_axes(C);
  PartPose p;
  p.joint_rotation[J("left_shoulder")] = -25 * kDeg * ax.left_arm_raise;
  p.joint_rotation[J("right_shoulder")] = -25 * kDeg * ax.right_arm_raise;
  p.joint_rotation[J("left_elbow")] = 25 * kDeg * ax.left_elbow_flex;
  p.joint_rotation[J("right_elbow")] = 25 * kDeg * ax.right_elbow_flex;
  return p;
}

PartPose pose_from_rest(const PartPose& pose, const PartPose& rest) {
  // World rotations of the parts (parents first), the pose's after the rest's, then relative again.
  std::array<Eigen::Matrix3d, kNumParts> by_pose, at_rest, both;
  by_pose[kPelvis] = rotation_from_axis_angle(pose.root_rotation);
  at_rest[kPelvis] = rotation_from_axis_angle(rest.root_rotation);
  for (int part = 1; part < kNumParts; ++part) {
    const auto parent = static_cast<size_t>(part_parent(part));
    by_pose[static_cast<size_t>(part)] = by_pose[parent] * rotation_from_axis_angle(pose.joint(part - 1));
    at_rest[static_cast<size_t>(part)] = at_rest[parent] * rotation_from_axis_angle(rest.joint(part - 1));
  }
  for (size_t part = 0; part < both.size(); ++part) both[part] = by_pose[part] * at_rest[part];
  PartPose out;
  out.root_rotation = axis_angle_from_rotation(both[kPelvis]);
  out.root_translation = pose.root_translation + rest.root_translation;
  for (int part = 1; part < kNumParts; ++part)
    out.joint(part - 1) =
        axis_angle_from_rotation(both[static_cast<size_t>(part_parent(part))].transpose() * both[static_cast<size_t>(part)]);
  return out;
}

}  // namespace posekit
