#include "posekit/fitting/fitted_measurements.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <memory>
#include <set>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/point_grid.h"

namespace posekit {
namespace {

constexpr double kMaxGapDeg = 40;  ///< as the rule-based measurements: a wider gap is a hole, not a girth
/// The most of a girth's tape (degrees about its centre) the fitted body may stand in for where
/// other parts hide the target's surface: past a third the girth is more the model's than the
/// body's. Over the robustness set's 345 girths (10 shapes), with up to 100 degrees filled the error
/// stayed within 24 mm; a hip folded by bending forward, 125 degrees filled, came out 51 mm short.
constexpr int kMaxFilledDeg = 120;
/// The target's section is taken from points near (in the plane) the fitted body's section: within
/// this share of the section's radius, and 1.5 to 5 cm; it bounds how far the person's surface may
/// stand off the fitted body (a neck's must not reach the trapezius).
constexpr double kNearShareOfRadius = 0.25, kNearMin = 0.015, kNearMax = 0.05;
/// A girth is not taken where the target's section and the fitted body's, both posed, differ by
/// more than 3 cm or 5% (the worst agreeing ones on the robustness set's pose kinds: 2.1 cm; the
/// folded hips and thighs that took in other surface: 9-11 cm).
constexpr double kSectionMismatch[2] = {0.03, 0.05};
/// A part takes part in a girth when this share of the fitted section's vertices carry it.
constexpr double kPartShare = 0.1;
/// Both thighs raised at least this far (degrees) from hanging straight down: a seated (or squatting)
/// body, its thighs near the horizontal, about halfway between a stride's (under 30) and a seat's 90.
constexpr double kThighsRaisedDeg = 60;

/// Why the hip and thigh of a seated or squatting body are not given standing (empty when the body
/// is neither): a seat, or the calves, press them out of their standing shape, and the body model's
/// posing (skinning, no contact) does not. ANSUR II's 6,068 adults show how much for a seat: their
/// hip breadth sitting exceeds the standing one by 34 mm (men) and 45 mm (women) on average, 19-49
/// and 29-63 mm from the 10th to the 90th percentile, against 12 mm for a hip girth by ISO 20685-1.
std::string thighs_raised_reason(const BodyFit& fit) {
  const Eigen::Vector3d down = -fit.up.normalized();
  double least = 180;
  for (const std::string side : {"left_", "right_"}) {
    const Eigen::Vector3d thigh =
        (fit.joints.row(find_joint_index(side + "knee")) - fit.joints.row(find_joint_index(side + "hip"))).transpose().normalized();
    least = std::min(least, 180 / M_PI * std::acos(std::clamp(thigh.dot(down), -1.0, 1.0)));
  }
  if (least < kThighsRaisedDeg) return "";
  std::ostringstream why;
  why << std::fixed << std::setprecision(0) << "seated or squatting (both thighs " << least
      << " degrees or more from hanging): a seat or the calves press the hips and thighs out of their standing shape, "
         "which the body model's posing does not (ANSUR II: hip breadth sitting exceeds standing by 34 mm in men and "
         "45 mm in women on average); measure them standing (--json gives the girth as posed)";
  return why.str();
}

/// The chain a part belongs to: the spine (pelvis to head), or one limb.
int part_chain(int part) {
  if (part <= kHead) return 0;
  return 1 + (part - kLeftUpperArm) / 3;
}

/// A body stands when its hips, knees and back are each turned under this (degrees) from rest.
constexpr double kStandingJointDeg = 25;
/// A stance whose thighs' spread is within this (degrees) of the rest's is the rest's: the fit's
/// joint angles on standing bodies are about 1 degree off, and a hip's fullest level can jump
/// between the buttocks and the thighs' tops on a change that small (a tilted body's hip 13 mm off).
constexpr double kStanceDeg = 2;

/// The posture a girth is given in (ISO 8559-1 measures standing, the arms clear of the torso): a
/// body that stands, in its own stance (each thigh's spread from the pelvis, about the forward
/// axis: feet together or wide apart change a hip by up to 4 cm, and a tape on the person reads
/// that; see kStanceDeg), otherwise at rest; any other body (kneeling, sitting, bending, a knee raised) at rest.
/// The rest of the pose stays at rest: a fit's small errors in the back and the legs' other angles
/// (a tilted body's pelvis tipped 7 degrees) would move the levels the rules find. Returns whether
/// the body stands.
bool girth_posture(const PartPose& fitted, PartPose* posture) {
  *posture = PartPose();
  for (int part : {kAbdomen, kChest, kLeftThigh, kLeftShank, kRightThigh, kRightShank})
    if (fitted.joint(part - 1).norm() > kStandingJointDeg * M_PI / 180) return false;
  bool own_stance = false;
  for (int thigh : {kLeftThigh, kRightThigh}) own_stance = own_stance || std::abs(fitted.joint(thigh - 1).z()) > kStanceDeg * M_PI / 180;
  if (own_stance)
    for (int thigh : {kLeftThigh, kRightThigh}) posture->joint(thigh - 1).z() = fitted.joint(thigh - 1).z();
  return true;
}

/// Rigid motion of the rest points `rest` onto `posed` (rows), least squares (Kabsch).
Eigen::Isometry3d rigid_motion(const Eigen::MatrixXd& rest, const Eigen::MatrixXd& posed) {
  const Eigen::Matrix4d m = Eigen::umeyama(rest.transpose(), posed.transpose(), false);
  Eigen::Isometry3d a = Eigen::Isometry3d::Identity();
  a.linear() = m.topLeftCorner<3, 3>();
  a.translation() = m.topRightCorner<3, 1>();
  return a;
}

/// The motion of the fitted body near a rest point: Kabsch over its `k` nearest rest vertices.
Eigen::Isometry3d local_motion(const Eigen::MatrixXd& rest, const Eigen::MatrixXd& posed, const Eigen::Vector3d& p, int k = 40) {
  std::vector<std::pair<double, int>> d(static_cast<size_t>(rest.rows()));
  for (Eigen::Index v = 0; v < rest.rows(); ++v)
    d[static_cast<size_t>(v)] = {(rest.row(v).transpose() - p).squaredNorm(), static_cast<int>(v)};
  k = std::min<int>(k, static_cast<int>(d.size()));
  std::partial_sort(d.begin(), d.begin() + k, d.end());
  Eigen::MatrixXd a(k, 3), b(k, 3);
  for (int i = 0; i < k; ++i) a.row(i) = rest.row(d[static_cast<size_t>(i)].second), b.row(i) = posed.row(d[static_cast<size_t>(i)].second);
  return rigid_motion(a, b);
}

/// Largest angle (degrees) about `centre`, in the plane of normal n, that no point covers.
double largest_angular_gap(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& centre, const Eigen::Vector3d& n) {
  if (pts.size() < 2) return 360;
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  std::vector<double> a;
  for (const auto& p : pts) a.push_back(std::atan2((p - centre).dot(w), (p - centre).dot(u)));
  std::sort(a.begin(), a.end());
  double gap = a.front() + 2 * M_PI - a.back();
  for (size_t k = 1; k < a.size(); ++k) gap = std::max(gap, a[k] - a[k - 1]);
  return gap * 180 / M_PI;
}

/// A girth's plane carried from the fitted body in the girths' posture (`source`, where `g` was
/// measured) to the fitted pose in the target's frame.
struct CarriedSection {
  Eigen::Vector3d point, normal, centre;
  std::vector<Eigen::Vector3d> loop;  ///< the fitted body's section, posed (target frame)
  std::set<int> parts;                ///< the parts the target's section may take points of
  double near = kNearMax;             ///< m: how far from `loop` the target's section may lie
};

CarriedSection carry_section(const BodyModel& model, const Eigen::MatrixXd& source, const Eigen::MatrixXd& source_normals,
                             const PointGrid& source_grid, const Eigen::MatrixXd& posed, const Girth& g) {
  CarriedSection s;
  const auto loops = slice_smooth_mesh(source, model.faces(), source_normals, g.normal, g.normal.dot(g.point));
  const int k = nearest_loop(loops, g.point);
  if (k < 0) return s;
  const Eigen::MatrixXd& L = loops[static_cast<size_t>(k)].points;
  std::vector<int> ring;
  std::vector<int> count(kNumParts, 0);
  for (Eigen::Index i = 0; i < L.rows(); ++i) {
    double d2 = 0;
    const int v = source_grid.nearest(L.row(i).transpose(), &d2);
    ring.push_back(v);
    ++count[static_cast<size_t>(model.vertex_parts()[v])];
  }
  // The section's parts and their neighbours along the same chain: the label border between two of
  // them follows the fit's joint, not the person's skin (the neck's tape runs near the head/chest
  // border). A branch (the arms off the chest, the legs off the pelvis) is never taken in.
  for (int p = 0; p < kNumParts; ++p) {
    if (count[static_cast<size_t>(p)] < kPartShare * static_cast<double>(L.rows())) continue;
    s.parts.insert(p);
    for (int q = 0; q < kNumParts; ++q)
      if ((part_parent(q) == p || part_parent(p) == q) && part_chain(q) == part_chain(p)) s.parts.insert(q);
  }
  std::sort(ring.begin(), ring.end());
  ring.erase(std::unique(ring.begin(), ring.end()), ring.end());
  Eigen::MatrixXd a(static_cast<Eigen::Index>(ring.size()), 3), b(a.rows(), 3);
  for (size_t i = 0; i < ring.size(); ++i)
    a.row(static_cast<Eigen::Index>(i)) = source.row(ring[i]), b.row(static_cast<Eigen::Index>(i)) = posed.row(ring[i]);
  const Eigen::Isometry3d m = rigid_motion(a, b);
  s.point = m * g.point;
  s.normal = (m.linear() * g.normal).normalized();
  s.centre = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < L.rows(); ++i) {
    s.loop.push_back(m * Eigen::Vector3d(L.row(i).transpose()));
    s.centre += s.loop.back() / static_cast<double>(L.rows());
  }
  const double radius = g.value / (2 * M_PI);
  s.near = std::clamp(kNearShareOfRadius * radius, kNearMin, kNearMax);
  return s;
}

/// Whether q (in the plane) lies near the fitted body's section.
bool near_fitted_section(const CarriedSection& s, const Eigen::Vector3d& q) {
  for (const auto& p : s.loop)
    if ((p - q).squaredNorm() < s.near * s.near) return true;
  return false;
}

/// Sectors about the fitted section's centre where the target shows no surface of the girth's parts
/// but another part's (an arm resting on the chest): the fitted body's carried section stands in
/// there, as a tape would lie over the torso under the arm. Returns how many sectors were filled.
constexpr int kSectors = 72;
int fill_hidden_sectors(const CarriedSection& s, const std::vector<Eigen::Vector3d>& hidden, std::vector<Eigen::Vector3d>* pts) {
  const Eigen::Vector3d u = s.normal.unitOrthogonal(), w = s.normal.cross(u);
  auto sector = [&](const Eigen::Vector3d& p) {
    const double a = std::atan2((p - s.centre).dot(w), (p - s.centre).dot(u)) + M_PI;
    return std::min(kSectors - 1, static_cast<int>(a / (2 * M_PI) * kSectors));
  };
  std::vector<char> seen(kSectors, 0), hides(kSectors, 0), filled(kSectors, 0);
  for (const auto& p : *pts) seen[static_cast<size_t>(sector(p))] = 1;
  for (const auto& p : hidden) hides[static_cast<size_t>(sector(p))] = 1;
  for (const auto& q : s.loop) {
    const int k = sector(q);
    if (seen[static_cast<size_t>(k)] || !hides[static_cast<size_t>(k)]) continue;
    pts->push_back(q);
    filled[static_cast<size_t>(k)] = 1;
  }
  return static_cast<int>(std::count(filled.begin(), filled.end(), 1));
}

/// A surface whose points carry part labels: a mesh (F, unit vertex normals N) or a scan (F empty,
/// sectioned in slabs half_slab thick each side).
struct LabelledSurface {
  const Eigen::MatrixXd& P;
  const Eigen::MatrixXi& F;
  Eigen::MatrixXd N;
  const Eigen::VectorXi& part;
  double half_slab;
};

struct SectionGirth {
  bool measured = false;
  double value = 0;
  std::string note;
  Eigen::MatrixXd tape;  ///< the hull the tape follows
};

/// The girth of a surface in a carried section: its points of the girth's parts near the fitted
/// body's section, the fitted section standing in where another part hides them (an arm resting on
/// the chest, the other thigh); a hole is no girth.
SectionGirth girth_in_section(const LabelledSurface& surface, const CarriedSection& s) {
  auto allowed = [&](Eigen::Index i) { return s.parts.count(surface.part[i]) > 0; };
  const bool scan = surface.F.rows() == 0;
  std::vector<Eigen::Vector3d> pts, hidden;
  if (scan) {
    for (Eigen::Index i = 0; i < surface.P.rows(); ++i) {
      const Eigen::Vector3d q = surface.P.row(i).transpose();
      const double h = (q - s.point).dot(s.normal);
      if (std::abs(h) >= surface.half_slab) continue;
      const Eigen::Vector3d in_plane = q - h * s.normal;
      if (near_fitted_section(s, in_plane)) (allowed(i) ? pts : hidden).push_back(in_plane);
    }
  } else {
    const Eigen::MatrixXi& F = surface.F;
    std::vector<Eigen::Index> kept, other;
    for (Eigen::Index f = 0; f < F.rows(); ++f) (allowed(F(f, 0)) && allowed(F(f, 1)) && allowed(F(f, 2)) ? kept : other).push_back(f);
    for (auto [faces, out_points] : {std::pair{&kept, &pts}, std::pair{&other, &hidden}}) {
      Eigen::MatrixXi KF(static_cast<Eigen::Index>(faces->size()), 3);
      for (size_t k = 0; k < faces->size(); ++k) KF.row(static_cast<Eigen::Index>(k)) = F.row((*faces)[k]);
      for (const SectionLoop& loop : slice_smooth_mesh(surface.P, KF, surface.N, s.normal, s.normal.dot(s.point)))
        for (Eigen::Index i = 0; i < loop.points.rows(); ++i)
          if (near_fitted_section(s, loop.points.row(i).transpose())) out_points->push_back(loop.points.row(i).transpose());
    }
  }
  SectionGirth out;
  const int filled = fill_hidden_sectors(s, hidden, &pts);
  if (filled * 360 / kSectors > kMaxFilledDeg) {
    out.note = "other parts hide " + std::to_string(filled * 360 / kSectors) +
               " of its 360 degrees (the pose folds it): a tape over more than " + std::to_string(kMaxFilledDeg) +
               " of the fitted body would measure the model, not the body";
    return out;
  }
  Eigen::MatrixXd hull_points;
  if (scan) {
    const SectionLoop loop = section_from_planar_points(pts, s.normal, kMaxGapDeg);
    if (loop.points.rows() < 3 || !loop.closed) {
      out.note = pts.size() < 8 ? "no points of the target here" : "section not closed (a hole in the scan)";
      return out;
    }
    hull_points = loop.points;
  } else {
    if (pts.size() < 8 || largest_angular_gap(pts, s.centre, s.normal) >= kMaxGapDeg) {
      out.note = pts.size() < 8 ? "no surface of the target here" : "section not closed (a hole in the surface, or the pose folds it)";
      return out;
    }
    hull_points.resize(static_cast<Eigen::Index>(pts.size()), 3);
    for (size_t k = 0; k < pts.size(); ++k) hull_points.row(static_cast<Eigen::Index>(k)) = pts[k].transpose();
  }
  if (filled > 0)
    out.note = "the tape passes over the fitted body where another part hides the surface (" + std::to_string(filled * 360 / kSectors) +
               " degrees of the section)";
  out.value = convex_hull_perimeter(hull_points, s.normal);
  out.tape = convex_hull_loop(hull_points, s.normal);
  out.measured = true;
  return out;
}

/// Landmarks in the target's frame: the torso's at its girths' tape points (`target`), the others
/// carried from the fitted body at rest (`fitted`'s features) by the body's local motion.
std::vector<Landmark> carried_landmarks(const Eigen::MatrixXd& rest, const Eigen::MatrixXd& posed, const BodyMeasurements& fitted,
                                        const BodyMeasurements& target) {
  const BodyFeatures& f = fitted.features;
  auto carried = [&](const Eigen::Vector3d& p) { return local_motion(rest, posed, p) * p; };
  std::vector<Landmark> out = {
      {"neck_base", carried(f.neck_base)}, {"left_armpit", carried(f.armpit[kLeft])}, {"right_armpit", carried(f.armpit[kRight])}};
  for (const char* name : {"bust", "underbust", "waist", "hip"})
    if (const Girth* fitted_girth = fitted.find(name); fitted_girth && fitted_girth->measured)
      out.push_back({name, target.find(name)->point});
  out.push_back({"crotch", carried(f.crotch)});
  out.push_back({"left_knee", carried(f.knee[kLeft])});
  out.push_back({"left_ankle", carried(f.ankle[kLeft])});
  return out;
}

/// The fitted body in a posture the girths are given in: where the rules measured it.
struct MeasuredBody {
  Eigen::MatrixXd V, N;
  std::unique_ptr<PointGrid> grid;
  BodyMeasurements measured;
};

MeasuredBody measured_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, BodyMeasurements measured) {
  return {V, vertex_normals(V, F), std::make_unique<PointGrid>(V), std::move(measured)};
}

