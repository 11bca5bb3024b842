#include "posekit/shape/body_features.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <limits>
#include <mutex>
#include <utility>

#include "bust_band.h"
#include "feature_constants.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/parallel.h"
#include "posekit/core/profile.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {
using shape_detail::kBustBelowArmpits;
using shape_detail::kBustPlateau;
using namespace shape_detail::fitted;
namespace {

/// A gap between joined thighs (thighs_apart): two thigh sections (at least kThighMinArea, centroids
/// within kThighMaxOffset of the axis; a forearm's is under 60 cm^2) below kJoinedThighsBelow of the height.
constexpr double kThighMinArea = 0.006, kThighMaxOffset = 0.2, kJoinedThighsBelow = 0.5;
constexpr double kStraddleRatio = 1.0 / 3;  ///< straddles(): shorter over longer side of the axis
constexpr double kBustBandStart = 0.62;     ///< of the crotch-to-armpit span
/// A section within 1 cm of the top wider round than this (m) is a cut, not a crown: a head of 10 cm
/// radius whose top 2 cm a booth's cameras do not see (a scan's crown) is under 0.38 m round there;
/// a head cut 5 cm down (an anonymised scan) is over 0.5 m. A mesh's cut is told by its opening.
constexpr double kCutTopGirth = 0.42;
/// Height where the arms separate over stature: 0.739 to 0.761 on the 10 bodies of the robustness
/// set (MakeHuman, women and men, BMI 15 to 40). Only used to estimate the stature of a body whose
/// head is cut, a stature then reported as not measured; the crotch (0.43 to 0.50) is too variable.
constexpr double kStatureFromArmsSeparate = 0.75;
constexpr double kCrotchOverStature = 0.465;  ///< the first, rougher estimate, before the arms are found
constexpr double kArmSectionArea = 1.5e-3;    ///< m^2: a thin adult upper arm's section is over 30 cm^2, an ear under 10
constexpr int kRefineSteps = 5;               ///< finer sections per step that place the arms' separation (the crotch: 4x)
constexpr double kArmClearance = 0.005;       ///< m: the arms separate where they stand this clear of the torso
constexpr int kArmClearanceSections = 8;      ///< sections below the armpit level searched for that clearance
constexpr double kWaistBandStart = 0.33;
constexpr double kWaistTieTolerance = 0.002;    ///< m of girth
constexpr double kKneeFraction = 0.563;         ///< knee joint between ankle joint and crotch
constexpr double kWristBand[2] = {0.48, 0.68};  ///< wrist between elbow and hand tip
/// refine_elbows: bend (degrees between upper arm and forearm) from which the first elbow estimate
/// starts to be kept, and is kept whole. Its kink is sure at MakeHuman's rest pose (36-47 degrees);
/// it drifts along nearly straight arms (6-17 cm off at 5-30 degrees).
constexpr double kElbowBendBlend[2] = {32, 42};
/// refine_elbows: the fit error (m RMS) an elbow one metre from kElbowPathFraction's place costs:
/// 10 cm off costs 5 mm RMS, so a 20-degree bend's kink outweighs it.
constexpr double kElbowPriorWeight = 0.05;
constexpr size_t kElbowFitHalfWidth = 6;         ///< arm sections each side of the kink in the elbow's fit
constexpr double kPalmFrom = 0.55;               ///< the palm lies beyond this fraction
constexpr double kWristBeyondNarrowest = 0.012;  ///< m, toward the hand (horizontal sections)
constexpr double kPalmGrowth = 1.15;             ///< the palm: a section this much fuller than the narrowest
constexpr double kForearmStep = 0.01;            ///< m between perpendicular forearm sections
/// m: the faces a forearm section is cut from lie this near the segment from the elbow to the hand's
/// tip (a forearm's radius is 3-5 cm, a palm with the thumb 6-8 cm; the sections' centres stray
/// a few cm from that segment where the wrist bends).
constexpr double kForearmSliceRadius = 0.15;

/// FeatureRegressors' records, each at the regression it stands for (nothing without a record).
void record_neck(const BodyFeatures& f, double widening_y, FeatureRegressors* r) {
  if (!r) return;
  r->neck = true;
  r->neck_inputs = {1.0, f.neck_y - widening_y, f.crown_y - widening_y, widening_y - f.crotch_y};
  r->neck_widening_y = widening_y;
  r->neck_base = f.neck_base;
}
void record_arm(int side, const Eigen::Vector3d& elbow_point, const Eigen::Vector3d& wrist_point, FeatureRegressors* r) {
  if (!r) return;
  r->arm[side] = true;
  r->elbow_point[side] = elbow_point, r->wrist_point[side] = wrist_point;
}
void record_shoulder(int side, const double (&inputs)[6], const Eigen::Vector3d& origin, FeatureRegressors* r) {
  if (!r) return;
  r->shoulder[side] = true;
  std::copy(inputs, inputs + 6, r->shoulder_inputs[side].begin());
  r->shoulder_origin[side] = origin;
}
void record_leg(int side, double fraction_y, double hollow_y, double leg_length, const Eigen::Vector3d& knee_point,
                const Eigen::Vector3d& ankle_point, FeatureRegressors* r) {
  if (!r) return;
  r->leg[side] = true;
  r->knee_fraction_y[side] = fraction_y, r->knee_hollow_y[side] = hollow_y, r->leg_length[side] = leg_length;
  r->knee_point[side] = knee_point, r->ankle_point[side] = ankle_point;
}
void record_hips(const BodyFeatures& f, double front, double back, const Eigen::Vector3d& lateral, const Eigen::Vector3d& forward,
                 FeatureRegressors* r) {
  if (!r) return;
  r->hips = true;
  r->hip_inputs = {1.0, f.stature, front, back};
  r->crotch = Eigen::Vector3d(f.crotch.x(), f.crotch_y, f.crotch.z());
  r->hip_lateral = lateral, r->hip_forward = forward;
}

/// A calibrated offset on the given side (the subject's left is +X).
Eigen::Vector3d offset_on(const double (&offset)[3], int side) {
  return Eigen::Vector3d(side == 0 ? offset[0] : -offset[0], offset[1], offset[2]);
}

/// Area-weighted centroid and area of a horizontal loop in the XZ plane.
struct LoopShape {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  double area = 0, girth = 0;
  double min_x = 0, max_x = 0;
};

/// Area, centroid and x-range of a horizontal loop; its girth (a convex hull) only when asked.
LoopShape shape_of(const SectionLoop& loop, bool with_girth = false) {
  LoopShape s;
  const Eigen::MatrixXd& P = loop.points;
  double a2 = 0, cx = 0, cz = 0;
  for (Eigen::Index i = 0, j = P.rows() - 1; i < P.rows(); j = i++) {
    const double cross = P(j, 0) * P(i, 2) - P(i, 0) * P(j, 2);
    a2 += cross;
    cx += (P(j, 0) + P(i, 0)) * cross;
    cz += (P(j, 2) + P(i, 2)) * cross;
  }
  s.area = std::abs(a2) / 2;
  if (std::abs(a2) > 1e-12) s.centroid = Eigen::Vector3d(cx / (3 * a2), P.col(1).mean(), cz / (3 * a2));
  else s.centroid = P.colwise().mean().transpose();
  if (with_girth) s.girth = convex_hull_perimeter(P, Eigen::Vector3d::UnitY());
  s.min_x = P.col(0).minCoeff();
  s.max_x = P.col(0).maxCoeff();
  return s;
}

/// The part of a closed horizontal loop on one side of the plane x = `x` (side +1: x >= it), clipped
/// along that plane: one thigh's share of a section through thighs joined into one surface.
SectionLoop half_loop(const SectionLoop& loop, double x, double side) {
  const Eigen::MatrixXd& P = loop.points;
  std::vector<Eigen::RowVector3d> out;
  for (Eigen::Index i = 0, j = P.rows() - 1; i < P.rows(); j = i++) {
    const double a = side * (P(j, 0) - x), b = side * (P(i, 0) - x);
    if ((a >= 0) != (b >= 0)) out.push_back(P.row(j) + (a / (a - b)) * (P.row(i) - P.row(j)));
    if (b >= 0) out.push_back(P.row(i));
  }
  SectionLoop half;
  half.closed = loop.closed;
  half.points.resize(static_cast<Eigen::Index>(out.size()), 3);
  for (size_t k = 0; k < out.size(); ++k) half.points.row(static_cast<Eigen::Index>(k)) = out[k];
  return half;
}

bool contains_xz(const SectionLoop& loop, double x, double z) {
  const Eigen::MatrixXd& P = loop.points;
  bool in = false;
  for (Eigen::Index i = 0, j = P.rows() - 1; i < P.rows(); j = i++)
    if ((P(i, 2) > z) != (P(j, 2) > z) && x < (P(j, 0) - P(i, 0)) * (z - P(i, 2)) / (P(j, 2) - P(i, 2)) + P(i, 0)) in = !in;
  return in;
}

/// A loop spanning x on both sides, the shorter side at least a third of the longer (the pelvis),
/// not one thigh pressed over the midline.
bool straddles(const LoopShape& s, double x) {
  const double a = x - s.min_x, b = s.max_x - x;
  return a > 0 && b > 0 && std::min(a, b) >= kStraddleRatio * std::max(a, b);
}

/// The two thighs apart (maybe pressed into each other, as a mesh's can be): a thigh-sized closed
/// loop each side of x and none that straddles it as the pelvis or joined thighs do.
bool thighs_apart(const std::vector<SectionLoop>& loops, double x) {
  bool left = false, right = false;
  for (const SectionLoop& loop : loops) {
    if (!loop.closed) continue;
    const LoopShape s = shape_of(loop);
    if (straddles(s, x)) return false;
    if (s.area < kThighMinArea || std::abs(s.centroid.x() - x) > kThighMaxOffset) continue;
    (s.centroid.x() > x ? left : right) = true;
  }
  return left && right;
}

/// Closed loops of a section larger than min_area, not counting loops nested inside another one
/// (cavities such as the inside of the mouth: they are holes of the outer section, not body parts).
int count_closed(const std::vector<SectionLoop>& loops, double min_area) {
  int n = 0;
  for (size_t i = 0; i < loops.size(); ++i) {
    if (!loops[i].closed || shape_of(loops[i]).area <= min_area) continue;
    bool nested = false;
    for (size_t j = 0; j < loops.size() && !nested; ++j)
      nested = j != i && loops[j].closed && contains_xz(loops[j], loops[i].points(0, 0), loops[i].points(0, 2));
    n += !nested;
  }
  return n;
}

/// Least-squares line through points (rows), as point + unit direction.
void fit_line(const std::vector<Eigen::Vector3d>& pts, Eigen::Vector3d* point, Eigen::Vector3d* dir) {
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& p : pts) mean += p;
  mean /= static_cast<double>(pts.size());
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(cov);
  *point = mean;
  *dir = es.eigenvectors().col(2);
}

