#include "posekit/datasets/robustness.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>

#include "json_helpers.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/pose_units.h"
#include "posekit/body/skinning.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/timer.h"
#include "posekit/datasets/remesh.h"
#include "posekit/datasets/scanner.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/shape/body_orientation.h"

namespace posekit {
using datasets_detail::kDeg;
using datasets_detail::vec;
namespace fs = std::filesystem;

namespace {

/// A body of the set in posekit's frame (Y up, facing +Z, metres) with its truth.
struct Sample {
  TriangleMesh mesh;
  Eigen::VectorXi triangle_part;  ///< rig label per triangle, -1 for added bits
  Eigen::MatrixXd joints;         ///< #joints x 3
  Measurements girths;            ///< the rig's measurements of this surface
  std::string girth_truth = "this pose";
  nlohmann::ordered_json facts = nlohmann::ordered_json::object();  ///< what was done, for the truth file
};

/// How a sample is written: file axes, unit, format; or as a booth scan.
struct FileForm {
  std::string up = "+Y", forward = "+Z";
  Unit unit = Unit::kMetre;
  std::string extension = "ply";
  bool scan = false;
};

const std::vector<RobustnessVariation> kVariations = {
    {"apose", "MakeHuman's rest A-pose, feet apart"},
    {"arms_close", "arms hanging 10-15 degrees from the vertical, close to the torso"},
    {"elbows_bent", "elbows anywhere from straight to bent 45 degrees"},
    {"fists", "fingers closed into fists"},
    {"feet_together", "ankles 10-13 cm apart"},
    {"feet_wide", "ankles about shoulder width apart"},
    {"thighs_touch", "a heavier version of the shape (weight slider >= 0.9), feet brought together until the thighs press together"},
    {"thighs_fused", "the same pressed 1 cm together, the thighs joined into one surface where they touch (a scan's reconstruction)"},
    {"torso_twist", "upper body twisted 10-20 degrees"},
    {"xup_mm_bent", "X up, millimetres, elbows bent 30-40 degrees, fists, feet apart (an X-up registration)"},
    {"zup", "Z up, facing -Y (metres, OBJ)"},
    {"facing_back_cm", "Y up, facing -Z, centimetres"},
    {"res_5k", "remeshed to about 5,000 vertices"},
    {"res_200k", "subdivided to about 210,000 vertices"},
    {"head_cut", "top 5-10% of the height cut off (an anonymised scan), hole left open"},
    {"no_head", "head cut off below the chin"},
    {"hands_cut", "hands cut off at the wrists, holes left open"},
    {"holes", "25 holes of 1-5 cm across"},
    {"noise", "vertices moved along the normal, 1 mm sigma, clipped at 3 mm"},
    {"components", "4 floating bits and 32 loose vertices beside the body"},
    {"scanner", "head cut, hands cut, soles open, 25 holes, 4 floating bits, 32 loose vertices, 1 mm noise"},
    {"scan_cloud", "a simulated 8-camera booth scan (points, mm): 1.5 mm noise, occlusion holes, outliers"},
    // Pose kinds (issue 44): what people do in front of a scanner or a camera, angles drawn at random.
    {"arms_touching", "a natural rest pose: arms 2-8 degrees from the vertical, touching the torso below the armpits"},
    {"hands_on_hips", "arms 35-45 degrees out and 10-20 back, elbows bent 90-110 degrees"},
    {"arms_crossed", "upper arms 40-50 degrees forward and in, elbows bent 110-130 degrees"},
    {"arms_overhead", "arms raised 150-170 degrees"},
    {"raised_knee", "left hip flexed 80-100 degrees, left knee 80-100"},
    {"lunge", "left hip flexed 50-70, knee 60-80; right hip extended 15-25, knee 20-40 degrees"},
    {"kneeling", "on both knees: knees flexed 85-95 degrees, thighs upright"},
    {"kneeling_one", "on the right knee: left hip and knee 85-95 degrees, right knee 85-95"},
    {"squatting", "hips flexed 100-120, knees 120-140, back 15-25 degrees forward, arms forward"},
    {"sitting_chair", "hips and knees flexed 85-95 degrees (no chair)"},
    {"sitting_floor", "hips flexed 85-95 degrees, knees 0-10, arms down"},
    {"bending_forward", "pelvis tipped 30-45 degrees forward over upright legs, back 20-30 more"},
    {"tilted", "the A-pose tilted 5-15 degrees about a random horizontal axis (a scanner's frame)"},
    {"random_pose",
     "each joint at random within a range of motion: arms 0-110 degrees out and -20-90 forward, elbows 0-120, "
     "hips -15-90 forward and 0-25 out, knees 0-100, back -10-30 forward and 15 twisted, neck -20-30"},
    // Booth scans of pose kinds (as scan_cloud): what a body scanner gives of people who do not hold
    // the scanning posture.
    {"scan_arms_touching", "arms_touching as a simulated booth scan (points, mm)"},
    {"scan_hands_on_hips", "hands_on_hips as a simulated booth scan (points, mm)"},
    {"scan_kneeling", "kneeling as a simulated booth scan (points, mm)"},
    {"scan_sitting_chair", "sitting_chair as a simulated booth scan (points, mm)"},
};

/// The pose kind of a variation: its name, or for a scan of a pose kind the name without "scan_".
std::string pose_kind_of(const std::string& v) { return v.rfind("scan_", 0) == 0 && v != "scan_cloud" ? v.substr(5) : v; }

Eigen::Vector3d joint(const Eigen::MatrixXd& J, const std::string& name) { return J.row(find_joint_index(name)).transpose(); }

/// Poses a shaped body by a 16-part pose and optional MakeHuman pose units (fingers), dual
/// quaternion skinning; the result carries the posed bone heads, so the rig measures it.
Body pose_body(const MakeHumanModel& model, const PoseUnits& units, const Body& body, const PartPose& pose,
               const std::vector<std::pair<std::string, double>>& unit_weights) {
  BonePose bones = bone_pose_from_part_pose(model.rig, pose);
  if (!unit_weights.empty()) {
    const BonePose extra = bone_pose_from_pose_units(model.rig, body, units, unit_weights);
    for (size_t b = 0; b < bones.local.size(); ++b) bones.local[b] = bones.local[b] * extra.local[b];
  }
  return skin_body(model, body, bones);
}

/// Rotation about the forward axis that brings each arm to `abduction` from the vertical.
void set_arm_abduction(const Eigen::MatrixXd& J, double abduction, PartPose* pose) {
  for (const char* side : {"left", "right"}) {
    const bool left = side[0] == 'l';
    const Eigen::Vector3d d = joint(J, std::string(side) + "_elbow") - joint(J, std::string(side) + "_shoulder");
    const double current = std::atan2(std::abs(d.x()), -d.y());
    const double turn = (left ? -1.0 : 1.0) * (current - abduction);
    pose->joint_rotation[find_joint_index(std::string(side) + "_shoulder")] = turn * Eigen::Vector3d::UnitZ();
  }
}

/// Hip rotations about the forward axis that put the ankle centres `separation` apart.
void set_ankle_separation(const Eigen::MatrixXd& J, double separation, PartPose* pose) {
  const double mid = 0.5 * (joint(J, "left_hip").x() + joint(J, "right_hip").x());
  for (const char* side : {"left", "right"}) {
    const bool left = side[0] == 'l';
    const double s = left ? 1.0 : -1.0;
    const Eigen::Vector3d hip = joint(J, std::string(side) + "_hip"), ankle = joint(J, std::string(side) + "_ankle");
    const double drop = hip.y() - ankle.y();
    const double now = std::atan2(s * (ankle.x() - hip.x()), drop);
    const double want = std::atan2(separation / 2 - s * (hip.x() - mid), drop);
    pose->joint_rotation[find_joint_index(std::string(side) + "_hip")] = s * (want - now) * Eigen::Vector3d::UnitZ();
  }
}

/// Elbow rotations in each arm's own bending plane that make the angle between upper arm and
/// forearm `flexion` (0: straight). MakeHuman's rest A-pose is bent about 45 degrees already.
void set_elbow_flexion(const Eigen::MatrixXd& J, double flexion, PartPose* pose) {
  for (const char* side : {"left", "right"}) {
    const std::string s(side);
    const Eigen::Vector3d upper = (joint(J, s + "_elbow") - joint(J, s + "_shoulder")).normalized();
    const Eigen::Vector3d fore = (joint(J, s + "_wrist") - joint(J, s + "_elbow")).normalized();
    const double rest = std::acos(std::clamp(upper.dot(fore), -1.0, 1.0));
    pose->joint_rotation[find_joint_index(s + "_elbow")] = (flexion - rest) * upper.cross(fore).normalized();
  }
}

/// The 16-part pose of a pose-kind variation, angles drawn from its ranges (flexion of hips and
/// shoulders forward is about -X, of knees about +X; Y up, facing +Z); none for another variation.
std::optional<PartPose> pose_kind(const std::string& v, const Eigen::MatrixXd& J, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  auto deg = [&](double lo, double hi) { return (lo + (hi - lo) * u(rng)) * kDeg; };
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Z = Eigen::Vector3d::UnitZ();
  PartPose p;
  auto set = [&](const char* joint, const Eigen::Vector3d& r) { p.joint(find_joint_index(joint)) = r; };
  if (v == "arms_touching") {
    set_arm_abduction(J, deg(2, 8), &p);
  } else if (v == "hands_on_hips") {
    set_arm_abduction(J, deg(35, 45), &p);
    const Eigen::Matrix3d back = rotation_from_axis_angle(deg(10, 20) * X);
    for (const char* side : {"left_shoulder", "right_shoulder"})
      set(side, axis_angle_from_rotation(back * rotation_from_axis_angle(p.joint(find_joint_index(side)))));
    set_elbow_flexion(J, deg(90, 110), &p);
  } else if (v == "arms_crossed") {
    const double fwd = deg(40, 50), in = deg(10, 20);
    set("left_shoulder", axis_angle_from_rotation(rotation_from_axis_angle(-fwd * X) * rotation_from_axis_angle(-in * Z)));
    set("right_shoulder", axis_angle_from_rotation(rotation_from_axis_angle(-fwd * X) * rotation_from_axis_angle(in * Z)));
    set_elbow_flexion(J, deg(110, 130), &p);
  } else if (v == "arms_overhead") {
    set_arm_abduction(J, deg(150, 170), &p);
  } else if (v == "raised_knee") {
    set("left_hip", -deg(80, 100) * X), set("left_knee", deg(80, 100) * X);
  } else if (v == "lunge") {
    set("left_hip", -deg(50, 70) * X), set("left_knee", deg(60, 80) * X);
    set("right_hip", deg(15, 25) * X), set("right_knee", deg(20, 40) * X);
  } else if (v == "kneeling") {
    set("left_knee", deg(85, 95) * X), set("right_knee", deg(85, 95) * X);
  } else if (v == "kneeling_one") {
    set("left_hip", -deg(85, 95) * X), set("left_knee", deg(85, 95) * X), set("right_knee", deg(85, 95) * X);
  } else if (v == "squatting") {
    set("left_hip", -deg(100, 120) * X), set("right_hip", -deg(100, 120) * X);
    set("left_knee", deg(120, 140) * X), set("right_knee", deg(120, 140) * X);
    set("lower_back", deg(15, 25) * X);
    set("left_shoulder", -deg(50, 70) * X), set("right_shoulder", -deg(50, 70) * X);
  } else if (v == "sitting_chair") {
    set("left_hip", -deg(85, 95) * X), set("right_hip", -deg(85, 95) * X);
    set("left_knee", deg(85, 95) * X), set("right_knee", deg(85, 95) * X);
  } else if (v == "sitting_floor") {
    set("left_hip", -deg(85, 95) * X), set("right_hip", -deg(85, 95) * X);
    set("left_knee", deg(0, 10) * X), set("right_knee", deg(0, 10) * X);
    set_arm_abduction(J, deg(15, 25), &p);
  } else if (v == "bending_forward") {
    const double tip = deg(30, 45);
    p.root_rotation = tip * X;
    set("left_hip", -tip * X), set("right_hip", -tip * X), set("lower_back", deg(20, 30) * X);
  } else if (v == "random_pose") {
    // Anatomical angles as the fit's library says them (abduction then flexion; hinge flexion), each
    // side on its own: no library pose but many of its neighbours.
    for (const double side : {1.0, -1.0}) {
      const std::string s = side > 0 ? "left_" : "right_";
      const Eigen::Vector3d d = joint(J, s + "elbow") - joint(J, s + "shoulder");
      const double rest = std::atan2(std::abs(d.x()), -d.y());
      set((s + "shoulder").c_str(), axis_angle_from_rotation(rotation_from_axis_angle(-deg(-20, 90) * X) *
                                                             rotation_from_axis_angle(side * (deg(0, 110) - rest) * Z)));
      set((s + "hip").c_str(),
          axis_angle_from_rotation(rotation_from_axis_angle(-deg(-15, 90) * X) * rotation_from_axis_angle(side * deg(0, 25) * Z)));
      set((s + "knee").c_str(), deg(0, 100) * X);
    }
    PartPose elbows;
    set_elbow_flexion(J, deg(0, 120), &elbows);  // (both sides alike; the other side's drawn next)
    const size_t left = static_cast<size_t>(find_joint_index("left_elbow")), right = static_cast<size_t>(find_joint_index("right_elbow"));
    p.joint_rotation[left] = elbows.joint_rotation[left];
    set_elbow_flexion(J, deg(0, 120), &elbows);
    p.joint_rotation[right] = elbows.joint_rotation[right];
    set("lower_back", axis_angle_from_rotation(rotation_from_axis_angle(deg(-10, 30) * X) *
                                               rotation_from_axis_angle(deg(-15, 15) * Eigen::Vector3d::UnitY())));
    set("neck", deg(-20, 30) * X);
  } else if (v == "tilted") {
    const double heading = deg(0, 360);
    p.root_rotation = deg(5, 15) * Eigen::Vector3d(std::cos(heading), 0, std::sin(heading));
  } else {
    return std::nullopt;
  }
  return p;
}

const std::vector<std::pair<std::string, double>> kFists = {
    {"Finger1CloseLeft", 0.8},  {"Finger2CloseLeft", 1.0},  {"Finger3CloseLeft", 1.0},  {"Finger4CloseLeft", 1.0},
    {"Finger5CloseLeft", 1.0},  {"Finger1CloseRight", 0.8}, {"Finger2CloseRight", 1.0}, {"Finger3CloseRight", 1.0},
    {"Finger4CloseRight", 1.0}, {"Finger5CloseRight", 1.0}};

/// The gap (m) between the thighs 4 cm below the crotch (the rig's upperleg02 heads): inner
/// surfaces' x (negative: they overlap).
double thigh_gap(const Rig& rig, const Body& body, const Eigen::MatrixXd& J) {
  const double y = 0.5 * (body.bone_heads(rig.find_bone("upperleg02.L"), 1) + body.bone_heads(rig.find_bone("upperleg02.R"), 1)) - 0.04;
  const double mid = 0.5 * (joint(J, "left_hip").x() + joint(J, "right_hip").x());
  const auto loops = slice_mesh(body.mesh.V, body.mesh.F, Eigen::Vector3d::UnitY(), y);
  double left_inner = 1e9, right_inner = -1e9;
  for (const auto& loop : loops) {
    const double cx = loop.points.col(0).mean();
    if (cx > mid) left_inner = std::min(left_inner, loop.points.col(0).minCoeff());
    else right_inner = std::max(right_inner, loop.points.col(0).maxCoeff());
  }
  return left_inner - right_inner;
}

/// Keeps the faces `keep` says; labels follow, unreferenced vertices stay (as in a raw scan).
void keep_faces(Sample* s, const std::vector<bool>& keep) {
  Eigen::Index n = 0;
  for (Eigen::Index f = 0; f < s->mesh.F.rows(); ++f)
    if (keep[static_cast<size_t>(f)]) {
      s->mesh.F.row(n) = s->mesh.F.row(f);
      s->triangle_part[n] = s->triangle_part[f];
      ++n;
    }
  s->mesh.F.conservativeResize(n, 3);
  s->triangle_part.conservativeResize(n);
}

/// Drops faces with a vertex for which `cut` is true; returns how many went.
template <class Cut>
long cut_faces(Sample* s, Cut cut) {
  std::vector<bool> keep(static_cast<size_t>(s->mesh.F.rows()), true);
  long removed = 0;
  for (Eigen::Index f = 0; f < s->mesh.F.rows(); ++f)
    for (int c = 0; c < 3 && keep[static_cast<size_t>(f)]; ++c)
      if (cut(s->mesh.V.row(s->mesh.F(f, c)).transpose())) keep[static_cast<size_t>(f)] = false, ++removed;
  keep_faces(s, keep);
  return removed;
}

void cut_head(Sample* s, double fraction_of_height) {
  const double top = s->mesh.V.col(1).maxCoeff(), floor = s->mesh.V.col(1).minCoeff();
  const double level = top - fraction_of_height * (top - floor);
  cut_faces(s, [&](const Eigen::Vector3d& v) { return v.y() > level; });
  s->facts["head_cut_at_y"] = level;
}

void cut_hands(Sample* s, std::mt19937* rng) {
  std::uniform_real_distribution<double> offset(-0.01, 0.015);
  for (const char* side : {"left", "right"}) {
    const Eigen::Vector3d wrist = joint(s->joints, std::string(side) + "_wrist");
    const Eigen::Vector3d dir = (wrist - joint(s->joints, std::string(side) + "_elbow")).normalized();
    const double at = offset(*rng);
    cut_faces(s, [&](const Eigen::Vector3d& v) { return (v - wrist).norm() < 0.3 && (v - wrist).dot(dir) > at; });
    s->facts[std::string(side) + "_hand_cut_beyond_wrist_m"] = at;
  }
}

void open_soles(Sample* s) {
  const double floor = s->mesh.V.col(1).minCoeff();
  const Eigen::MatrixXd N = face_normals(s->mesh.V, s->mesh.F);
  std::vector<bool> keep(static_cast<size_t>(s->mesh.F.rows()), true);
  for (Eigen::Index f = 0; f < s->mesh.F.rows(); ++f) {
    bool low = true;
    for (int c = 0; c < 3; ++c) low = low && s->mesh.V(s->mesh.F(f, c), 1) < floor + 0.012;
    keep[static_cast<size_t>(f)] = !(low && N(f, 1) < -0.5);
  }
  keep_faces(s, keep);
  s->facts["soles_open"] = true;
}

void punch_holes(Sample* s, int count, std::mt19937* rng) {
  const Eigen::MatrixXd C = face_centroids(s->mesh.V, s->mesh.F);
  const Eigen::VectorXd A = face_areas(s->mesh.V, s->mesh.F);
  std::discrete_distribution<Eigen::Index> pick(A.data(), A.data() + A.size());
  std::uniform_real_distribution<double> radius(0.005, 0.025);
  std::vector<bool> keep(static_cast<size_t>(s->mesh.F.rows()), true);
  for (int h = 0; h < count; ++h) {
    const Eigen::RowVector3d centre = C.row(pick(*rng));
    const double r = radius(*rng);
    for (Eigen::Index f = 0; f < C.rows(); ++f)
      if ((C.row(f) - centre).norm() < r) keep[static_cast<size_t>(f)] = false;
  }
  keep_faces(s, keep);
  s->facts["holes"] = count;
}

void add_noise(Sample* s, double sigma, std::mt19937* rng) {
  const Eigen::MatrixXd N = vertex_normals(s->mesh.V, s->mesh.F);
  std::normal_distribution<double> g(0.0, sigma);
  for (Eigen::Index v = 0; v < s->mesh.V.rows(); ++v) s->mesh.V.row(v) += std::clamp(g(*rng), -3 * sigma, 3 * sigma) * N.row(v);
  s->facts["noise_sigma_m"] = sigma;
}

/// Floating bits a booth picks up (a strap, a hair clump, the floor): small closed blobs 15-50 cm
/// from the body, and loose vertices (no face) near its surface.
void add_floating_bits(Sample* s, int blobs, int loose, std::mt19937* rng) {
  const BoundingBox box = bounding_box(s->mesh.V);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double t = (1 + std::sqrt(5.0)) / 2;
  Eigen::MatrixXd ico(12, 3);
  ico << -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, 0, 0, -1, t, 0, 1, t, 0, -1, -t, 0, 1, -t, t, 0, -1, t, 0, 1, -t, 0, -1, -t, 0, 1;
  ico.rowwise().normalize();
  Eigen::MatrixXi ico_f(20, 3);
  ico_f << 0, 11, 5, 0, 5, 1, 0, 1, 7, 0, 7, 10, 0, 10, 11, 1, 5, 9, 5, 11, 4, 11, 10, 2, 10, 7, 6, 7, 1, 8, 3, 9, 4, 3, 4, 2, 3, 2, 6, 3,
      6, 8, 3, 8, 9, 4, 9, 5, 2, 4, 11, 6, 2, 10, 8, 6, 7, 9, 8, 1;
  for (int b = 0; b < blobs; ++b) {
    const double r = 0.01 + 0.03 * u(*rng);
    const double angle = 2 * M_PI * u(*rng), away = 0.15 + 0.35 * u(*rng);
    const Eigen::Vector3d at(box.center().x() + (0.5 * box.extent().x() + away) * std::cos(angle),
                             box.min.y() + r + (box.extent().y() - 2 * r) * u(*rng),
                             box.center().z() + (0.5 * box.extent().z() + away) * std::sin(angle));
    const Eigen::Index base = s->mesh.V.rows();
    s->mesh.V.conservativeResize(base + 12, 3);
    s->mesh.V.bottomRows(12) = (r * ico).rowwise() + at.transpose();
    s->mesh.F.conservativeResize(s->mesh.F.rows() + 20, 3);
    s->mesh.F.bottomRows(20) = ico_f.array() + static_cast<int>(base);
    s->triangle_part.conservativeResize(s->triangle_part.size() + 20);
    s->triangle_part.tail(20).setConstant(-1);
  }
  std::uniform_int_distribution<Eigen::Index> vertex(0, s->mesh.V.rows() - 1);
  const Eigen::Index base = s->mesh.V.rows();
  s->mesh.V.conservativeResize(base + loose, 3);
  std::normal_distribution<double> jitter(0.0, 0.01);
  for (int k = 0; k < loose; ++k)
    s->mesh.V.row(base + k) = s->mesh.V.row(vertex(*rng)) + Eigen::RowVector3d(jitter(*rng), jitter(*rng), jitter(*rng));
  s->facts["floating_bits"] = blobs;
  s->facts["loose_vertices"] = loose;
}

/// The set's shapes: women, men and mixed, BMI about 15 to 40 (make_calibration_specs).
std::vector<BodySpec> robustness_shapes(unsigned seed, int count) { return make_calibration_specs(seed * 7919u + 20261123u, count); }

}  // namespace

const std::vector<RobustnessVariation>& robustness_variations() { return kVariations; }

namespace {

/// The variations asked for (all when `only` is empty); an unknown name is an error naming the known ones.
std::vector<RobustnessVariation> chosen_variations(const std::vector<std::string>& only) {
  for (const auto& name : only) {
    auto it = std::find_if(kVariations.begin(), kVariations.end(), [&](const RobustnessVariation& v) { return v.name == name; });
    if (it == kVariations.end()) {
      std::string known;
      for (const auto& v : kVariations) known += (known.empty() ? "" : ", ") + v.name;
      throw InvalidInput("robustness set: unknown variation '" + name + "' (known: " + known + ")");
    }
  }
  std::vector<RobustnessVariation> chosen;
  for (const auto& v : kVariations)
    if (only.empty() || std::find(only.begin(), only.end(), v.name) != only.end()) chosen.push_back(v);
  return chosen;
}

/// One shape of the set and its variations: the rest body, its joints and girths, and the draws
/// every variation takes in turn from the shape's own generator.
class ShapeVariations {
 public:
  ShapeVariations(const MakeHumanModel& model, const PoseUnits& units, const Eigen::VectorXi& rest_labels, const BodySpec& spec,
                  unsigned seed, const std::string& id)
      : model(model),
        units(units),
        rest_labels(rest_labels),
        spec(spec),
        rng(seed),
        rest(build_body(model, spec)),
        J(joint_centres(model.rig, rest)),
        stats(body_stats(rest.mesh)) {
    try {
      rest_girths = measure_makehuman_body(model, rest);
    } catch (const InvalidInput& e) {
      throw InvalidInput(std::string("robustness set: shape ") + id + ": the rig cannot measure its rest pose: " + e.what());
    }
    apose = sample_of(rest, {});
  }

