#include "posekit/body/parts.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <numeric>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"

namespace posekit {
namespace {

const std::array<std::string, kNumParts> kPartNames = {
    "pelvis",        "abdomen",    "chest",      "head",       "left_upper_arm", "left_forearm", "left_hand",   "right_upper_arm",
    "right_forearm", "right_hand", "left_thigh", "left_shank", "left_foot",      "right_thigh",  "right_shank", "right_foot"};
const std::array<int, kNumParts> kPartParent = {-1,           kPelvis, kAbdomen,       kChest,        kChest,  kLeftUpperArm,
                                                kLeftForearm, kChest,  kRightUpperArm, kRightForearm, kPelvis, kLeftThigh,
                                                kLeftShank,   kPelvis, kRightThigh,    kRightShank};
const std::array<std::string, kNumJoints> kJointNames = {"lower_back", "upper_back",     "neck",        "left_shoulder", "left_elbow",
                                                         "left_wrist", "right_shoulder", "right_elbow", "right_wrist",   "left_hip",
                                                         "left_knee",  "left_ankle",     "right_hip",   "right_knee",    "right_ankle"};
/// The MakeHuman bone that starts each part (".L" is the subject's left, +X).
const std::array<std::string, kNumParts> kPartRootBone = {
    "root",         "spine04", "spine02",      "neck01",       "upperarm01.L", "lowerarm01.L", "wrist.L",      "upperarm01.R",
    "lowerarm01.R", "wrist.R", "upperleg01.L", "lowerleg01.L", "foot.L",       "upperleg01.R", "lowerleg01.R", "foot.R"};

Eigen::Vector3d vec3(const nlohmann::json& j, const std::string& key, const std::string& context) {
  if (!j.is_array() || j.size() != 3) throw InvalidInput(context + ": '" + key + "' must be an array of 3 numbers");
  Eigen::Vector3d v;
  for (int k = 0; k < 3; ++k) {
    if (!j[k].is_number()) throw InvalidInput(context + ": '" + key + "' must be an array of 3 numbers");
    v[k] = j[k].get<double>();
    if (!std::isfinite(v[k])) throw InvalidInput(context + ": '" + key + "' has a non-finite value");
  }
  return v;
}

}  // namespace

const std::string& part_name(int part) { return kPartNames.at(part); }
int part_parent(int part) { return kPartParent.at(part); }
int mirror_part(int part) {
  if (part >= kLeftUpperArm && part <= kLeftHand) return part + 3;
  if (part >= kRightUpperArm && part <= kRightHand) return part - 3;
  if (part >= kLeftThigh && part <= kLeftFoot) return part + 3;
  if (part >= kRightThigh && part <= kRightFoot) return part - 3;
  return part;
}
const std::string& joint_name(int joint) { return kJointNames.at(joint); }

std::vector<std::string> joint_names_where(const std::array<bool, kNumJoints>& flags) {
  std::vector<std::string> names;
  for (int j = 0; j < kNumJoints; ++j)
    if (flags[static_cast<size_t>(j)]) names.push_back(joint_name(j));
  return names;
}
int find_joint_index(const std::string& name) {
  for (int j = 0; j < kNumJoints; ++j)
    if (kJointNames[j] == name) return j;
  return -1;
}

std::array<int, kNumParts> part_root_bones(const Rig& rig) {
  std::array<int, kNumParts> roots;
  for (int p = 0; p < kNumParts; ++p) {
    roots[p] = rig.find_bone(kPartRootBone[p]);
    if (roots[p] < 0) throw InvalidInput("rig has no bone '" + kPartRootBone[p] + "' (expected the MakeHuman default rig)");
  }
  return roots;
}

std::vector<int> bone_parts(const Rig& rig) {
  const auto roots = part_root_bones(rig);
  std::vector<int> part(rig.num_bones(), -1);
  for (int p = 0; p < kNumParts; ++p) part[roots[p]] = p;
  for (int b = 0; b < rig.num_bones(); ++b)  // parents first
    if (part[b] < 0) part[b] = rig.parent[b] < 0 ? kPelvis : part[rig.parent[b]];
  return part;
}

Eigen::VectorXi vertex_part_labels(const MakeHumanModel& model) {
  const std::vector<int> parts = bone_parts(model.rig);
  Eigen::VectorXi labels(model.weights.rows());
  for (Eigen::Index v = 0; v < model.weights.rows(); ++v) {
    std::array<double, kNumParts> sum{};
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(model.weights, v); it; ++it) sum[parts[it.col()]] += it.value();
    labels[v] = static_cast<int>(std::max_element(sum.begin(), sum.end()) - sum.begin());
  }
  return labels;
}

