#include "posekit/body/subjects.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <mutex>
#include <random>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/parallel.h"
#include "posekit/core/profile.h"

namespace posekit {
namespace {

const char* kVariationModifiers[] = {
    "measure/measure-neck-circ-decr|incr",       "measure/measure-shoulder-dist-decr|incr",   "measure/measure-napetowaist-dist-decr|incr",
    "measure/measure-waisttohip-dist-decr|incr", "measure/measure-upperleg-height-decr|incr", "measure/measure-lowerleg-height-decr|incr",
    "measure/measure-calf-circ-decr|incr",       "measure/measure-frontchest-dist-decr|incr", "measure/measure-upperarm-length-decr|incr",
    "measure/measure-lowerarm-length-decr|incr", "measure/measure-bust-circ-decr|incr",       "measure/measure-hips-circ-decr|incr",
    "buttocks/buttocks-volume-decr|incr"};

/// Fat added beyond the weight slider per unit of fatness above 1, and taken away below 0.
const std::pair<const char*, double> kFatModifiers[] = {
    {"measure/measure-waist-circ-decr|incr", 0.9},    {"measure/measure-hips-circ-decr|incr", 0.7},
    {"measure/measure-bust-circ-decr|incr", 0.6},     {"measure/measure-thigh-circ-decr|incr", 0.7},
    {"measure/measure-upperarm-circ-decr|incr", 0.6}, {"stomach/stomach-pregnant-decr|incr", 0.5},
    {"torso/torso-scale-depth-decr|incr", 0.4},       {"torso/torso-scale-horiz-decr|incr", 0.3},
    {"hip/hip-scale-horiz-decr|incr", 0.3},           {"measure/measure-calf-circ-decr|incr", 0.4},
    {"measure/measure-neck-circ-decr|incr", 0.4},     {"buttocks/buttocks-volume-decr|incr", 0.4}};
constexpr double kMinFatness = -1.0, kMaxFatness = 3.0;

/// fatness < 0: weight 0 and thinner; 0..1: the weight slider; > 1: weight 1 and fatter.
BodySpec with_fatness(BodySpec s, double fatness) {
  s.weight = std::clamp(fatness, 0.0, 1.0);
  const double extra = fatness > 1.0 ? fatness - 1.0 : std::min(fatness, 0.0);
  if (extra != 0.0)
    for (const auto& [name, per_unit] : kFatModifiers) {
      double& v = s.modifiers[name];
      v = std::clamp(v + per_unit * extra, -1.0, 1.0);
    }
  return s;
}

/// Height, muscle, proportions, ethnic mix and the local variation modifiers, drawn at random.
BodySpec random_sliders(double gender, std::mt19937& rng) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  BodySpec b;
  b.gender = gender;
  b.height = 0.3 + 0.35 * u(rng);
  b.muscle = 0.3 + 0.4 * u(rng);
  b.proportions = 0.35 + 0.3 * u(rng);
  b.african = u(rng);
  b.asian = u(rng);
  b.caucasian = 0.2 + 0.8 * u(rng);
  for (const char* m : kVariationModifiers) b.modifiers[m] = std::round((u(rng) * 0.8 - 0.4) * 1000) / 1000;
  return b;
}

/// Centre of the torso section at height y, from the spine joints.
Eigen::Vector3d torso_centre(const Eigen::MatrixXd& J, double y) {
  const int a = find_joint_index("lower_back"), b = find_joint_index("upper_back"), c = find_joint_index("neck");
  const Eigen::Vector3d pa = J.row(a), pb = J.row(b), pc = J.row(c);
  Eigen::Vector3d p = y < pb.y() ? pa + (pb - pa) * std::clamp((y - pa.y()) / (pb.y() - pa.y()), -2.0, 1.0)
                                 : pb + (pc - pb) * std::clamp((y - pb.y()) / (pc.y() - pb.y()), 0.0, 1.0);
  p.y() = y;
  return p;
}

struct Section {
  double girth = 0;
  bool closed = false;
  Eigen::MatrixXd points;
};

/// The section of the smooth surface through the vertices (N: unit vertex normals), as measure_body
/// takes it.
Section section(const TriangleMesh& m, const Eigen::MatrixXd& N, const Eigen::Vector3d& normal, const Eigen::Vector3d& through,
                const Eigen::Vector3d& near) {
  const auto loops = slice_smooth_mesh(m.V, m.F, N, normal, normal.dot(through));
  const int k = nearest_loop(loops, near);
  Section s;
  if (k < 0) return s;
  s.closed = loops[k].closed;
  s.points = loops[k].points;
  s.girth = convex_hull_perimeter(s.points, normal);
  return s;
}

/// Point-in-polygon of (x, z) against a horizontal loop.
bool inside_xz(const Eigen::MatrixXd& loop, double x, double z) {
  bool in = false;
  for (Eigen::Index i = 0, j = loop.rows() - 1; i < loop.rows(); j = i++) {
    const double xi = loop(i, 0), zi = loop(i, 2), xj = loop(j, 0), zj = loop(j, 2);
    if ((zi > z) != (zj > z) && x < (xj - xi) * (z - zi) / (zj - zi) + xi) in = !in;
  }
  return in;
}

}  // namespace