  /// The shape under variation `v`, and how it is to be written.
  Sample vary(const std::string& v, FileForm* file_form) {
    FileForm& form = *file_form;
    Sample s;
    PartPose pose;
    if (v == "apose") {
      s = apose;
    } else if (v == "arms_close") {
      const double a = (10 + 5 * u(rng)) * kDeg;
      set_arm_abduction(J, a, &pose);
      s = posed(pose, {}, {{"arm_abduction_deg", a / kDeg}}, rest);
      // Arms this close can meet the torso below the bust, where the rig's measurement then
      // looks for it (2 of 10 shapes: an underbust read as the bust, 7-18 cm short). The torso's
      // girths are the standing body's with the arms away (ISO 8559-1), which these arms leave.
      s.girths = rest_girths;
      s.girth_truth = "rest pose (girths are measured with the arms away, ISO 8559-1)";
    } else if (v == "elbows_bent") {
      const double a = 45 * u(rng) * kDeg;
      set_elbow_flexion(J, a, &pose);
      s = posed(pose, {}, {{"elbow_flexion_deg", a / kDeg}}, rest);
    } else if (v == "fists") {
      s = posed(pose, kFists, {{"fists", true}}, rest);
    } else if (v == "feet_together") {
      const double d = 0.10 + 0.03 * u(rng);
      set_ankle_separation(J, d, &pose);
      s = posed(pose, {}, {{"ankle_separation_m", d}}, rest);
    } else if (v == "feet_wide") {
      const double d = (joint(J, "left_shoulder") - joint(J, "right_shoulder")).norm() * (0.9 + 0.2 * u(rng));
      set_ankle_separation(J, d, &pose);
      s = posed(pose, {}, {{"ankle_separation_m", d}}, rest);
    } else if (v == "thighs_touch") {
      s = thighs_pressed(0.003);
    } else if (v == "thighs_fused") {
      // As a scan's reconstruction joins them: the thighs pressed 1 cm into each other, the
      // surfaces inside the other removed and the two holes zipped into one seam (on the mesh
      // subdivided once, so the seam follows the contact curve within about 5 mm).
      const Sample pressed = thighs_pressed(0.01);
      s = pressed;
      std::vector<int> origin;
      // Between the knees and 2 cm below the crotch, where the thighs meet (the toes and lips that
      // touch stay as they are, and so does the groin's skin folding into itself).
      const Eigen::AlignedBox3d thighs(
          Eigen::Vector3d(-1, std::max(joint(pressed.joints, "left_knee").y(), joint(pressed.joints, "right_knee").y()), -1),
          Eigen::Vector3d(1, pressed.girths.crotch_height - 0.02, 1));
      s.mesh = fuse_interpenetrating_surfaces(subdivide_midpoints(pressed.mesh), thighs, &origin);
      s.triangle_part.resize(s.mesh.F.rows());
      for (Eigen::Index f = 0; f < s.mesh.F.rows(); ++f) s.triangle_part[f] = pressed.triangle_part[origin[static_cast<size_t>(f)] / 4];
    } else if (v == "torso_twist") {
      const double size = 10 + 10 * u(rng), side = u(rng) < 0.5 ? -1 : 1;  // drawn in this order
      const double a = size * kDeg * side;
      pose.joint_rotation[find_joint_index("upper_back")] = a * Eigen::Vector3d::UnitY();
      s = posed(pose, {}, {{"twist_deg", a / kDeg}}, rest);
    } else if (v == "xup_mm_bent") {
      const double a = (30 + 10 * u(rng)) * kDeg;
      set_elbow_flexion(J, a, &pose);
      set_ankle_separation(J, 0.30, &pose);
      s = posed(pose, kFists, {{"elbow_flexion_deg", a / kDeg}, {"fists", true}, {"ankle_separation_m", 0.30}}, rest);
      form.up = "+X";
      form.forward = "+Z";
      form.unit = Unit::kMillimetre;
    } else if (v == "zup") {
      s = apose;
      form.up = "+Z";
      form.forward = "-Y";
      form.extension = "obj";
    } else if (v == "facing_back_cm") {
      s = apose;
      form.forward = "-Z";
      form.unit = Unit::kCentimetre;
    } else if (v == "res_5k") {
      s = apose;
      SurfacePoints corr;
      s.mesh = remesh_body(apose.mesh, 5000, &corr);
      s.triangle_part.resize(s.mesh.F.rows());
      for (Eigen::Index f = 0; f < s.mesh.F.rows(); ++f) {
        const int a = apose.triangle_part[corr.face[s.mesh.F(f, 0)]], b = apose.triangle_part[corr.face[s.mesh.F(f, 1)]],
                  c = apose.triangle_part[corr.face[s.mesh.F(f, 2)]];
        s.triangle_part[f] = (b == c) ? b : a;
      }
    } else if (v == "res_200k") {
      s = apose;
      s.mesh = subdivide_midpoints(subdivide_midpoints(apose.mesh));
      s.triangle_part.resize(s.mesh.F.rows());
      for (Eigen::Index f = 0; f < s.mesh.F.rows(); ++f) s.triangle_part[f] = apose.triangle_part[f / 16];
    } else if (v == "head_cut") {
      s = apose;
      cut_head(&s, 0.05 + 0.05 * u(rng));
    } else if (v == "no_head") {
      s = apose;
      const double chin =
          joint(s.joints, "neck").y() + 0.45 * (rest.bone_heads(model.rig.find_bone("head"), 1) - joint(s.joints, "neck").y());
      const double top = s.mesh.V.col(1).maxCoeff(), floor = s.mesh.V.col(1).minCoeff();
      cut_head(&s, (top - chin) / (top - floor));
    } else if (v == "hands_cut") {
      s = apose;
      cut_hands(&s, &rng);
    } else if (v == "holes") {
      s = apose;
      punch_holes(&s, 25, &rng);
    } else if (v == "noise") {
      s = apose;
      add_noise(&s, 0.001, &rng);
    } else if (v == "components") {
      s = apose;
      add_floating_bits(&s, 4, 32, &rng);
    } else if (v == "scanner") {
      s = apose;
      cut_head(&s, 0.05 + 0.05 * u(rng));
      cut_hands(&s, &rng);
      open_soles(&s);
      punch_holes(&s, 25, &rng);
      add_noise(&s, 0.001, &rng);
      add_floating_bits(&s, 4, 32, &rng);
    } else if (v == "scan_cloud") {
      s = apose;
      form.scan = true;
    } else if (const auto kind = pose_kind(pose_kind_of(v), J, rng)) {
      s = posed(*kind, {}, {{"pose_kind", pose_kind_of(v)}, {"pose", nlohmann::ordered_json::parse(part_pose_to_json(*kind))}}, rest);
      form.scan = v != pose_kind_of(v);
      // Girths are the person's in the standing posture (ISO 8559-1): a horizontal tape round a
      // kneeling or sitting body, or round arms resting on the chest, is no girth of theirs.
      s.girths = apose.girths;
      s.girth_truth = "rest pose (girths are measured standing, ISO 8559-1)";
    }
    return s;
  }