double line_error(const std::vector<Eigen::Vector3d>& pts, size_t from, size_t to) {
  if (to - from < 2) return 0;
  std::vector<Eigen::Vector3d> sub(pts.begin() + static_cast<long>(from), pts.begin() + static_cast<long>(to));
  Eigen::Vector3d p, d;
  fit_line(sub, &p, &d);
  double e = 0;
  for (const auto& q : sub) e += ((q - p) - (q - p).dot(d) * d).squaredNorm();
  return e;
}

/// The vertex of the least-squares parabola through the points (t[i], v[i]) in *vertex; false
/// unless it opens downward (want_max) or upward.
bool parabola_vertex(const std::vector<double>& t, const std::vector<double>& v, bool want_max, double* vertex) {
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < t.size(); ++i) {
    const Eigen::Vector3d row(1, t[i], t[i] * t[i]);
    AtA += row * row.transpose();
    Atb += row * v[i];
  }
  const Eigen::Vector3d c = AtA.ldlt().solve(Atb);
  if (want_max ? !(c[2] < 0) : !(c[2] > 0)) return false;
  *vertex = -c[1] / (2 * c[2]);
  return true;
}

}  // namespace

SectionStack horizontal_sections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double step, int threads) {
  if (V.rows() == 0 || F.rows() == 0) throw InvalidInput("horizontal_sections: empty mesh");
  if (!(step > 0)) throw InvalidInput("horizontal_sections: step must be positive");
  SectionStack s;
  s.floor_y = V.col(1).minCoeff();
  s.top_y = V.col(1).maxCoeff();
  s.step = step;
  for (double y = s.floor_y + step / 2; y < s.top_y; y += step) s.y.push_back(y);
  s.loops = slice_mesh_stack(V, F, Eigen::Vector3d::UnitY(), s.y, threads);
  return s;
}

namespace {
void refine_elbows(BodyFeatures* features);
}  // namespace

void refine_wrists(const SectionAt& section, BodyFeatures* features, int threads, FeatureRegressors* regressors) {
  BodyFeatures& f = *features;
  // Each side's forearm followed from f as it is; the results are applied side by side afterwards.
  struct Followed {
    bool tried = false, palm = false;
    Eigen::Vector3d wrist = Eigen::Vector3d::Zero();
    Eigen::Vector3d narrowest = Eigen::Vector3d::Zero(), direction = Eigen::Vector3d::Zero();  ///< for the record
  };
  auto follow = [&](int side) {
    Followed out;
    if (!f.arm_found[side] || f.hand_cut[side]) return out;
    out.tried = true;
    const double reach = (f.hand_tip[side] - f.elbow[side]).norm();
    Eigen::Vector3d dir = (f.wrist[side] - f.elbow[side]).normalized(), at = f.elbow[side];
    std::vector<Eigen::Vector3d> centres, dirs;
    std::vector<double> girths;
    size_t narrowest = 0;
    bool palm = false;
    for (double s = 0; s < reach && !palm; s += kForearmStep) {
      const SectionLoop loop = section(at, dir);
      if (!loop.closed || loop.points.rows() < 3) break;
      const Eigen::Vector3d centre = loop.points.colwise().mean().transpose();
      if ((centre - at).norm() > 0.04) break;  // jumped to another part
      centres.push_back(centre);
      dirs.push_back(dir);
      girths.push_back(convex_hull_perimeter(loop.points, dir));
      if (girths.back() < girths[narrowest]) narrowest = girths.size() - 1;
      palm = s > 0.1 && girths.back() > kPalmGrowth * girths[narrowest];
      if (centres.size() >= 3) dir = (centre - centres[centres.size() - 3]).normalized();  // over 2 cm
      at = centre + kForearmStep * dir;
    }
    if (!palm) return out;
    out.palm = true;
    // Between sections: the vertex of the parabola through the narrowest and its neighbours.
    double shift = 0;
    if (narrowest > 0) {
      const double a = girths[narrowest - 1], b = girths[narrowest], c = girths[narrowest + 1], curvature = a - 2 * b + c;
      if (curvature > 1e-12) shift = std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5) * kForearmStep;
    }
    out.wrist = centres[narrowest] + (shift + kWristBeyondNarrowestSection) * dirs[narrowest];
    out.narrowest = centres[narrowest] + shift * dirs[narrowest], out.direction = dirs[narrowest];
    return out;
  };
  std::array<Followed, 2> followed;
  parallel_for_ranges(
      2, threads == 1 ? 1 : 2,
      [&](long begin, long end) {
        for (long side = begin; side < end; ++side) followed[static_cast<size_t>(side)] = follow(static_cast<int>(side));
      },
      1);
  for (int side : {kLeft, kRight}) {
    const Followed& r = followed[static_cast<size_t>(side)];
    if (!r.tried) continue;
    if (r.palm) f.wrist[side] = r.wrist;
    if (r.palm && regressors)
      regressors->forearm[side] = true, regressors->narrowest_forearm[side] = r.narrowest,
      regressors->forearm_direction[side] = r.direction;
    if (!r.palm)
      f.warnings.push_back(std::string("could not follow the ") + (side == kLeft ? "left" : "right") +
                           " forearm to the palm with perpendicular sections: its wrist comes from horizontal sections only");
  }
  refine_elbows(&f);
}