const char* bmi_class_name(BmiClass c) {
  switch (c) {
    case BmiClass::kUnderweight:
      return "underweight";
    case BmiClass::kNormal:
      return "normal";
    case BmiClass::kOverweight:
      return "overweight";
    case BmiClass::kObese:
      return "obese";
  }
  return "";
}

BmiClass bmi_class_of(double bmi) {
  if (bmi < 18.5) return BmiClass::kUnderweight;
  if (bmi < 25) return BmiClass::kNormal;
  if (bmi < 30) return BmiClass::kOverweight;
  return BmiClass::kObese;
}

BodyStats body_stats(const TriangleMesh& body) {
  BodyStats s;
  s.stature_m = body.V.col(1).maxCoeff() - body.V.col(1).minCoeff();
  s.volume_litres = signed_volume(body.V, body.F) * 1000.0;
  s.mass_kg = s.volume_litres * kBodyDensityKgPerLitre;
  s.bmi = s.mass_kg / (s.stature_m * s.stature_m);
  return s;
}

namespace {

/// Subjects 0..count-1 of a seed; only those `wanted` accepts get their fatness bisected (the
/// others only draw from the generator, so that each subject is the same whichever are made).
template <class Wanted>
std::vector<SubjectSpec> subject_specs(const MakeHumanModel& model, unsigned seed, int count, Wanted wanted) {
  if (count < 1) throw InvalidInput("make_subject_specs: count must be positive");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double class_lo[] = {16.3, 20.0, 26.0, 31.0}, class_hi[] = {17.8, 23.5, 28.8, 35.0};
  std::vector<SubjectSpec> out;
  const int per_gender = (count + 1) / 2;
  for (int i = 0; i < count; ++i) {
    SubjectSpec s;
    s.female = i < per_gender;
    const int k = s.female ? i : i - per_gender;
    s.id = std::string(s.female ? "f" : "m") + (k + 1 < 10 ? "0" : "") + std::to_string(k + 1);
    s.target_class = static_cast<BmiClass>((k * 4) / std::max(1, per_gender) % 4);
    const int c = static_cast<int>(s.target_class);
    s.target_bmi = class_lo[c] + (class_hi[c] - class_lo[c]) * u(rng);
    const BodySpec b = random_sliders(s.female ? 0.0 : 1.0, rng);
    if (!wanted(i)) continue;
    // Bisection on fatness: BMI grows with it.
    double lo = kMinFatness, hi = kMaxFatness;
    for (int it = 0; it < 32; ++it) {
      const double mid = 0.5 * (lo + hi);
      (body_stats(build_body(model, with_fatness(b, mid)).mesh).bmi < s.target_bmi ? lo : hi) = mid;
    }
    s.spec = body_spec_from_json(body_spec_to_json(with_fatness(b, 0.5 * (lo + hi))), "subject " + s.id);  // valid, as stored
    const double bmi = body_stats(build_body(model, s.spec).mesh).bmi;
    if (bmi_class_of(bmi) != s.target_class)
      throw InvalidInput("make_subject_specs: subject " + s.id + " reaches BMI " + std::to_string(bmi) + ", not the " +
                         bmi_class_name(s.target_class) + " target " + std::to_string(s.target_bmi));
    out.push_back(std::move(s));
  }
  return out;
}

}  // namespace