  const BodyStats& rest_stats() const { return stats; }
  std::mt19937& generator() { return rng; }

 private:
  Sample sample_of(const Body& body, const nlohmann::ordered_json& facts) {
    Sample s;
    s.mesh = body.mesh;
    s.triangle_part = rest_labels;
    s.joints = joint_centres(model.rig, body);
    s.facts = facts;
    try {
      s.girths = measure_makehuman_body(model, body);
    } catch (const InvalidInput&) {  // arms never clear of the torso: torso girths from rest
      s.girths = rest_girths;
      s.girth_truth = "rest pose (the rig cannot measure this pose)";
    }
    return s;
  }
  Sample posed(const PartPose& pose, const std::vector<std::pair<std::string, double>>& fingers, const nlohmann::ordered_json& facts,
               const Body& base) {
    return sample_of(pose_body(model, units, base, pose, fingers), facts);
  }
  /// A heavier version of the shape, feet brought together (20 cm down to 8 cm between the ankles)
  /// until the thighs press `overlap` (m) into each other 4 cm below the crotch, as on heavy people.
  Sample thighs_pressed(double overlap) {
    BodySpec heavy = spec;
    heavy.weight = std::max(heavy.weight, 0.9);
    const Body body = build_body(model, heavy);
    const Eigen::MatrixXd HJ = joint_centres(model.rig, body);
    Body together;
    double d = 0.20, gap = 1;
    PartPose pose;
    for (double separation = 0.20; separation >= 0.08 - 1e-9; separation -= 0.02) {
      d = separation;
      pose = PartPose{};
      set_ankle_separation(HJ, d, &pose);
      together = pose_body(model, units, body, pose, {});
      gap = thigh_gap(model.rig, together, joint_centres(model.rig, together));
      if (gap < -overlap) break;
    }
    const BodyStats heavy_stats = body_stats(body.mesh);
    Sample pressed =
        sample_of(together, {{"weight_slider", heavy.weight}, {"bmi", heavy_stats.bmi}, {"ankle_separation_m", d}, {"thigh_gap_m", gap}});
    if (pressed.girth_truth != "this pose") pressed.girths = measure_makehuman_body(model, body);
    return pressed;
  }