namespace {

/// Re-places each found elbow of a nearly straight arm: at the kink of a two-line fit to the arm
/// axis between the shoulder and the wrist, where the fit's RMS error plus a prior on where between
/// shoulder and wrist the elbow lies (kElbowPathFraction, kElbowPriorWeight) is least. A clearly
/// bent arm (over 42 degrees) keeps its elbow; between 32 and 42 degrees the two blend.
void refine_elbows(BodyFeatures* features) {
  BodyFeatures& f = *features;
  for (int side : {kLeft, kRight}) {
    const std::vector<Eigen::Vector3d>& axis = f.arm_axis[side];
    if (!f.arm_found[side] || axis.size() < 20) continue;
    // The axis from the armpit down to its point nearest the wrist.
    size_t end = 0;
    for (size_t k = 1; k < axis.size(); ++k)
      if ((axis[k] - f.wrist[side]).norm() < (axis[end] - f.wrist[side]).norm()) end = k;
    if (end < 12) continue;
    std::vector<double> cost(end + 1, std::numeric_limits<double>::max());
    size_t best = 0;
    for (size_t k = 4; k + 4 <= end; ++k) {
      const double rms = std::sqrt((line_error(axis, 0, k + 1) + line_error(axis, k, end + 1)) / static_cast<double>(end + 2));
      const Eigen::Vector3d elbow = axis[k] + offset_on(kElbowOffset, side);
      const double upper = (elbow - f.shoulder[side]).norm(), length = upper + (f.wrist[side] - elbow).norm();
      cost[k] = rms + kElbowPriorWeight * std::abs(upper - kElbowPathFraction * length);
      if (best == 0 || cost[k] < cost[best]) best = k;
    }
    if (best == 0) continue;
    // Between sections (about 1 cm apart along an A-pose arm): the vertex of a parabola through the
    // cost at the best section and kElbowFitHalfWidth / 2 each side.
    double at = static_cast<double>(best);
    const size_t half = kElbowFitHalfWidth / 2;
    if (best >= 4 + half && best + half + 4 <= end) {
      std::vector<double> t, v;
      for (size_t k = best - half; k <= best + half; ++k)
        t.push_back(static_cast<double>(k) - static_cast<double>(best)), v.push_back(cost[k]);
      double vertex = 0;
      if (parabola_vertex(t, v, false, &vertex)) at += std::clamp(vertex, -1.0, 1.0);
    }
    const size_t k = static_cast<size_t>(std::floor(at));
    const Eigen::Vector3d point = axis[k] + (at - static_cast<double>(k)) * (axis[std::min(k + 1, end)] - axis[k]);
    // A clearly bent arm keeps the kink of the whole arm's axis (find_body_features), a nearly
    // straight one takes this estimate; in between they blend, so that the elbow moves smoothly.
    // The bend is read at this estimate: a drifted first one can sit anywhere off the line.
    const Eigen::Vector3d elbow = point + offset_on(kElbowOffset, side);
    const Eigen::Vector3d upper = elbow - f.shoulder[side], lower = f.wrist[side] - elbow;
    const double bend = std::acos(std::clamp(upper.normalized().dot(lower.normalized()), -1.0, 1.0)) * 180 / M_PI;
    // A cut hand leaves that first kink fit (over 80% of the armpit-to-tip axis) short of the forearm.
    const double kept =
        f.hand_cut[side] ? 0.0 : std::clamp((bend - kElbowBendBlend[0]) / (kElbowBendBlend[1] - kElbowBendBlend[0]), 0.0, 1.0);
    f.elbow[side] = kept * f.elbow[side] + (1 - kept) * elbow;
  }
}

}  // namespace

TriangleMesh body_surface(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, std::string* note, std::vector<int>* vertex_map,
                          std::vector<int>* face_map, std::vector<std::vector<int>>* input_boundary, int threads) {
  FloatingBits bits;
  std::vector<int> vmap;
  TriangleMesh body;
  std::vector<std::vector<int>> loops, input_loops;
  // On a second thread the input's own boundary, in case floating bits are left out (else the
  // body's loops, renumbered, are the input's).
  const bool speculate = input_boundary && threads != 1;
  parallel_for_ranges(
      speculate ? 2 : 1, speculate ? 2 : 1,
      [&](long begin, long end) {
        for (long task = begin; task < end; ++task) {
          if (task == 1) {
            input_loops = boundary_loops(F);
            continue;
          }
          bits = find_floating_bits(V, F);
          TriangleMesh whole;
          whole.V = V;
          whole.F = F;
          body = extract_faces(whole, bits.keep_face, &vmap);
          loops = boundary_loops(body.F);
        }
      },
      1);
  if (face_map) {
    face_map->clear();
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      if (bits.keep_face[static_cast<size_t>(f)]) face_map->push_back(static_cast<int>(f));
  }
  // Holes: boundary loops follow the faces' half-edges a->b, so a cap triangle runs b->a.
  int filled = 0, too_big = 0;
  double largest = 0;
  std::vector<Eigen::RowVector3d> centres;
  std::vector<Eigen::Vector3i> caps;
  if (input_boundary) {
    if (body.F.rows() == F.rows()) {  // every face kept: the same loops, renumbered
      *input_boundary = loops;
      for (auto& loop : *input_boundary)
        for (int& v : loop) v = vmap[static_cast<size_t>(v)];
    } else {
      *input_boundary = speculate ? std::move(input_loops) : boundary_loops(F);
    }
  }
  for (const auto& loop : loops) {
    if (loop.size() < 3) continue;
    double length = 0;
    Eigen::RowVector3d centre = Eigen::RowVector3d::Zero();
    for (size_t k = 0; k < loop.size(); ++k) {
      length += (body.V.row(loop[k]) - body.V.row(loop[(k + 1) % loop.size()])).norm();
      centre += body.V.row(loop[k]);
    }
    if (length > kMaxFilledHole) {
      ++too_big;
      continue;
    }
    const int c = static_cast<int>(body.V.rows() + static_cast<Eigen::Index>(centres.size()));
    centres.push_back(centre / static_cast<double>(loop.size()));
    for (size_t k = 0; k < loop.size(); ++k) caps.emplace_back(loop[(k + 1) % loop.size()], loop[k], c);
    ++filled;
    largest = std::max(largest, length);
  }
  if (!caps.empty()) {
    const Eigen::Index nv = body.V.rows(), nf = body.F.rows();
    body.V.conservativeResize(nv + static_cast<Eigen::Index>(centres.size()), 3);
    for (size_t k = 0; k < centres.size(); ++k) body.V.row(nv + static_cast<Eigen::Index>(k)) = centres[k];
    body.F.conservativeResize(nf + static_cast<Eigen::Index>(caps.size()), 3);
    for (size_t k = 0; k < caps.size(); ++k) body.F.row(nf + static_cast<Eigen::Index>(k)) = caps[k].transpose();
    body.N.resize(0, 3);  // attributes of the fill's vertices are not known
    body.C.resize(0, 3);
    body.UV.resize(0, 2);
    body.vertex_scalars.clear();
    body.face_group.resize(0);
    vmap.resize(static_cast<size_t>(body.V.rows()), -1);
    if (face_map) face_map->resize(static_cast<size_t>(body.F.rows()), -1);
  }
  if (note) {
    *note = bits.bits ? bits.describe() : "";
    if (filled) {
      char text[200];
      std::snprintf(text, sizeof text, "closed %d hole%s (the largest %.0f cm round) to section across them", filled,
                    filled == 1 ? "" : "s", 100 * largest);
      *note += (note->empty() ? "" : "; ") + std::string(text);
    }
    if (too_big) *note += (note->empty() ? "" : "; ") + std::to_string(too_big) + " opening(s) over 80 cm round left open";
  }
  if (vertex_map) *vertex_map = std::move(vmap);
  return body;
}

BodyFeatures find_body_features(const Eigen::MatrixXd& V_in, const Eigen::MatrixXi& F_in) {
  return find_body_features(V_in, F_in, nullptr);
}