/// One girth of the target: `reference`, measured on `source`, carried to the fitted pose (fitted
/// posed: `fitted`), cut on the target's surface there, less the pose's change to the fitted body's
/// section. *as_posed: the target's section as posed (NaN when there is none).
Girth girth_on_target(const BodyModel& model, const MeasuredBody& source, const Girth& reference, const LabelledSurface& target,
                      const LabelledSurface& fitted, bool stands, double* as_posed) {
  *as_posed = std::numeric_limits<double>::quiet_NaN();
  Girth g;
  g.name = reference.name;
  if (!reference.measured) {
    g.note = "not measured on the fitted body: " + reference.note;
    return g;
  }
  CarriedSection s = carry_section(model, source.V, source.N, *source.grid, fitted.P, reference);
  // Standing, a tape round the pelvis goes round the tops of the thighs too (feet together, they
  // are the hip's sides; a thigh's section near the crotch takes in the other thigh where they
  // touch, as the rig's measurement does: over 90 standing bodies the thigh's error 3.6 mm against
  // 4.2 with the hip alone).
  if (stands && s.parts.count(kPelvis)) s.parts.insert({kLeftThigh, kRightThigh});
  if (s.loop.empty()) {
    g.note = "the fitted body has no section here";
    return g;
  }
  g.point = s.point;
  g.normal = s.normal;
  const SectionGirth on_target = girth_in_section(target, s);
  if (!on_target.measured) {
    g.note = on_target.note;
    return g;
  }
  // The girth standing: the pose's change of the section as the fitted body shows it (its section
  // here posed, against in the girths' posture) taken off the target's (an arm lowered onto the
  // chest flattens its sides; a sitting body's belly folds).
  const SectionGirth on_fitted = girth_in_section(fitted, s);
  *as_posed = on_target.value;
  if (!on_fitted.measured) {
    g.note = "the pose folds this section: the fitted body has no closed section here in this pose (measure it standing)";
    return g;
  }
  // The target's section must be the fitted body's, both posed: where they differ by more than
  // kSectionMismatch the section took in what is not the girth's (a folded hip, a thigh's labels
  // off), or the fit is off there.
  const double mismatch = on_target.value - on_fitted.value;
  if (std::abs(mismatch) > std::max(kSectionMismatch[0], kSectionMismatch[1] * on_fitted.value)) {
    std::ostringstream why;
    why << std::fixed << std::setprecision(1) << "the section on the target (" << 100 * on_target.value
        << " cm in this pose) differs from the fitted body's (" << 100 * on_fitted.value << " cm) by " << 100 * mismatch
        << " cm: the fit or its labels are off here";
    g.note = why.str();
    return g;
  }
  g.value = on_target.value - (on_fitted.value - reference.value);
  g.tape = on_target.tape;  // where the tape went on the target, as posed
  g.note = on_target.note;
  g.measured = true;
  return g;
}

}  // namespace