std::vector<SubjectSpec> make_subject_specs(const MakeHumanModel& model, unsigned seed, int count) {
  return subject_specs(model, seed, count, [](int) { return true; });
}

SubjectSpec make_subject_spec(const MakeHumanModel& model, unsigned seed, int index, int count) {
  if (index < 0 || index >= count)
    throw InvalidInput("make_subject_spec: subject " + std::to_string(index) + " is not one of " + std::to_string(count));
  return subject_specs(model, seed, count, [index](int i) { return i == index; }).front();
}

std::vector<BodySpec> make_calibration_specs(unsigned seed, int count) {
  if (count < 0) throw InvalidInput("make_calibration_specs: count must not be negative");
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<BodySpec> out;
  for (int i = 0; i < count; ++i) {
    const double gender = i % 3 == 0 ? 0.0 : i % 3 == 1 ? 1.0 : u(rng);
    const double fatness = kMinFatness + (kMaxFatness - kMinFatness) * u(rng);
    out.push_back(with_fatness(random_sliders(gender, rng), fatness));
  }
  return out;
}

std::vector<Eigen::MatrixXd> make_population_bodies(const MakeHumanModel& model, const PopulationOptions& o, std::string* note) {
  if (o.count < 2) throw InvalidInput("make_population_bodies: at least 2 bodies are needed");
  std::vector<BodySpec> specs = make_calibration_specs(o.seed, o.count);
  if (!o.local_variation)
    for (BodySpec& s : specs)
      for (const char* m : kVariationModifiers) s.modifiers.erase(m);
  std::vector<Eigen::MatrixXd> bodies(specs.size());
  std::vector<char> kept(specs.size(), 0);
  std::mutex progress_mutex;
  int done = 0;
  parallel_for_ranges(
      static_cast<long>(specs.size()), o.threads,
      [&](long begin, long end) {
        for (long i = begin; i < end; ++i) {
          const size_t k = static_cast<size_t>(i);
          Body body = build_body(model, specs[k]);
          kept[k] = !o.keep || o.keep(specs[k], body.mesh);
          if (kept[k]) bodies[k] = std::move(body.mesh.V);
          if (o.progress) {
            const std::lock_guard<std::mutex> lock(progress_mutex);
            o.progress(++done, static_cast<int>(specs.size()));
          }
        }
      },
      1);
  std::vector<Eigen::MatrixXd> out;
  for (size_t k = 0; k < bodies.size(); ++k)
    if (kept[k]) out.push_back(std::move(bodies[k]));
  if (note) {
    *note = std::to_string(out.size()) + " MakeHuman bodies (make_calibration_specs(" + std::to_string(o.seed) + ", " +
            std::to_string(o.count) + ")" + (o.local_variation ? "" : ", without the measure modifiers") + ")";
    if (!o.keep_note.empty()) *note += ", " + o.keep_note;
  }
  return out;
}