BodyFeatures find_body_features(const Eigen::MatrixXd& V_in, const Eigen::MatrixXi& F_in, TriangleMesh* surface_out, int threads,
                                FeatureRegressors* regressors) {
  std::string left_out;
  TriangleMesh owned;
  TriangleMesh& surface = surface_out ? *surface_out : owned;
  std::vector<std::vector<int>> input_boundary;
  surface = body_surface(V_in, F_in, &left_out, nullptr, nullptr, &input_boundary, threads);
  const Eigen::MatrixXd& V = surface.V;
  const Eigen::MatrixXi& F = surface.F;
  if (V.rows() == 0) throw InvalidInput("body features: the mesh has no faces");
  const BoundingBox box = bounding_box(V);
  // A cut head: an opening over 25 cm round within 6 cm of the top (its edge is jagged: a
  // scanner's or a cutter's, so the sections just under it are no clean ring).
  bool top_is_cut = false;
  std::vector<std::pair<double, Eigen::Vector3d>> openings;  // (length, centre)
  for (const auto& loop : input_boundary) {
    double length = 0, low = box.max.y();
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    for (size_t k = 0; k < loop.size(); ++k) {
      length += (V_in.row(loop[k]) - V_in.row(loop[(k + 1) % loop.size()])).norm();
      low = std::min(low, V_in(loop[k], 1));
      centre += V_in.row(loop[k]).transpose() / static_cast<double>(loop.size());
    }
    if (length > 0.25 && low > box.max.y() - 0.06) top_is_cut = true;
    openings.emplace_back(length, centre);
  }
  const double height = box.extent().y();
  if (height < 0.8 || height > 2.6)
    throw InvalidInput("body features: the mesh is " + std::to_string(height) +
                       " m tall along its up axis (posekit's Y): expected a standing human in metres (wrong unit, or up axis?)");
  if (box.extent().z() > height || box.extent().x() > 1.3 * height)
    throw InvalidInput(
        "body features: the mesh is wider than it is tall along its up axis (posekit's Y): expected a standing body, not a lying one "
        "(wrong --up?)");
  BodyFeatures f = find_body_features(
      horizontal_sections(V, F, kSectionStep, threads),
      [&](const std::vector<double>& heights) { return slice_mesh_stack(V, F, Eigen::Vector3d::UnitY(), heights, threads); }, top_is_cut,
      threads, regressors);
  // A hand cut off (a scan's wrists): the arm ends in an opening as big round as a wrist or
  // forearm (10 to 35 cm) within 5 cm of where it was followed to. The wrist is the cut's centre.
  // A hole in one hand (fingers lost) is no cut wrist: an opening that lies well beyond the other
  // arm's wrist, from its shoulder, while the other hand is whole, is left to the hole filling.
  std::vector<Eigen::Vector3d> cut_at[2];
  for (int side : {kLeft, kRight}) {
    if (!f.arm_found[side]) continue;
    for (const auto& [length, centre] : openings)
      if (length > 0.10 && length < 0.35 && (centre - f.hand_tip[side]).norm() < 0.05) cut_at[side].push_back(centre);
  }
  for (int side : {kLeft, kRight}) {
    const int other = 1 - side;
    const char* name = side == kLeft ? "left" : "right";
    for (const Eigen::Vector3d& centre : cut_at[side]) {
      if (f.arm_found[other] && cut_at[other].empty()) {
        const double reach = (centre - f.shoulder[side]).norm(), wrist_reach = (f.wrist[other] - f.shoulder[other]).norm();
        if (reach > 1.15 * wrist_reach) {
          f.warnings.push_back(std::string("an opening at the ") + name + " hand lies " +
                               std::to_string(static_cast<int>(std::lround(100 * (reach - wrist_reach)))) +
                               " cm beyond where the other arm's wrist is: a hole in the hand, not a cut wrist");
          continue;
        }
      }
      f.hand_cut[side] = true;
      f.wrist[side] = centre;
      f.warnings.push_back(std::string("the ") + name +
                           " hand is cut off (the arm ends in an opening): its wrist is placed at the cut's centre");
    }
  }
  // Forearm sections slice only the faces near each forearm and hand (within kForearmSliceRadius
  // of the segment from the elbow to the hand's tip, the reach of the sections' centres): the whole
  // mesh, about 60 times, would cost more than all the horizontal sections. Each side's faces are
  // picked on the thread that follows that forearm, at its first section.
  TriangleMesh arm[2];  // re-indexed, so that a section visits only the arm's vertices too
  std::once_flag arm_picked[2];
  const auto pick_arm = [&](int side) {
    const Eigen::Vector3d a = f.elbow[side], ab = f.hand_tip[side] - f.elbow[side];
    const double length2 = std::max(ab.squaredNorm(), 1e-12);
    std::vector<char> near(static_cast<size_t>(V.rows()));
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      const Eigen::Vector3d p = V.row(v).transpose() - a;
      const double t = std::clamp(p.dot(ab) / length2, 0.0, 1.0);
      near[static_cast<size_t>(v)] = (p - t * ab).squaredNorm() < kForearmSliceRadius * kForearmSliceRadius;
    }
    std::vector<bool> kept(static_cast<size_t>(F.rows()));
    for (Eigen::Index t = 0; t < F.rows(); ++t) kept[t] = near[F(t, 0)] || near[F(t, 1)] || near[F(t, 2)];
    TriangleMesh whole;
    whole.V = V;
    whole.F = F;
    arm[side] = extract_faces(whole, kept);
  };
  refine_wrists(
      [&](const Eigen::Vector3d& point, const Eigen::Vector3d& normal) {
        const int side = point.x() > f.axis_x ? kLeft : kRight;
        std::call_once(arm_picked[side], pick_arm, side);
        const TriangleMesh& part = arm[side];
        const auto loops = slice_mesh(part.V, part.F, normal, normal.dot(point));
        const int k = nearest_loop(loops, point);
        return k < 0 ? SectionLoop{} : loops[static_cast<size_t>(k)];
      },
      &f, threads, regressors);
  if (!left_out.empty()) f.warnings.insert(f.warnings.begin(), left_out);
  return f;
}