FittedMeasurements measure_by_body_fit(const BodyModel& model, const BodyFit& fit, const Eigen::MatrixXd& T, const Eigen::MatrixXi& F) {
  if (fit.target_part.rows() != T.rows())
    throw InvalidInput("measure_by_body_fit: the fit labels " + std::to_string(fit.target_part.rows()) + " points, the target has " +
                       std::to_string(T.rows()));
  if (fit.V.rows() != model.space().vertices())
    throw InvalidInput("measure_by_body_fit: the fit is not of this body model (" + std::to_string(fit.V.rows()) + " vertices)");
  const ShapedBody body(model, fit.coefficients);
  const Eigen::MatrixXd& rest = body.rest_vertices();
  FittedMeasurements out;
  try {
    out.fitted = measure_body(rest, model.faces());
  } catch (const InvalidInput& e) {
    throw InvalidInput(std::string("measure_by_body_fit: the fitted body cannot be measured at rest: ") + e.what());
  }
  LabelledSurface target{T, F, Eigen::MatrixXd(), fit.target_part, 0};
  if (F.rows() == 0) {
    // Point spacing from the fitted body's area and the target's points (a scan covers most of it).
    const double area = face_areas(fit.V, model.faces()).sum();
    target.half_slab = std::max(0.004, 0.5 * section_slab_thickness(std::sqrt(area / std::max<Eigen::Index>(1, T.rows()))));
  } else {
    target.N = vertex_normals(T, F);
  }
  const LabelledSurface fitted_posed{fit.V, model.faces(), vertex_normals(fit.V, model.faces()), model.vertex_parts(), 0};
  // The fitted body in the posture the girths are given in, measured there by the rules: its levels
  // (a hip's fullest level rises from the tops of spread thighs to the buttocks as the feet come
  // together) and its girths. At rest for a body that does not stand, and for a girth the rules
  // cannot take in the posture (a thigh pressed against the other).
  const MeasuredBody at_rest = measured_body(rest, model.faces(), out.fitted);
  PartPose posture;
  const bool stands = girth_posture(fit.pose, &posture);
  std::unique_ptr<MeasuredBody> in_posture;
  if (std::any_of(posture.joint_rotation.begin(), posture.joint_rotation.end(), [](const Eigen::Vector3d& r) { return !r.isZero(0); })) {
    Eigen::MatrixXd V;
    body.pose(posture, &V);
    try {
      in_posture = std::make_unique<MeasuredBody>(measured_body(V, model.faces(), measure_body(V, model.faces())));
    } catch (const InvalidInput&) {
    }
  }

  BodyMeasurements& m = out.target;
  m.stature = out.fitted.stature;
  m.stature_note = "the fitted body's, standing";
  m.features = out.fitted.features;
  for (const Girth& rest_girth : out.fitted.girths) {
    const Girth* posture_girth = in_posture ? in_posture->measured.find(rest_girth.name) : nullptr;
    const bool own = posture_girth && posture_girth->measured;
    double as_posed = 0;
    m.girths.push_back(
        girth_on_target(model, own ? *in_posture : at_rest, own ? *posture_girth : rest_girth, target, fitted_posed, stands, &as_posed));
    out.as_posed.push_back(as_posed);
  }
  const std::string raised = thighs_raised_reason(fit);
  std::vector<bool> seated(m.girths.size(), false);  // declined for the posture: the section as posed is the person's
  for (size_t k = 0; k < m.girths.size(); ++k) {
    Girth& g = m.girths[k];
    if (raised.empty() || (g.name != "hip" && g.name != "thigh") || !g.measured) continue;
    g.measured = false, g.note = raised, g.tape.resize(0, 3);
    seated[k] = true;
  }
  reject_implausible_girths(&m);
  for (size_t k = 0; k < m.girths.size(); ++k)
    if (!m.girths[k].measured && !seated[k]) out.as_posed[k] = std::numeric_limits<double>::quiet_NaN();  // no section of its own

  out.landmarks = carried_landmarks(rest, fit.V, out.fitted, m);
  return out;
}

}  // namespace posekit