std::vector<std::vector<std::pair<int, double>>> vertex_part_weights(const MakeHumanModel& model) {
  const std::vector<int> parts = bone_parts(model.rig);
  const auto& W = model.weights;
  std::vector<std::vector<std::pair<int, double>>> out(static_cast<size_t>(W.rows()));
  for (Eigen::Index v = 0; v < W.rows(); ++v) {
    std::array<double, kNumParts> sum{};
    for (Eigen::SparseMatrix<double, Eigen::RowMajor>::InnerIterator it(W, v); it; ++it)
      sum[static_cast<size_t>(parts[static_cast<size_t>(it.col())])] += it.value();
    const double total = std::accumulate(sum.begin(), sum.end(), 0.0);
    auto& pw = out[static_cast<size_t>(v)];
    for (int p = 0; p < kNumParts; ++p)
      if (sum[static_cast<size_t>(p)] > 1e-4 * total) pw.emplace_back(p, sum[static_cast<size_t>(p)]);
    double kept = 0;
    for (const auto& entry : pw) kept += entry.second;
    if (kept <= 0) pw = {{static_cast<int>(std::max_element(sum.begin(), sum.end()) - sum.begin()), 1.0}};
    else
      for (auto& entry : pw) entry.second /= kept;
  }
  return out;
}

Eigen::VectorXi triangle_part_labels(const Eigen::MatrixXi& F, const Eigen::VectorXi& vl) {
  Eigen::VectorXi labels(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int a = vl[F(f, 0)], b = vl[F(f, 1)], c = vl[F(f, 2)];
    labels[f] = (b == c && b != a) ? b : a;
  }
  return labels;
}

Eigen::MatrixXd joint_centres(const Rig& rig, const Body& body) {
  const auto roots = part_root_bones(rig);
  Eigen::MatrixXd J(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) J.row(j) = body.bone_heads.row(roots[j + 1]);
  return J;
}

Eigen::Matrix3d rotation_from_axis_angle(const Eigen::Vector3d& aa) {
  const double angle = aa.norm();
  if (angle < 1e-300) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, aa / angle).toRotationMatrix();
}

Eigen::Vector3d axis_angle_from_rotation(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd aa(R);
  return aa.angle() * aa.axis();
}

std::vector<int> joints_of_part(int part) {
  std::vector<int> joints;
  if (part > 0) joints.push_back(part - 1);
  for (int c = 1; c < kNumParts; ++c)
    if (part_parent(c) == part) joints.push_back(c - 1);
  return joints;
}

PartPose part_pose_from_json(const std::string& text, const std::string& context) {
  const nlohmann::json j = parse_json(text, context);
  if (!j.is_object()) throw InvalidInput(context + ": expected a JSON object with 'joints'");
  PartPose pose;
  for (auto it = j.begin(); it != j.end(); ++it) {
    if (it.key() == "joints") {
      if (!it->is_object()) throw InvalidInput(context + ": 'joints' must be an object of joint: [rx, ry, rz]");
      for (auto jt = it->begin(); jt != it->end(); ++jt) {
        const int index = find_joint_index(jt.key());
        if (index < 0) {
          std::string known;
          for (const auto& n : kJointNames) known += (known.empty() ? "" : ", ") + n;
          throw InvalidInput(context + ": unknown joint '" + jt.key() + "' (expected one of " + known + ")");
        }
        pose.joint_rotation[index] = vec3(*jt, "joints/" + jt.key(), context);
      }
    } else if (it.key() == "root_rotation") {
      pose.root_rotation = vec3(*it, it.key(), context);
    } else if (it.key() == "root_translation") {
      pose.root_translation = vec3(*it, it.key(), context);
    } else if (it.key() != "units" && it.key() != "format" && it.key() != "name") {
      throw InvalidInput(context + ": unknown key '" + it.key() + "' (expected joints, root_rotation, root_translation)");
    }
  }
  return pose;
}

std::string part_pose_to_json(const PartPose& pose) {
  nlohmann::ordered_json j;
  j["format"] = "posekit 16-part pose 1";
  j["units"] = "axis-angle radians relative to the parent part, metres";
  j["joints"] = nlohmann::ordered_json::object();
  for (int k = 0; k < kNumJoints; ++k) {
    const auto& r = pose.joint_rotation[k];
    j["joints"][kJointNames[k]] = {r.x(), r.y(), r.z()};
  }
  j["root_rotation"] = {pose.root_rotation.x(), pose.root_rotation.y(), pose.root_rotation.z()};
  j["root_translation"] = {pose.root_translation.x(), pose.root_translation.y(), pose.root_translation.z()};
  return j.dump(2) + "\n";
}

PartPose read_part_pose(const std::string& path) { return part_pose_from_json(read_file_bytes(path), path); }

void write_part_pose(const std::string& path, const PartPose& pose) {
  const std::string text = part_pose_to_json(pose);
  write_file_atomically(
      path, [&](std::ostream& out) { out << text; }, false);
}

BonePose bone_pose_from_part_pose(const Rig& rig, const PartPose& pose) {
  const auto roots = part_root_bones(rig);
  BonePose out = BonePose::identity(rig.num_bones());
  out.local[roots[kPelvis]] = rotation_from_axis_angle(pose.root_rotation);
  out.root_translation = pose.root_translation;
  for (int j = 0; j < kNumJoints; ++j) out.local[roots[j + 1]] = rotation_from_axis_angle(pose.joint_rotation[j]);
  return out;
}

}  // namespace posekit