BodyFeatures find_body_features(const SectionStack& st, const HorizontalSectionsAt& sections_at, bool top_is_cut, int threads,
                                FeatureRegressors* regressors) {
  BodyFeatures f;
  f.floor_y = st.floor_y;
  f.top_y = f.crown_y = st.top_y;
  f.stature = st.top_y - st.floor_y;
  const int n = static_cast<int>(st.y.size());
  if (n < 20) throw InvalidInput("body features: too few sections (" + std::to_string(n) + ") for a standing body");
  double scale = f.stature;  // the body's height the fractions below refer to (estimated when the head is cut)
  auto level_at = [&](double fraction) { return std::clamp(static_cast<int>(fraction * scale / st.step), 0, n - 1); };
  // A cut top: the sections within 1 cm of it are a wide ring, not a crown.
  double top_girth = 0;
  for (int i = std::max(0, n - static_cast<int>(std::ceil(0.01 / st.step))); i < n; ++i)
    for (const auto& loop : st.loops[i])
      if (loop.points.rows() >= 3) top_girth = std::max(top_girth, convex_hull_perimeter(loop.points, Eigen::Vector3d::UnitY()));
  f.head_cut = top_is_cut || top_girth > kCutTopGirth;
  // Standing, not upside-down: the top 12% (head and neck) is one large section at nearly every
  // level, the bottom 12% (feet and shins) never is.
  auto single_fraction = [&](double from, double to) {
    int single = 0, total = 0;
    for (int i = level_at(from); i <= level_at(to); ++i, ++total) single += count_closed(st.loops[i], 2e-3) == 1;
    return static_cast<double>(single) / std::max(1, total);
  };
  const double low_single = single_fraction(0.02, 0.12), high_single = single_fraction(0.88, 0.98);
  if (low_single > 0.5 && high_single < 0.5)
    throw InvalidInput("body features: one section near the bottom and several near the top: the body seems upside-down");
  if (high_single < 0.5 && !f.head_cut)
    throw InvalidInput("body features: no single head section in the top 12% of the height: not a standing body");
  const int low = count_closed(st.loops[level_at(0.08)], 1e-3);
  if (low < 2)
    throw InvalidInput("body features: expected two separate legs at 8% of the height, found " + std::to_string(low) +
                       " section(s) (legs together, or not a standing body)");

  // Legs at 20% of the height: the two largest loops give the sagittal axis.
  std::vector<std::pair<double, LoopShape>> legs;
  for (const auto& l : st.loops[level_at(0.2)])
    if (l.closed) legs.emplace_back(shape_of(l).area, shape_of(l));
  std::sort(legs.begin(), legs.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  if (legs.size() < 2) throw InvalidInput("body features: could not find both legs at 20% of the height");
  f.axis_x = 0.5 * (legs[0].second.centroid.x() + legs[1].second.centroid.x());
  double z_track = 0.5 * (legs[0].second.centroid.z() + legs[1].second.centroid.z());

  // Torso: from the crotch up, the loop enclosing the axis.
  std::vector<int> torso(n, -1);
  std::vector<LoopShape> torso_shape(n);
  int crotch = -1;
  double crotch_track_z = 0, joined_from = 0, joined_to = 0;
  bool joined = false;
  for (int i = level_at(0.2); i < level_at(0.97); ++i) {
    // Below the crotch only a loop enclosing the axis point counts (the outer one: a scan's tunnel
    // between joined thighs leaves a small loop inside); above it, the largest loop that spans the
    // axis near the tracked centre (the neck, not the chin beside it).
    int found = -1;
    for (size_t k = 0; k < st.loops[i].size(); ++k)
      if (st.loops[i][k].closed && contains_xz(st.loops[i][k], f.axis_x, z_track) &&
          (crotch >= 0 || straddles(shape_of(st.loops[i][k]), f.axis_x)) &&
          (found < 0 || shape_of(st.loops[i][k]).area > shape_of(st.loops[i][found]).area))
        found = static_cast<int>(k);
    if (crotch >= 0) {
      double best_area = found >= 0 ? shape_of(st.loops[i][found]).area : 0.0;
      for (size_t k = 0; k < st.loops[i].size(); ++k) {
        if (!st.loops[i][k].closed) continue;
        const LoopShape sh = shape_of(st.loops[i][k]);
        const double d = Eigen::Vector2d(sh.centroid.x() - f.axis_x, sh.centroid.z() - z_track).norm();
        if (sh.min_x < f.axis_x && sh.max_x > f.axis_x && d < 0.1 && sh.area > best_area) best_area = sh.area, found = static_cast<int>(k);
      }
    }
    // The thighs apart above sections that held both: they were joined below (a scan's
    // reconstruction of touching thighs), and the crotch is above this gap between them.
    if (crotch >= 0 && st.y[i] < f.floor_y + kJoinedThighsBelow * (st.top_y - f.floor_y) && thighs_apart(st.loops[i], f.axis_x) &&
        thighs_apart(st.loops[i - 1], f.axis_x)) {
      joined = true, joined_from = st.y[crotch], joined_to = std::max(st.y[crotch], st.y[i - 2]);
      for (int j = crotch; j < i; ++j) torso[j] = -1;
      crotch = -1;
      continue;
    }
    if (found < 0) {
      if (crotch >= 0 && i - crotch > 3) torso[i] = torso[i - 1] >= 0 ? -2 : -1;  // hole: keep tracking
      continue;
    }
    if (crotch < 0) crotch = i, crotch_track_z = z_track;
    torso[i] = found;
    torso_shape[i] = shape_of(st.loops[i][found]);
    z_track = torso_shape[i].centroid.z();
  }
  if (crotch < 0) throw InvalidInput("body features: no section encloses the body axis: could not find the crotch");
  // The torso's girths (convex hulls: most of this function's time on a dense scan), level by level.
  parallel_for_ranges(
      n, threads,
      [&](long begin, long end) {
        for (long i = begin; i < end; ++i)
          if (torso[i] >= 0) torso_shape[i].girth = convex_hull_perimeter(st.loops[i][torso[i]].points, Eigen::Vector3d::UnitY());
      },
      64);
  if (joined)
    f.warnings.push_back("crotch: the thighs are joined into one surface below it (" +
                         std::to_string(std::lround(1000 * (joined_from - f.floor_y))) + " to " +
                         std::to_string(std::lround(1000 * (joined_to - f.floor_y))) +
                         " mm above the soles): taken above the gap between them; sections there hold both thighs");
  // With finer sections (a quarter of the other refinements' step: the thigh girth, 2 cm below,
  // changes by up to 2 mm per mm there), the lowest below st.y[crotch] that still encloses the axis.
  f.crotch_y = st.y[crotch];
  if (sections_at && crotch > 0) {
    constexpr int kCrotchSteps = 4 * kRefineSteps;
    std::vector<double> heights;
    for (int k = kCrotchSteps - 1; k >= 1; --k) heights.push_back(st.y[crotch] - k * st.step / kCrotchSteps);
    const auto fine = sections_at(heights);
    for (size_t k = 0; k < heights.size() && f.crotch_y == st.y[crotch]; ++k)
      for (const auto& loop : fine[k])
        if (loop.closed && contains_xz(loop, f.axis_x, crotch_track_z) && straddles(shape_of(loop), f.axis_x)) f.crotch_y = heights[k];
  }
  f.crotch = Eigen::Vector3d(f.axis_x, f.crotch_y, torso_shape[crotch].centroid.z());
  if (f.head_cut) scale = std::max(scale, (f.crotch_y - f.floor_y) / kCrotchOverStature);
  f.crotch_axis_z = crotch_track_z;

  // Arms: going down from high on the chest, the first level where a separate loop appears on a side
  // is that side's armpit.
  auto side_loops = [&](int i, int side) {
    std::vector<int> out;
    if (torso[i] < 0) return out;
    for (size_t k = 0; k < st.loops[i].size(); ++k) {
      if (static_cast<int>(k) == torso[i]) continue;  // open loops count: a scan's arm has gaps near the armpit
      const LoopShape s = shape_of(st.loops[i][k]);
      if (s.area < 2e-5) continue;
      // Well to the side: a loop in front of a cut head (the chin) is no arm.
      const double reach = side == kLeft ? torso_shape[i].max_x - f.axis_x : f.axis_x - torso_shape[i].min_x;
      if ((side == kLeft ? s.centroid.x() - f.axis_x : f.axis_x - s.centroid.x()) > 0.4 * reach) out.push_back(static_cast<int>(k));
    }
    return out;
  };
  // An arm, not an ear (a cut head's ears can lie below 86% of the estimated stature): within 4 cm
  // below, a side loop as big as an arm's section.
  auto arm_sized_below = [&](int i, int side) {
    for (int j = i; j > crotch && j >= i - static_cast<int>(0.04 / st.step); --j)
      for (int k : side_loops(j, side))
        if (shape_of(st.loops[j][static_cast<size_t>(k)]).area >= kArmSectionArea) return true;
    return false;
  };
  int armpit_level[2] = {-1, -1};
  for (int side : {kLeft, kRight})
    for (int i = level_at(0.86); i > crotch; --i)
      if (!side_loops(i, side).empty() && !side_loops(i - 1, side).empty() && !side_loops(i - 2, side).empty() &&
          arm_sized_below(i, side)) {
        armpit_level[side] = i;
        break;
      }
  for (int side : {kLeft, kRight})
    if (armpit_level[side] < 0)
      throw InvalidInput(std::string("body features: the ") + (side == kLeft ? "left" : "right") +
                         " arm never separates from the torso (arms touching the body?)");
  for (int side : {kLeft, kRight}) {
    const int i = armpit_level[side];
    const auto arms = side_loops(i, side);
    const SectionLoop& torso_loop = st.loops[i][torso[i]];
    const SectionLoop& arm_loop = st.loops[i][arms.front()];
    Eigen::Index t_idx, a_idx;
    if (side == kLeft) {
      torso_loop.points.col(0).maxCoeff(&t_idx);
      arm_loop.points.col(0).minCoeff(&a_idx);
    } else {
      torso_loop.points.col(0).minCoeff(&t_idx);
      arm_loop.points.col(0).maxCoeff(&a_idx);
    }
    f.armpit[side] = 0.5 * (torso_loop.points.row(t_idx) + arm_loop.points.row(a_idx)).transpose();
    f.armpit[side].y() = st.y[i] + st.step / 2;
  }
  for (int side : {kLeft, kRight})
    if (f.armpit[side].y() < f.floor_y + 0.62 * scale)
      throw InvalidInput(std::string("body features: the ") + (side == kLeft ? "left" : "right") +
                         " arm separates from the torso only at " +
                         std::to_string(static_cast<int>(100 * (f.armpit[side].y() - f.floor_y) / scale)) +
                         "% of the height (armpits are at 70-78%): arms touching the body?");
  // The arms separate where each arm first stands kArmClearance clear of the torso. Where its loop
  // parts from the torso's depends on how the narrow crease of a heavy armpit is tessellated (by
  // 2 mm when remeshed); the gap a little lower widens steadily. Between the armpit level (separate)
  // and the next one up (joined), finer sections find where the loops part; the gap is then
  // followed down the sections to the clearance, and that bracket refined with finer sections.
  f.arms_separate_y = std::numeric_limits<double>::infinity();
  {
    const double fine_step = st.step / kRefineSteps;
    std::vector<double> heights;
    for (int side : {kLeft, kRight})
      for (int k = 1; k < kRefineSteps; ++k) heights.push_back(st.y[armpit_level[side]] + k * fine_step);
    const auto fine = sections_at ? sections_at(heights) : std::vector<std::vector<SectionLoop>>{};
    Eigen::Vector3d torso_centre[2], arm_centre[2];
    // The gap between the loops nearest the torso's and the arm's centres at the armpit (0 when
    // they are one loop, -1 when either is missing).
    auto gap = [&](int side, const std::vector<SectionLoop>& loops, double y) {
      const int t = nearest_loop(loops, Eigen::Vector3d(torso_centre[side].x(), y, torso_centre[side].z()));
      const int a = nearest_loop(loops, Eigen::Vector3d(arm_centre[side].x(), y, arm_centre[side].z()));
      return t < 0 || a < 0 ? -1.0 : t == a ? 0.0 : loop_distance(loops[static_cast<size_t>(t)], loops[static_cast<size_t>(a)]);
    };
    std::vector<std::pair<double, double>> profile[2];  // (level, gap), descending levels
    for (int side : {kLeft, kRight}) {
      const int i = armpit_level[side];
      torso_centre[side] = torso_shape[i].centroid;
      arm_centre[side] = shape_of(st.loops[i][side_loops(i, side).front()]).centroid;
      std::vector<std::pair<double, double>> above;  // ascending from the armpit level
      for (int k = 1; k < kRefineSteps && !fine.empty(); ++k) {
        const double y = st.y[i] + k * fine_step;
        above.emplace_back(y, gap(side, fine[static_cast<size_t>(side * (kRefineSteps - 1) + k - 1)], y));
        if (above.back().second <= 0) break;
      }
      if (above.empty() || above.back().second > 0) above.emplace_back(st.y[i] + st.step, 0.0);
      profile[side].assign(above.rbegin(), above.rend());
      for (int j = i; j > crotch && j >= i - kArmClearanceSections; --j) {
        const double g = gap(side, st.loops[j], st.y[j]);
        if (g <= 0) continue;
        profile[side].emplace_back(st.y[j], g);
        if (g >= kArmClearance) break;
      }
    }
    // The first level at or past the clearance, and the one above it.
    auto bracket = [&](int side) {
      const auto& p = profile[side];
      for (size_t k = 1; k < p.size(); ++k)
        if (p[k].second >= kArmClearance) return k;
      return size_t{0};
    };
    if (sections_at) {
      std::vector<double> refine;
      std::vector<int> refine_side;
      for (int side : {kLeft, kRight}) {
        const size_t k = bracket(side);
        if (k > 0 && profile[side][k - 1].first - profile[side][k].first > 1.5 * fine_step)
          for (int r = 1; r < kRefineSteps; ++r) refine.push_back(profile[side][k].first + r * fine_step), refine_side.push_back(side);
      }
      const auto sections = refine.empty() ? std::vector<std::vector<SectionLoop>>{} : sections_at(refine);
      for (size_t r = 0; r < refine.size(); ++r) {
        const double g = gap(refine_side[r], sections[r], refine[r]);
        if (g >= 0) profile[refine_side[r]].emplace_back(refine[r], g);
      }
      for (auto& p : profile) std::sort(p.begin(), p.end(), [](const auto& u, const auto& v) { return u.first > v.first; });
    }
    for (int side : {kLeft, kRight}) {
      const auto& p = profile[side];
      const size_t k = bracket(side);
      double level = 0;
      if (k > 0) {
        level = p[k - 1].first + (p[k].first - p[k - 1].first) * (kArmClearance - p[k - 1].second) / (p[k].second - p[k - 1].second);
      } else {
        level = p.size() > 1 ? 0.5 * (p[0].first + p[1].first) : p[0].first;  // where the loops part
        f.arm_touches_torso[side] = true;
        f.warnings.push_back(std::string("arms: the ") + (side == kLeft ? "left" : "right") + " arm is nowhere " +
                             std::to_string(static_cast<int>(kArmClearance * 1000)) + " mm clear of the torso within " +
                             std::to_string(static_cast<int>(kArmClearanceSections * st.step * 100)) +
                             " cm below the armpit (arm touching the body?): the bust band may end too low");
      }
      f.arms_separate_y = std::min(f.arms_separate_y, level);
    }
  }
  if (f.head_cut) {
    scale = std::max(f.stature, (f.arms_separate_y - f.floor_y) / kStatureFromArmsSeparate);
    f.stature = scale;
    f.crown_y = f.floor_y + scale;
    f.warnings.push_back(std::string("the top of the body is cut (") +
                         (top_is_cut ? "an opening there"
                                     : "a section within 1 cm of the top is " +
                                           std::to_string(static_cast<int>(std::lround(top_girth * 100))) + " cm round") +
                         ", no crown): the head is missing or partial; stature and crown estimated from the level "
                         "where the arms separate (" +
                         std::to_string(static_cast<int>(std::lround(scale * 100))) + " cm)");
  }
  const int armpit_low = std::min(armpit_level[kLeft], armpit_level[kRight]);
  const int armpit_high = std::max(armpit_level[kLeft], armpit_level[kRight]);

  auto girth = [&](int i) { return torso[i] >= 0 ? torso_shape[i].girth : std::numeric_limits<double>::quiet_NaN(); };
  auto argbest = [&](int from, int to, bool want_max) {
    int best = -1;
    for (int i = std::max(from, crotch); i <= std::min(to, n - 1); ++i) {
      const double g = girth(i);
      if (std::isnan(g)) continue;
      if (best < 0 || (want_max ? g > girth(best) : g < girth(best))) best = i;
    }
    return best;
  };

  // Neck: the narrowest section between the shoulders and the head; its base is where the girth
  // starts to widen into the shoulders.
  // Below the chin; with the head cut, anywhere up to 1 cm under the cut.
  const int neck_band_top = f.head_cut
                                ? std::max(level_at(0.95) - static_cast<int>(0.1 / st.step), n - 1 - static_cast<int>(0.01 / st.step))
                                : level_at(0.95) - static_cast<int>(0.1 / st.step);
  const int neck = argbest(armpit_high + static_cast<int>(0.05 / st.step), neck_band_top, false);
  if (neck < 0) throw InvalidInput("body features: could not find the neck");
  f.neck_y = st.y[neck];
  int base = neck;
  while (base - 1 > armpit_high && !std::isnan(girth(base - 1)) && girth(base - 1) < 1.25 * girth(neck)) --base;
  f.neck_top = torso_shape[neck].centroid;
  f.neck_top.y() = st.y[neck];
  f.neck_base = torso_shape[base].centroid;
  f.neck_base.y() = st.y[base];
  // Neck and head joints (the neck girth's axis): the neck joint regressed on the level where the
  // neck widens, the head joint at a calibrated fraction of the way from the neck base to the crown,
  // behind the centroid of the head's section there.
  const double threshold = 1.25 * girth(neck);
  double widening_y = st.y[base];
  if (base - 1 >= 0 && girth(base - 1) >= threshold && girth(base - 1) > girth(base))
    widening_y -= st.step * (threshold - girth(base)) / (girth(base - 1) - girth(base));
  const double* w = kNeckJointFromBase;
  f.neck_joint = Eigen::Vector3d(
      f.neck_base.x(),
      widening_y + w[0] + w[1] * (f.neck_y - widening_y) + w[2] * (f.crown_y - widening_y) + w[3] * (widening_y - f.crotch_y),
      f.neck_base.z() + kNeckJointForward);
  record_neck(f, widening_y, regressors);
  const double head_y = f.neck_base.y() + kHeadJointFraction * (f.crown_y - f.neck_base.y());
  const int head_level = std::clamp(static_cast<int>(std::lround((head_y - st.y[0]) / st.step)), 0, n - 1);
  Eigen::Vector3d head_centre = f.neck_top;  // over a hole, the nearest closed head section within 2.5 cm
  for (int d = 0; d <= 5; ++d) {
    if (head_level - d >= 0 && torso[head_level - d] >= 0) {
      head_centre = torso_shape[head_level - d].centroid;
      break;
    }
    if (head_level + d < n && torso[head_level + d] >= 0) {
      head_centre = torso_shape[head_level + d].centroid;
      break;
    }
  }
  f.head_joint = Eigen::Vector3d(head_centre.x(), head_y, head_centre.z() + kHeadJointForward);
  if (regressors) regressors->head = true, regressors->crown_y = f.crown_y, regressors->head_centre = head_centre;

  // Arms: follow each arm's loop down from the armpit; centroids trace the limb axis.
  for (int side : {kLeft, kRight}) {
    std::vector<Eigen::Vector3d> axis;
    std::vector<double> area, girth;
    Eigen::Vector3d previous = f.armpit[side];
    Eigen::Vector3d tip = previous;
    for (int i = armpit_level[side]; i >= 0; --i) {
      int best = -1;
      double best_d = axis.empty() ? 0.15 : 0.08;  // a heavy arm's centre lies far from the armpit point
      for (size_t k = 0; k < st.loops[i].size(); ++k) {
        if (static_cast<int>(k) == torso[i]) continue;
        const LoopShape s = shape_of(st.loops[i][k]);
        if ((side == kLeft) != (s.centroid.x() > f.axis_x)) continue;
        const double d = Eigen::Vector2d(s.centroid.x() - previous.x(), s.centroid.z() - previous.z()).norm();
        if (d < best_d) best = static_cast<int>(k), best_d = d;
      }
      if (best < 0) break;
      const LoopShape s = shape_of(st.loops[i][best], true);
      axis.push_back(s.centroid);
      area.push_back(s.area);
      girth.push_back(s.girth);
      previous = s.centroid;
      Eigen::Index lowest;
      st.loops[i][best].points.col(1).minCoeff(&lowest);
      tip = st.loops[i][best].points.row(lowest).transpose();
    }
    if (axis.size() < 20) {
      f.arm_found[side] = false;
      f.warnings.push_back(std::string("could not follow the ") + (side == kLeft ? "left" : "right") +
                           " arm from the armpit to the hand (holes?): its shoulder, elbow and wrist are not found");
      f.shoulder[side] = f.armpit[side] + Eigen::Vector3d(0, 0.06, 0);  // a placeholder above the armpit
      continue;
    }
    // A sliver at the top (a fold of a deformed mesh in the armpit) is not the arm's first section.
    while (axis.size() > 25 && area[0] < 0.25 * std::max({area[1], area[2], area[3], area[4]})) {
      axis.erase(axis.begin());
      area.erase(area.begin());
      girth.erase(girth.begin());
    }
    f.hand_tip[side] = tip;
    f.arm_axis[side] = axis;
    const size_t m = axis.size();
    // Elbow: the break of a two-segment line through the axis (the kink of the slightly bent A-pose
    // arm), first up to 80% of the arm, then up to the wrist found from it.
    auto find_elbow = [&](size_t end) {
      size_t elbow = end / 2;
      double best = std::numeric_limits<double>::max();
      for (size_t k = end / 4; k < end * 3 / 4; ++k) {
        const double e = line_error(axis, 0, k) + line_error(axis, k, end);
        if (e < best) best = e, elbow = k;
      }
      return elbow;
    };
    // Wrist: the thinnest section between 48% and 68% of the way from the elbow to the hand tip,
    // proximal of the palm (the fullest section beyond 55%): horizontal sections of the hanging hand
    // narrow again towards the fingertips.
    auto find_wrist = [&](size_t elbow) {
      const double reach = (tip - axis[elbow]).norm();
      auto fraction = [&](size_t k) { return (axis[k] - axis[elbow]).norm() / reach; };
      size_t palm = m;
      for (size_t k = elbow; k < m; ++k)
        if (fraction(k) >= kPalmFrom && (palm == m || girth[k] > girth[palm])) palm = k;
      size_t wrist = elbow;
      double wrist_girth = std::numeric_limits<double>::max();
      for (size_t k = elbow; k < m; ++k) {
        const double t = fraction(k);
        if (t < kWristBand[0] || t > kWristBand[1] || (k >= palm && wrist_girth < std::numeric_limits<double>::max())) continue;
        if (girth[k] < wrist_girth) wrist_girth = girth[k], wrist = k;
      }
      return wrist;
    };
    size_t elbow = find_elbow(m * 8 / 10);
    size_t wrist = find_wrist(elbow);
    elbow = find_elbow(wrist);
    wrist = find_wrist(elbow);
    // Elbow joint: on a heavy arm, nearly straight, the fit's error has a long, flat valley whose
    // minimum jumps by whole sections when the body is remeshed (and with the wrist's section). So
    // the joint is the vertex of a parabola fitted to the error over kElbowFitHalfWidth sections
    // each side of the first pass's minimum (the forearm line ending at 80% of the arm), placed
    // between the sections.
    const size_t fit_end = m * 8 / 10, centre = find_elbow(fit_end);
    Eigen::Vector3d elbow_point = axis[centre];
    if (centre >= kElbowFitHalfWidth && centre + kElbowFitHalfWidth < fit_end) {
      std::vector<double> t, v;
      for (size_t k = centre - kElbowFitHalfWidth; k <= centre + kElbowFitHalfWidth; ++k)
        t.push_back(static_cast<double>(k) - static_cast<double>(centre)),
            v.push_back(line_error(axis, 0, k) + line_error(axis, k, fit_end));
      double vertex = 0;
      if (parabola_vertex(t, v, false, &vertex)) {
        const double half = static_cast<double>(kElbowFitHalfWidth);
        const double at = static_cast<double>(centre) + std::clamp(vertex, -half, half);
        const size_t k = static_cast<size_t>(std::floor(at));
        elbow_point = axis[k] + (at - static_cast<double>(k)) * (axis[std::min(k + 1, m - 1)] - axis[k]);
      }
    }
    f.elbow[side] = elbow_point + offset_on(kElbowOffset, side);
    // Wrist joint: just distal of the narrowest forearm section.
    const Eigen::Vector3d forearm = (axis[wrist] - axis[elbow]).normalized();
    f.wrist[side] = axis[wrist] + kWristBeyondNarrowest * forearm + offset_on(kWristOffset, side);
    record_arm(side, elbow_point, axis[wrist] + kWristBeyondNarrowest * forearm, regressors);
    // Shoulder joint: regressed (kShoulderFromSection) on the torso section 1.5 arm radii above the
    // armpit; without a closed section there, the arm's top centroid.
    const double radius = std::sqrt(area[0] / M_PI);
    int level = armpit_level[side];
    while (level + 1 < n && st.y[level] < f.armpit[side].y() + 1.5 * radius) ++level;
    f.shoulder[side] = Eigen::Vector3d(axis[0].x(), st.y[level], axis[0].z());
    if (torso[level] >= 0) {
      const Eigen::MatrixXd& P = st.loops[level][torso[level]].points;
      const double outward = side == kLeft ? 1.0 : -1.0;
      double lo_z = 1e9, hi_z = -1e9, width = 0;
      int count = 0;
      for (Eigen::Index r = 0; r < P.rows(); ++r) {
        const double lateral = outward * (P(r, 0) - f.armpit[side].x());
        if (lateral <= 0) continue;
        ++count;
        lo_z = std::min(lo_z, P(r, 2));
        hi_z = std::max(hi_z, P(r, 2));
        width = std::max(width, lateral);
      }
      const double mid_z = 0.5 * (lo_z + hi_z);
      const double x[6] = {1.0, width, radius, hi_z - lo_z, outward * (axis[0].x() - f.armpit[side].x()), axis[0].z() - mid_z};
      auto predict = [&](const double(&w)[6]) {
        double v = 0;
        for (int k = 0; k < 6; ++k) v += w[k] * x[k];
        return v;
      };
      if (count >= 5)
        f.shoulder[side] =
            Eigen::Vector3d(f.armpit[side].x() + outward * predict(kShoulderFromSection.lateral),
                            f.armpit[side].y() + predict(kShoulderFromSection.up), mid_z + predict(kShoulderFromSection.forward));
      if (count >= 5) record_shoulder(side, x, Eigen::Vector3d(f.armpit[side].x(), f.armpit[side].y(), mid_z), regressors);
    }
  }

  // Girth levels of the torso (ISO 8559-1 style, see README).
  // Search bands as fractions of the crotch-to-armpit span (spine proportions measured on the
  // MakeHuman population, see README), so that a large belly is not taken for the bust.
  const int span = armpit_low - crotch;
  // Each level is searched among the sections in a band of heights, then placed between the
  // sections (so that it does not jump a whole step when the mesh is remeshed): at the band's end
  // when the girth still grows (or shrinks) beyond it, else at the vertex of the parabola through
  // the extreme section's and its neighbours' girths.
  auto first_at_or_above = [&](double y) { return static_cast<int>(std::lower_bound(st.y.begin(), st.y.end(), y) - st.y.begin()); };
  auto last_at_or_below = [&](double y) { return static_cast<int>(std::upper_bound(st.y.begin(), st.y.end(), y) - st.y.begin()) - 1; };
  auto better = [&](int i, int than, bool want_max) {
    return i >= 0 && i < n && !std::isnan(girth(i)) && (want_max ? girth(i) > girth(than) : girth(i) < girth(than));
  };
  auto refined_level = [&](int i, double from_y, double to_y, bool want_max) {
    if (i == last_at_or_below(to_y) && better(i + 1, i, want_max)) return std::clamp(to_y, st.y[i], st.y[i] + st.step);
    if (i == first_at_or_above(from_y) && better(i - 1, i, want_max)) return std::clamp(from_y, st.y[i] - st.step, st.y[i]);
    if (i <= crotch || i + 1 >= n) return st.y[i];
    const double a = girth(i - 1), b = girth(i), c = girth(i + 1), curvature = a - 2 * b + c;
    if (std::isnan(a) || std::isnan(c) || std::abs(curvature) < 1e-12) return st.y[i];
    return st.y[i] + std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5) * st.step;
  };
  auto level_of_extremum = [&](double from_y, double to_y, bool want_max, int* index) {
    *index = argbest(first_at_or_above(from_y), last_at_or_below(to_y), want_max);
    return *index < 0 ? 0.0 : refined_level(*index, from_y, to_y, want_max);
  };
  // Bust: the fullest level up to 1 cm below where the arms separate (the breasts, or a man's chest
  // under the armpits). A flat chest has near-equal maxima far apart: the level is the centre of the
  // span around the fullest section where the girth stays within kBustPlateau of it, weighted by
  // how much fuller than that each level is (peak_centre: stable when the body is remeshed).
  int bust = -1, underbust = -1, waist = -1, hip = -1;
  const int bust_from = std::min(n - 1, crotch + static_cast<int>(kBustBandStart * span));
  const double bust_to_y = f.arms_separate_y - kBustBelowArmpits;
  const int bust_to = last_at_or_below(bust_to_y);
  bust = argbest(bust_from, bust_to, true);
  if (bust >= 0) {
    std::vector<double> ys, gs;
    for (int i = bust_from; i <= bust_to; ++i) ys.push_back(st.y[i]), gs.push_back(girth(i));
    if (bust_to_y > st.y[bust_to] + 1e-9) ys.push_back(bust_to_y), gs.push_back(girth(bust_to));  // on to the band's end
    f.bust_y = peak_centre(ys, gs, static_cast<size_t>(bust - bust_from), girth(bust) - kBustPlateau);
  }
  f.torso_levels_doubtful = bust == bust_from && better(bust - 1, bust, true);
  if (f.torso_levels_doubtful)
    f.warnings.push_back(
        "bust: the torso is fullest at the bottom of the bust band and fuller still below it (a belly, or "
        "arms merged with the torso in a scan): the bust, underbust and waist levels are doubtful");
  if (bust >= 0) f.underbust_y = level_of_extremum(f.bust_y - 0.12, f.bust_y - 0.03, false, &underbust);
  if (bust >= 0) {
    const double waist_from = st.y[std::min(n - 1, crotch + static_cast<int>(kWaistBandStart * span))], waist_to = f.bust_y - 0.05;
    level_of_extremum(waist_from, waist_to, false, &waist);
    // A flat waist can have two near-equal minima: take the highest local minimum within
    // kWaistTieTolerance of the narrowest (the natural waist, nearest the ribs).
    for (int i = waist + 1; waist >= 0 && i < std::min(last_at_or_below(waist_to), n - 1); ++i) {
      const double g = girth(i);
      if (g <= girth(waist) + kWaistTieTolerance && g <= girth(i - 1) && g <= girth(i + 1)) waist = i;
    }
    if (waist >= 0) f.waist_y = refined_level(waist, waist_from, waist_to, false);
  }
  if (waist >= 0) f.hip_y = level_of_extremum(f.crotch_y + 0.02, f.waist_y, true, &hip);
  if (bust < 0 || underbust < 0 || waist < 0 || hip < 0)
    throw InvalidInput("body features: the torso sections between crotch and armpits are not closed (holes?)");

  // Legs: follow each leg's loop down from the crotch.
  Eigen::Vector3d probe[2];  // the thighs' centres that give the pelvis's lateral direction
  for (int side : {kLeft, kRight}) {
    std::vector<Eigen::Vector3d> axis;
    std::vector<double> depth, back;
    std::vector<int> level;
    std::vector<SectionLoop> leg_loops;  // their girths are needed only near the ankle
    Eigen::Vector3d previous(f.axis_x + (side == kLeft ? 0.1 : -0.1), 0, f.crotch.z());
    for (int i = crotch - 1; i >= 0; --i) {
      int best = -1;
      double best_d = 0.15;
      SectionLoop best_loop;
      for (size_t k = 0; k < st.loops[i].size(); ++k) {
        if (!st.loops[i][k].closed) continue;
        // A section across the body's axis holds both thighs (a scan joined them): this leg's half.
        const bool joined = contains_xz(st.loops[i][k], f.axis_x, f.crotch.z());
        SectionLoop candidate = joined ? half_loop(st.loops[i][k], f.axis_x, side == kLeft ? 1.0 : -1.0) : st.loops[i][k];
        if (candidate.points.rows() < 3) continue;
        const LoopShape s = shape_of(candidate);
        if ((side == kLeft) != (s.centroid.x() > f.axis_x) || s.area < 5e-4) continue;
        const double d = Eigen::Vector2d(s.centroid.x() - previous.x(), s.centroid.z() - previous.z()).norm();
        if (d < best_d) best = static_cast<int>(k), best_d = d, best_loop = std::move(candidate);
      }
      if (best < 0) continue;
      const LoopShape s = shape_of(best_loop);
      axis.push_back(s.centroid);
      depth.push_back(best_loop.points.col(2).maxCoeff() - best_loop.points.col(2).minCoeff());
      back.push_back(best_loop.points.col(2).minCoeff());
      level.push_back(i);
      leg_loops.push_back(std::move(best_loop));
      previous = s.centroid;
    }
    if (axis.size() < 40)
      throw InvalidInput(std::string("body features: could not follow the ") + (side == kLeft ? "left" : "right") + " leg");
    auto index_of_height = [&](double y) {
      size_t best = 0;
      for (size_t k = 0; k < axis.size(); ++k)
        if (std::abs(axis[k].y() - y) < std::abs(axis[best].y() - y)) best = k;
      return best;
    };
    // Ankle: below the thinnest section above the foot, the level where the section has grown 1.45
    // times as deep (front to back): the foot begins there, at the ankle joint.
    size_t ankle = index_of_height(f.floor_y + 0.07 * f.stature);
    const size_t ankle_from = index_of_height(f.floor_y + 0.12 * f.stature), ankle_to = index_of_height(f.floor_y + 0.04 * f.stature);
    std::vector<double> g(axis.size(), 0.0);  // girths (convex hulls), from ankle_from to ankle_to
    for (size_t k = std::min(ankle_from, ankle); k <= std::max(ankle_to, ankle); ++k)
      g[k] = convex_hull_perimeter(leg_loops[k].points, Eigen::Vector3d::UnitY());
    for (size_t k = ankle_from; k <= ankle_to; ++k)
      if (g[k] < g[ankle]) ankle = k;
    const double min_depth = depth[ankle];
    while (ankle + 1 < axis.size() && depth[ankle + 1] < 1.45 * min_depth) ++ankle;
    // Knee: a fixed fraction of the way from the ankle joint up to the crotch, drawn toward the
    // popliteal hollow (the level within 10 cm above / 6 cm below where the back of the leg comes
    // furthest forward) by a regression on the calibration bodies (kKneeTowardHollow).
    // Both levels are placed between the sections (the depth's crossing, the hollow's parabola), so
    // that remeshing does not move the knee by whole steps.
    double ankle_y = axis[ankle].y();
    if (ankle + 1 < axis.size() && depth[ankle + 1] > depth[ankle])
      ankle_y -= (axis[ankle].y() - axis[ankle + 1].y()) *
                 std::clamp((1.45 * min_depth - depth[ankle]) / (depth[ankle + 1] - depth[ankle]), 0.0, 1.0);
    const double leg_length = f.crotch_y - ankle_y;
    const double fraction_y = ankle_y + kKneeFraction * leg_length;
    size_t hollow = index_of_height(fraction_y);
    for (size_t k = index_of_height(fraction_y + 0.10); k <= index_of_height(fraction_y - 0.06); ++k)
      if (back[k] > back[hollow]) hollow = k;
    // The hollow is shallow: the vertex of a parabola fitted over 3 cm each side.
    double hollow_y = axis[hollow].y();
    if (hollow >= 6 && hollow + 6 < axis.size()) {
      std::vector<double> t, v;
      for (size_t k = hollow - 6; k <= hollow + 6; ++k) t.push_back(axis[k].y() - axis[hollow].y()), v.push_back(back[k]);
      double vertex = 0;
      if (parabola_vertex(t, v, true, &vertex)) hollow_y += std::clamp(vertex, -0.03, 0.03);
    }
    const double knee_y = fraction_y + kKneeTowardHollow * (hollow_y - fraction_y) + kKneeShift * leg_length;
    const size_t knee = index_of_height(knee_y);
    f.ankle[side] = axis[ankle] + offset_on(kAnkleOffset, side);
    f.knee[side] = Eigen::Vector3d(axis[knee].x(), knee_y, axis[knee].z()) + offset_on(kKneeOffset, side);  // even over a hole
    record_leg(side, fraction_y, hollow_y, leg_length, Eigen::Vector3d(axis[knee].x(), knee_y, axis[knee].z()), axis[ankle], regressors);
    probe[side] = axis[index_of_height(f.crotch_y - kHipProbe * f.stature)];
  }
  // Hips, in the pelvis's own frame: lateral along the line between the thigh probes (a torso
  // turned from the hips does not turn it), forward perpendicular to it, from the crotch.
  Eigen::Vector3d lateral = probe[kLeft] - probe[kRight];
  lateral.y() = 0;
  lateral = lateral.norm() > 0.01 ? lateral.normalized() : Eigen::Vector3d::UnitX();
  const Eigen::Vector3d forward = lateral.cross(Eigen::Vector3d::UnitY());
  // The torso's section there, or the nearest closed one within 2 cm (a scan's hole).
  const SectionLoop* pelvis = nullptr;
  const int hip_level = first_at_or_above(f.crotch_y + kHipLevel * f.stature);
  for (int d = 0; !pelvis && d * st.step <= 0.02; ++d)
    for (int i : {hip_level + d, hip_level - d})
      for (const SectionLoop& loop : st.loops[static_cast<size_t>(std::clamp(i, 0, n - 1))])
        if (!pelvis && loop.closed && contains_xz(loop, f.crotch.x(), f.crotch.z())) pelvis = &loop;
  if (!pelvis) throw InvalidInput("body features: no closed torso section round the crotch at the hip joints' level (a hole?)");
  double front = -1e9, back = 1e9;
  for (Eigen::Index k = 0; k < pelvis->points.rows(); ++k) {
    const double ahead = (pelvis->points.row(k).transpose() - f.crotch).dot(forward);
    front = std::max(front, ahead);
    back = std::min(back, ahead);
  }
  auto regress = [&](const double(&c)[4]) { return c[0] + c[1] * f.stature + c[2] * front + c[3] * back; };
  record_hips(f, front, back, lateral, forward, regressors);
  for (int side : {kLeft, kRight}) {
    Eigen::Vector3d hip = f.crotch + (side == kLeft ? 1.0 : -1.0) * regress(kHipLateral) * lateral + regress(kHipForward) * forward;
    hip.y() = f.crotch_y + regress(kHipUp);
    f.hip[side] = hip;
  }
  return f;
}

}  // namespace posekit