Measurements measure_makehuman_body(const MakeHumanModel& model, const Body& body) {
  const TriangleMesh& m = body.mesh;
  const Eigen::MatrixXd N = vertex_normals(m.V, m.F);
  const Eigen::MatrixXd J = joint_centres(model.rig, body);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  Measurements r;
  r.stature = m.V.col(1).maxCoeff() - m.V.col(1).minCoeff();
  auto torso = [&](double y) { return section(m, N, up, Eigen::Vector3d(0, y, 0), torso_centre(J, y)); };
  const double lower_back = J(find_joint_index("lower_back"), 1), upper_back = J(find_joint_index("upper_back"), 1);
  const double shoulder = J(find_joint_index("left_shoulder"), 1);
  constexpr double kStep = 0.002;
  constexpr double kArmClearance = 0.005;  // m, as in find_body_features
  // Arms' separation: down from the shoulder joints, the first level (1 mm steps) from which on for
  // 1 cm the section through the upper arm's axis (shoulder to elbow joint) is not the torso's; then
  // on down, the level where that section first stands kArmClearance clear of the torso's.
  double arms_separate = shoulder;
  for (const char* side : {"left", "right"}) {
    const Eigen::Vector3d sh = J.row(find_joint_index(std::string(side) + "_shoulder")).transpose();
    const Eigen::Vector3d el = J.row(find_joint_index(std::string(side) + "_elbow")).transpose();
    std::vector<double> heights;
    for (double y = sh.y(); y > upper_back; y -= 0.001) heights.push_back(y);
    const auto sections = slice_mesh_stack(m.V, m.F, up, heights);
    std::vector<double> gap(heights.size(), 0.0);  // between arm and torso, 0 where they are one loop
    std::vector<bool> separate(heights.size());
    for (size_t k = 0; k < heights.size(); ++k) {
      const Eigen::Vector3d arm = sh + (el - sh) * ((heights[k] - sh.y()) / (el.y() - sh.y()));
      const int t = nearest_loop(sections[k], torso_centre(J, heights[k])), a = nearest_loop(sections[k], arm);
      separate[k] = t >= 0 && a >= 0 && t != a;
      if (separate[k]) gap[k] = loop_distance(sections[k][static_cast<size_t>(t)], sections[k][static_cast<size_t>(a)]);
    }
    size_t k = 0;
    while (k + 10 < heights.size() && !(separate[k] && separate[k + 5] && separate[k + 10])) ++k;
    if (k + 10 >= heights.size())
      throw InvalidInput("measure_makehuman_body: the " + std::string(side) + " arm never separates from the torso");
    // From there down, where the arm first stands 5 mm clear of the torso (between the 1 mm levels).
    double above_y = heights[k] + 0.001, above_gap = 0;
    while (k + 1 < heights.size() && gap[k] < kArmClearance) above_y = heights[k], above_gap = gap[k], ++k;
    if (gap[k] < kArmClearance)
      throw InvalidInput("measure_makehuman_body: the " + std::string(side) + " arm never stands clear of the torso");
    arms_separate = std::min(arms_separate, above_y + (heights[k] - above_y) * (kArmClearance - above_gap) / (gap[k] - above_gap));
  }
  r.arms_separate_height = arms_separate;
  // Bust: the fullest torso level between the upper back and 1 cm below the arms' separation; on
  // a flat chest, the centre of the span around it where the girth stays within 3 mm of the fullest,
  // weighted by how much fuller each level is (peak_centre).
  std::vector<double> ys, gs;
  for (double y = arms_separate - 0.01; y >= upper_back; y -= 0.001) ys.push_back(y);
  const auto band = slice_mesh_stack(m.V, m.F, up, ys);
  for (size_t k = 0; k < ys.size(); ++k) {
    const int loop = nearest_loop(band[k], torso_centre(J, ys[k]));
    gs.push_back(loop >= 0 && band[k][static_cast<size_t>(loop)].closed
                     ? convex_hull_perimeter(band[k][static_cast<size_t>(loop)].points, up)
                     : std::numeric_limits<double>::quiet_NaN());
  }
  size_t best = 0;
  for (size_t k = 1; k < gs.size(); ++k)
    if (gs[k] > gs[best] || std::isnan(gs[best])) best = k;
  if (gs.empty() || std::isnan(gs[best])) throw InvalidInput("measure_makehuman_body: no closed bust level found");
  // ys descends: the profile ascending for peak_centre.
  const double fullest = gs[best];
  std::reverse(ys.begin(), ys.end());
  std::reverse(gs.begin(), gs.end());
  r.bust_height = peak_centre(ys, gs, gs.size() - 1 - best, fullest - 0.003);
  // The girth: the fullest within 3 cm of that level, up to the band's end, in 1 mm steps.
  r.bust = 0;
  const double search_top = std::min(r.bust_height + 0.03, arms_separate - 0.01);
  for (double y = r.bust_height - 0.03;; y = std::min(y + 0.001, search_top)) {
    const Section s = torso(y);
    if (s.closed) r.bust = std::max(r.bust, s.girth);
    if (y >= search_top) break;
  }
  r.underbust = 1e9;
  for (double y = r.bust_height - 0.03; y >= r.bust_height - 0.12; y -= kStep) r.underbust = std::min(r.underbust, torso(y).girth);
  // Waist: the narrowest level between the lower back and the bust.
  r.waist = 1e9;
  for (double y = lower_back; y <= r.bust_height - 0.05; y += kStep) {
    const Section s = torso(y);
    if (s.closed && s.girth < r.waist) r.waist = s.girth, r.waist_height = y;
  }
  // Crotch: the lowest level whose section still encloses the body axis.
  // Down from the head of the rig's upperleg02 (at the crotch; the hip joint, upperleg01's head, is
  // at the femoral head 7-10 cm higher) to the last torso section enclosing the axis.
  const Eigen::Vector3d crotch_bone = body.bone_heads.row(model.rig.find_bone("upperleg02.L")).transpose();
  const Eigen::Vector3d axis = torso_centre(J, crotch_bone.y());
  r.crotch_height = crotch_bone.y();
  for (double y = crotch_bone.y(); y > crotch_bone.y() - 0.3; y -= kStep) {
    const Section s = torso(y);
    if (!s.closed || !inside_xz(s.points, axis.x(), axis.z())) break;
    r.crotch_height = y;
  }
  // Hip: the fullest level between the crotch and the lower back.
  for (double y = r.crotch_height + 0.02; y <= lower_back; y += kStep) {
    const Section s = torso(y);
    if (s.closed && s.girth > r.hip) r.hip = s.girth, r.hip_height = y;
  }
  // Thigh: the left leg 2 cm below the crotch.
  r.thigh = section(m, N, up, Eigen::Vector3d(0, r.crotch_height - 0.02, 0),
                    Eigen::Vector3d(crotch_bone.x(), r.crotch_height - 0.02, crotch_bone.z()))
                .girth;
  // Upper arm: perpendicular to the left upper arm, midway between shoulder and elbow.
  const Eigen::Vector3d sh = J.row(find_joint_index("left_shoulder")).transpose(), el = J.row(find_joint_index("left_elbow")).transpose();
  const Eigen::Vector3d mid = 0.5 * (sh + el);
  r.upper_arm = section(m, N, (el - sh).normalized(), mid, mid).girth;
  // Neck: perpendicular to the neck axis, a third of the way from its base to the head joint.
  const Eigen::Vector3d neck_base = J.row(find_joint_index("neck")).transpose();
  const Eigen::Vector3d head = body.bone_heads.row(model.rig.find_bone("head")).transpose();
  const Eigen::Vector3d neck_point = neck_base + (head - neck_base) / 3.0;
  r.neck = section(m, N, (head - neck_base).normalized(), neck_point, neck_point).girth;
  for (double g : {r.bust, r.underbust, r.waist, r.hip, r.thigh, r.upper_arm, r.neck})
    if (!(g > 0.05 && g < 3.0)) throw InvalidInput("measure_makehuman_body: a girth came out implausible (" + std::to_string(g) + " m)");
  return r;
}

}  // namespace posekit
