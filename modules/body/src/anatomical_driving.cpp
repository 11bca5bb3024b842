#include "posekit/body/anatomical_driving.h"

#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "posekit/core/error.h"

namespace posekit {
namespace {

/// R = swing * twist, the twist about the unit axis `a` (the swing moves `a`, the twist keeps it).
void swing_twist(const Eigen::Matrix3d& R, const Eigen::Vector3d& a, Eigen::Vector3d* swing, Eigen::Vector3d* twist) {
  const Eigen::Quaterniond q(R);
  const double along = q.vec().dot(a);
  Eigen::Quaterniond t(q.w(), along * a.x(), along * a.y(), along * a.z());
  if (t.norm() < 1e-12) {
    t = Eigen::Quaterniond::Identity();  // a half turn about an axis perpendicular to a: all swing
  } else {
    t.normalize();
  }
  *twist = axis_angle_from_rotation(t.toRotationMatrix());
  *swing = axis_angle_from_rotation((q * t.conjugate()).toRotationMatrix());
}

int bone(const Rig& rig, const std::string& name) {
  const int b = rig.find_bone(name);
  if (b < 0) throw InvalidInput("anatomical driving: the rig has no bone '" + name + "' (expected the MakeHuman default rig)");
  return b;
}

/// Spreads the chain's rotation R (last bone's world relative to the chain's parent) over its bones:
/// bone i gets swing^f_i twist^g_i, the last bone the remainder, so the product is exactly R.
void spread(BonePose* out, const std::vector<int>& chain, const Eigen::Matrix3d& R, const Eigen::Vector3d& axis,
            const double* swing_fraction, const double* twist_fraction) {
  Eigen::Vector3d swing, twist;
  swing_twist(R, axis, &swing, &twist);
  Eigen::Matrix3d done = Eigen::Matrix3d::Identity();
  for (size_t i = 0; i + 1 < chain.size(); ++i) {
    const Eigen::Matrix3d local = rotation_from_axis_angle(swing_fraction[i] * swing) * rotation_from_axis_angle(twist_fraction[i] * twist);
    out->local[static_cast<size_t>(chain[i])] = local;
    done = done * local;
  }
  out->local[static_cast<size_t>(chain.back())] = done.transpose() * R;
}

Eigen::Vector3d direction(const Body& body, int from_bone, int to_bone) {
  const Eigen::Vector3d d = (body.bone_heads.row(to_bone) - body.bone_heads.row(from_bone)).transpose();
  return d.norm() > 1e-9 ? Eigen::Vector3d(d.normalized()) : Eigen::Vector3d::UnitY();
}

}  // namespace

const char* const kDrivingNames = "rig, anatomical or anatomical-alternative";

bool is_driving_name(const std::string& name) { return name == "rig" || name == "anatomical" || name == "anatomical-alternative"; }

std::optional<AnatomicalDriving> anatomical_driving_by_name(const std::string& name, const std::string& context) {
  if (!is_driving_name(name)) throw InvalidInput(context + ": unknown driving '" + name + "' (expected " + kDrivingNames + ")");
  if (name == "rig") return std::nullopt;
  if (name == "anatomical") return AnatomicalDriving{};
  return AnatomicalDriving::alternative();
}

AnatomicalDriving AnatomicalDriving::alternative() {
  AnatomicalDriving d;
  d.name = "anatomical-alternative";
  d.girdle_share = 0.25;
  d.clavicle_share = 0.7;
  d.lumbar_swing = {0.5, 0.3, 0.2};
  d.lumbar_twist = {0.1, 0.3, 0.6};
  d.thoracic_swing = {0.4, 0.6};
  d.thoracic_twist = {0.6, 0.4};
  d.neck_swing = {0.25, 0.25, 0.25, 0.25};
  d.neck_twist = {0.15, 0.15, 0.2, 0.5};
  d.upper_arm_twist_proximal = 0.4;
  d.thigh_twist_proximal = 0.6;
  d.forearm_pronation = 0.75;
  d.dual_quaternion = false;
  return d;
}

BonePose anatomical_bone_pose(const Rig& rig, const Body& body, const PartPose& pose, const AnatomicalDriving& d) {
  const auto roots = part_root_bones(rig);
  BonePose out = BonePose::identity(rig.num_bones());
  out.local[static_cast<size_t>(roots[kPelvis])] = rotation_from_axis_angle(pose.root_rotation);
  out.root_translation = pose.root_translation;
  auto R = [&](const char* joint) { return rotation_from_axis_angle(pose.joint(find_joint_index(joint))); };

  // Spine and neck.
  const int s5 = bone(rig, "spine05"), s4 = bone(rig, "spine04"), s3 = bone(rig, "spine03"), s2 = bone(rig, "spine02"),
            s1 = bone(rig, "spine01"), n1 = bone(rig, "neck01"), n2 = bone(rig, "neck02"), n3 = bone(rig, "neck03"),
            head = bone(rig, "head");
  spread(&out, {s5, s4, s3}, R("lower_back"), direction(body, s5, s2), d.lumbar_swing.data(), d.lumbar_twist.data());
  spread(&out, {s2, s1}, R("upper_back"), direction(body, s2, n1), d.thoracic_swing.data(), d.thoracic_twist.data());
  const Eigen::Vector3d neck_axis = [&] {
    const Eigen::Vector3d v = (body.bone_tails.row(head) - body.bone_heads.row(n1)).transpose();
    return v.norm() > 1e-9 ? Eigen::Vector3d(v.normalized()) : Eigen::Vector3d::UnitY();
  }();
  spread(&out, {n1, n2, n3, head}, R("neck"), neck_axis, d.neck_swing.data(), d.neck_twist.data());

  for (const char* side : {"L", "R"}) {
    const std::string s = side;
    const bool left = s == "L";
    // Arm: girdle, glenohumeral joint, twist along the humerus; elbow; pronation along the forearm.
    const int clavicle = bone(rig, "clavicle." + s), scapula = bone(rig, "shoulder01." + s), ua1 = bone(rig, "upperarm01." + s),
              ua2 = bone(rig, "upperarm02." + s), la1 = bone(rig, "lowerarm01." + s), la2 = bone(rig, "lowerarm02." + s),
              wrist = bone(rig, "wrist." + s);
    const double girdle = d.girdle_share;
    const double arm_swing[4] = {girdle * d.clavicle_share, girdle * (1 - d.clavicle_share), 1 - girdle, 0};
    const double arm_twist[4] = {0, 0, d.upper_arm_twist_proximal, 1 - d.upper_arm_twist_proximal};
    spread(&out, {clavicle, scapula, ua1, ua2}, R(left ? "left_shoulder" : "right_shoulder"), direction(body, ua1, la1), arm_swing,
           arm_twist);
    out.local[static_cast<size_t>(la1)] = R(left ? "left_elbow" : "right_elbow");
    const double wrist_swing[2] = {0, 1}, wrist_twist[2] = {d.forearm_pronation, 1 - d.forearm_pronation};
    spread(&out, {la2, wrist}, R(left ? "left_wrist" : "right_wrist"), direction(body, la1, wrist), wrist_swing, wrist_twist);
    // Leg: the femur's twist over both thigh bones; knee and ankle as hinges of their parts.
    const int ul1 = bone(rig, "upperleg01." + s), ul2 = bone(rig, "upperleg02." + s), ll1 = bone(rig, "lowerleg01." + s),
              foot = bone(rig, "foot." + s);
    const double leg_swing[2] = {1, 0}, leg_twist[2] = {d.thigh_twist_proximal, 1 - d.thigh_twist_proximal};
    spread(&out, {ul1, ul2}, R(left ? "left_hip" : "right_hip"), direction(body, ul1, ll1), leg_swing, leg_twist);
    out.local[static_cast<size_t>(ll1)] = R(left ? "left_knee" : "right_knee");
    out.local[static_cast<size_t>(foot)] = R(left ? "left_ankle" : "right_ankle");
  }
  return out;
}

}  // namespace posekit