  const MakeHumanModel& model;
  const PoseUnits& units;
  const Eigen::VectorXi& rest_labels;
  const BodySpec spec;
  std::mt19937 rng;
  std::uniform_real_distribution<double> u{0.0, 1.0};
  const Body rest;
  const Eigen::MatrixXd J;
  const BodyStats stats;
  Measurements rest_girths;
  Sample apose;
};

/// Writes one sample in its form (mesh file or simulated scan) and its truth file; returns the
/// manifest's entry.
nlohmann::ordered_json write_sample(const fs::path& tmp, const char* id, const std::string& v, FileForm form, Sample s,
                                    const BodySpec& spec, const BodyStats& stats, std::mt19937& rng) {
  const std::string name = std::string(id) + "_" + v;
  const std::string file = "bodies/" + name + "." + (form.scan ? "ply" : form.extension);
  const BodyOrientation orientation = orientation_from_axes(parse_axis(form.up), parse_axis(form.forward));
  // p_posekit = R p_file: rows p_file^T = p_posekit^T R.
  auto to_file = [&](const Eigen::MatrixXd& P) { return Eigen::MatrixXd(P * orientation.rotation); };
  if (form.scan) {
    ScannerOptions so;
    so.views_around = 8;
    so.seed = rng();
    SimulatedScan scan = simulate_scan(s.mesh, so);
    PointCloud cloud;
    cloud.P = to_file(scan.cloud.P);
    write_point_cloud((tmp / file).string(), cloud, {Unit::kMillimetre});
    s.facts["scan_points"] = cloud.P.rows();
    form.unit = Unit::kMillimetre;
  } else {
    TriangleMesh m;
    m.V = to_file(s.mesh.V);
    m.F = s.mesh.F;
    write_mesh((tmp / file).string(), m, {form.unit});
  }
  nlohmann::ordered_json truth;
  truth["format"] = "posekit robustness truth 1";
  truth["variation"] = v;
  truth["shape"] = id;
  truth["kind"] = form.scan ? "scan" : "mesh";
  truth["file"] = {{"path", file}, {"unit", unit_name(form.unit)}, {"up", form.up}, {"forward", form.forward}};
  truth["body"] = {{"gender", spec.gender}, {"weight", spec.weight}, {"bmi", stats.bmi}, {"stature_m", stats.stature_m}};
  truth["done"] = s.facts;
  truth["frame"] = "posekit (Y up, facing +Z, left +X), metres";
  for (int j = 0; j < kNumJoints; ++j) truth["joints"][joint_name(j)] = vec(s.joints.row(j).transpose());
  const Measurements& g = s.girths;
  truth["girths"] = {{"bust", g.bust},   {"underbust", g.underbust}, {"waist", g.waist}, {"hip", g.hip},
                     {"thigh", g.thigh}, {"upper_arm", g.upper_arm}, {"neck", g.neck}};
  truth["girths_from"] = s.girth_truth;
  truth["levels_y"] = {{"crotch", g.crotch_height}, {"hip", g.hip_height}, {"waist", g.waist_height}, {"bust", g.bust_height}};
  if (!form.scan) truth["triangle_part"] = std::vector<int>(s.triangle_part.data(), s.triangle_part.data() + s.triangle_part.size());
  const std::string truth_file = "truth/" + name + ".json";
  const std::string text = truth.dump() + "\n";
  write_file_atomically((tmp / truth_file).string(), [&](std::ostream& os) { os << text; }, false);
  return {{"name", name}, {"variation", v}, {"shape", id}, {"file", file}, {"truth", truth_file}};
}

}  // namespace

RobustnessSummary make_robustness_set(const std::string& out_dir, const RobustnessOptions& o) {
  const Stopwatch t0;
  const std::vector<RobustnessVariation> chosen = chosen_variations(o.only);
  if (o.shape_specs.empty() && o.shapes < 1) throw InvalidInput("robustness set: at least one shape is needed");

  RobustnessSummary r;
  write_folder_atomically(out_dir, o.force, [&](const std::string& tmp_folder) {
    const fs::path tmp(tmp_folder);
    create_folders((tmp / "bodies").string());
    create_folders((tmp / "truth").string());
    const auto model = load_makehuman_model(o.data_root);
    const PoseUnits units = read_pose_units(model->data_root + "/poseunits/body-poseunits.json");
    const Eigen::VectorXi rest_labels = triangle_part_labels(model->body_F, vertex_part_labels(*model));
    const int shapes = o.shape_specs.empty() ? o.shapes : static_cast<int>(o.shape_specs.size());
    const auto specs = o.shape_specs.empty() ? robustness_shapes(o.seed, o.shapes) : o.shape_specs;
    nlohmann::ordered_json bodies = nlohmann::ordered_json::array();
    const int total = shapes * static_cast<int>(chosen.size());
    int done = 0;
    for (int k = 0; k < shapes; ++k) {
      char id[16];
      std::snprintf(id, sizeof id, "s%02d", k + 1);
      const BodySpec& spec = specs[static_cast<size_t>(k)];
      ShapeVariations shape(*model, units, rest_labels, spec, o.seed * 1000003u + static_cast<unsigned>(k), id);
      for (const auto& variation : chosen) {
        FileForm form;
        Sample s = shape.vary(variation.name, &form);
        bodies.push_back(write_sample(tmp, id, variation.name, form, std::move(s), spec, shape.rest_stats(), shape.generator()));
        if (o.progress) o.progress(++done, total, bodies.back()["name"].get<std::string>());
      }
    }
    nlohmann::ordered_json manifest;
    manifest["format"] = "posekit robustness set 1";
    manifest["generator"] = {{"seed", o.seed},
                             {"shapes", shapes},
                             {"source", "MakeHuman CC0 assets (data root)"},
                             {"shapes_from", o.shape_specs.empty() ? "random MakeHuman sliders" : o.shapes_source},
                             {"posing", "163-bone rig, MakeHuman skinning weights, dual quaternion skinning"}};
    nlohmann::ordered_json vars = nlohmann::ordered_json::array();
    for (const auto& v : chosen) vars.push_back({{"name", v.name}, {"description", v.description}});
    manifest["variations"] = vars;
    manifest["bodies"] = bodies;
    const std::string text = manifest.dump(2) + "\n";
    write_file_atomically((tmp / "manifest.json").string(), [&](std::ostream& os) { os << text; }, false);
    r.bodies = total;
    r.shapes = shapes;
    r.variations = static_cast<int>(chosen.size());
  });
  r.seconds = t0.seconds();
  return r;
}

}  // namespace posekit
