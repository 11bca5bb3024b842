#include "posekit/shape/layered_representation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <map>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/parallel.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {
namespace {

// Part labels belong to layers, once and for all (Eq. 2a): the first torso layers (crotch to hip,
// and on to about the lower-back joint, at 0.36 of the crotch-to-armpit span on the MakeHuman
// population) are pelvis, the next ones up to about the upper-back joint (0.68) abdomen, the rest
// chest.
constexpr int kPelvisLayers = 6, kAbdomenLayers = 7;
// Layers per segment of each chain: torso crotch-hip-waist-underbust-bust-armpit-neck base; head;
// legs crotch-knee-ankle-sole; arms (upper arm)-elbow-wrist-hand tip.
constexpr int kTorsoSegments[] = {3, 5, 5, 3, 3, 4};
constexpr int kHeadSegments = 10, kNeckSegments = 2;
constexpr int kLegSegments[] = {6, 6, 3};
constexpr int kArmSegments[] = {5, 6, 4};

struct Plane2d {
  Eigen::Vector3d origin, front, side;
  Eigen::Vector2d to2d(const Eigen::Vector3d& p) const { return {(p - origin).dot(front), (p - origin).dot(side)}; }
};

/// The polygon's points at N equal angles about its area centroid, taking the farthest crossing of
/// each ray (the envelope of a star-shaped section). Returns the centroid.
Eigen::Vector3d resample(const std::vector<Eigen::Vector3d>& polygon, const Eigen::Vector3d& normal, const Eigen::Vector3d& front, int n,
                         Eigen::MatrixXd& out, Eigen::Index first_row) {
  const Eigen::Vector3d side = normal.cross(front);
  Plane2d plane{polygon.front(), front, side};
  std::vector<Eigen::Vector2d> q;
  for (const auto& p : polygon) q.push_back(plane.to2d(p));
  double a2 = 0, cx = 0, cy = 0;
  for (size_t i = 0, j = q.size() - 1; i < q.size(); j = i++) {
    const double cr = q[j].x() * q[i].y() - q[i].x() * q[j].y();
    a2 += cr;
    cx += (q[j].x() + q[i].x()) * cr;
    cy += (q[j].y() + q[i].y()) * cr;
  }
  Eigen::Vector2d c = std::abs(a2) > 1e-12 ? Eigen::Vector2d(cx / (3 * a2), cy / (3 * a2)) : Eigen::Vector2d::Zero();
  if (std::abs(a2) <= 1e-12)
    for (const auto& p : q) c += p / static_cast<double>(q.size());
  for (int k = 0; k < n; ++k) {
    const double theta = 2 * M_PI * k / n;
    const Eigen::Vector2d d(std::cos(theta), std::sin(theta));
    double best = -1;
    for (size_t i = 0, j = q.size() - 1; i < q.size(); j = i++) {
      const Eigen::Vector2d e = q[i] - q[j];
      const double den = d.x() * e.y() - d.y() * e.x();
      if (std::abs(den) < 1e-15) continue;
      const Eigen::Vector2d w = q[j] - c;
      const double t = (w.x() * e.y() - w.y() * e.x()) / den;
      const double s = (w.x() * d.y() - w.y() * d.x()) / den;
      if (t > 0 && s >= 0 && s <= 1) best = std::max(best, t);
    }
    if (best < 0) {  // the centroid is outside (should not happen): nearest point in angle
      double best_dot = -2;
      for (const auto& p : q)
        if ((p - c).normalized().dot(d) > best_dot) best_dot = (p - c).normalized().dot(d), best = (p - c).norm();
    }
    const Eigen::Vector2d p2 = c + best * d;
    out.row(first_row + k) = (plane.origin + p2.x() * front + p2.y() * side).transpose();
  }
  return plane.origin + c.x() * front + c.y() * side;
}

/// Convex hull (in the plane) of the given points, counter-clockwise about `normal`.
std::vector<Eigen::Vector3d> planar_hull(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& normal,
                                         const Eigen::Vector3d& front) {
  if (pts.size() < 3) return pts;  // no polygon: the caller reports the degenerate section
  const Eigen::Vector3d side = normal.cross(front);
  std::vector<std::pair<Eigen::Vector2d, size_t>> q;
  for (size_t i = 0; i < pts.size(); ++i) q.push_back({Eigen::Vector2d(pts[i].dot(front), pts[i].dot(side)), i});
  std::sort(q.begin(), q.end(), [](const auto& a, const auto& b) {
    return a.first.x() != b.first.x() ? a.first.x() < b.first.x() : a.first.y() < b.first.y();
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<size_t> hull(2 * q.size());
  size_t k = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    while (k >= 2 && cross(q[hull[k - 2]].first, q[hull[k - 1]].first, q[i].first) <= 0) --k;
    hull[k++] = i;
  }
  for (size_t i = q.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(q[hull[k - 2]].first, q[hull[k - 1]].first, q[i].first) <= 0) --k;
    hull[k++] = i;
  }
  std::vector<Eigen::Vector3d> out;
  for (size_t i = 0; i + 1 < k; ++i) out.push_back(pts[q[hull[i]].second]);
  return out;
}

class Builder {
 public:
  Builder(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const BodyFeatures& f, int n, int threads = 1)
      : V_(V), F_(F), f_(f), n_(n), threads_(threads) {}

  /// The layers' planes only (centres as placed, before any section): no mesh is read.
  LayeredRepresentation plan() {
    planning_ = true;
    return layers();
  }

  LayeredRepresentation build() {
    // The horizontal layers (torso, head, legs) are sliced in one pass over the faces: a first run
    // only collects their heights.
    collecting_ = true;
    torso();
    head();
    for (int side : {kLeft, kRight}) leg(side);
    collecting_ = false;
    const auto sections = slice_mesh_stack(V_, F_, Eigen::Vector3d::UnitY(), horizontal_heights_, threads_);
    for (size_t i = 0; i < sections.size(); ++i) horizontal_sections_.emplace(horizontal_heights_[i], sections[i]);
    // The two arms' sections side by side (each only reads the surface).
    parallel_for_ranges(
        2, threads_ == 1 ? 1 : 2,
        [&](long begin, long end) {
          for (long side = begin; side < end; ++side) arm_sections_[side] = arm_sections(static_cast<int>(side));
        },
        1);
    return layers();
  }

 private:
  /// Every chain's layers in the topology's order, stitched.
  LayeredRepresentation layers() {
    rep_.points_per_layer = n_;
    rep_.chain_names = {"torso", "head", "left_leg", "right_leg", "left_arm", "right_arm"};
    torso();
    head();
    for (int side : {kLeft, kRight}) leg(side);
    for (int side : {kLeft, kRight}) arm(side);
    stitch();
    return std::move(rep_);
  }

  /// Adds one layer from the section polygon chosen by `pick` on the plane through `centre`.
  /// hull_of_nearby: the hull of the loops whose centres lie within nearby_radius of `centre`.
  /// same_side_of_x: for legs, neighbours must lie on the centre's side of this x (the other leg
  /// may be nearer than nearby_radius when the feet are together). `given`: the plane's section,
  /// cut already (an arm's, from the faces around it).
  void add_layer(int chain, const Eigen::Vector3d& centre, const Eigen::Vector3d& normal, int part, bool hull_of_nearby,
                 const std::vector<SectionLoop>* given = nullptr, double nearby_radius = 0.05,
                 double same_side_of_x = std::numeric_limits<double>::quiet_NaN()) {
    const Eigen::Vector3d n = normal.normalized();
    const bool horizontal = !given && n == Eigen::Vector3d::UnitY();
    if (collecting_) {
      if (horizontal) horizontal_heights_.push_back(centre.y());
      return;
    }
    Eigen::Vector3d front = Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ().dot(n) * n;
    if (front.norm() < 1e-6) front = n.unitOrthogonal();
    front.normalize();
    if (planning_) {
      const Eigen::Index row = static_cast<Eigen::Index>(rep_.layers.size()) * n_;
      points_.conservativeResize(row + n_, 3);
      points_.middleRows(row, n_).rowwise() = centre.transpose();
      rep_.layers.push_back({chain, centre, n, front, n.cross(front), part});
      return;
    }
    const auto cached = horizontal ? horizontal_sections_.find(centre.y()) : horizontal_sections_.end();
    std::vector<SectionLoop> sliced;
    if (!given && cached == horizontal_sections_.end()) sliced = slice_mesh(V_, F_, n, n.dot(centre));
    const std::vector<SectionLoop>& loops = given ? *given : cached != horizontal_sections_.end() ? cached->second : sliced;
    const int nearest = nearest_loop(loops, centre);
    if (nearest < 0)
      throw InvalidInput("layered representation: no section of the " + rep_.chain_names[chain] + " at " + std::to_string(centre.x()) +
                         ", " + std::to_string(centre.y()) + ", " + std::to_string(centre.z()));
    std::vector<Eigen::Vector3d> polygon;
    if (hull_of_nearby) {  // limbs: the nearest loop and its neighbours (fingers), as a tape would go
      const bool one_side = !std::isnan(same_side_of_x);
      const double own = centre.x() - same_side_of_x;
      for (size_t k = 0; k < loops.size(); ++k) {
        const Eigen::MatrixXd& P = loops[k].points;
        const Eigen::Vector3d c = P.colwise().mean().transpose();
        if (static_cast<int>(k) != nearest && ((c - centre).norm() > nearby_radius || (one_side && (c.x() - same_side_of_x) * own < 0)))
          continue;
        // A leg's section that reaches past the legs' middle (thighs pressed into each other, or
        // joined into one surface by a scan) is cut there: the part on this leg's side.
        for (Eigen::Index r = 0; r < P.rows(); ++r) {
          const Eigen::Vector3d p = P.row(r).transpose(), q = P.row((r + 1) % P.rows()).transpose();
          const double dp = p.x() - same_side_of_x, dq = q.x() - same_side_of_x;
          if (!one_side || dp * own >= 0) polygon.push_back(p);
          if (one_side && dp * dq < 0) polygon.push_back(p + dp / (dp - dq) * (q - p));
        }
      }
      polygon = planar_hull(polygon, n, front);
    } else {
      const Eigen::MatrixXd& P = loops[nearest].points;
      for (Eigen::Index r = 0; r < P.rows(); ++r) polygon.push_back(P.row(r).transpose());
    }
    if (polygon.size() < 3)
      throw InvalidInput("layered representation: degenerate section of the " + rep_.chain_names[chain] +
                         " (is the body standing in the standard pose?)");
    const Eigen::Index row = static_cast<Eigen::Index>(rep_.layers.size()) * n_;
    points_.conservativeResize(row + n_, 3);
    RepresentationLayer layer;
    layer.chain = chain;
    layer.normal = n;
    layer.front = front;
    layer.side = n.cross(front);
    layer.part = part;
    layer.centre = resample(polygon, n, front, n_, points_, row);
    rep_.layers.push_back(layer);
  }

  void torso() {
    const double span = std::min(f_.armpit[kLeft].y(), f_.armpit[kRight].y()) - f_.crotch_y;
    const double keys[] = {f_.crotch_y + 0.01,        f_.hip_y,        f_.waist_y, f_.underbust_y, f_.bust_y,
                           f_.crotch_y + span - 0.01, f_.neck_base.y()};
    int index = 0;
    for (int s = 0; s < 6; ++s)
      for (int k = 0; k < kTorsoSegments[s] + (s == 5); ++k, ++index) {
        const double y = keys[s] + (keys[s + 1] - keys[s]) * k / kTorsoSegments[s];
        const double t = (y - f_.crotch_y) / std::max(1e-6, f_.neck_base.y() - f_.crotch_y);
        const Eigen::Vector3d centre(f_.axis_x, y, f_.crotch.z() + t * (f_.neck_base.z() - f_.crotch.z()));
        const int part = index < kPelvisLayers ? kPelvis : (index < kPelvisLayers + kAbdomenLayers ? kAbdomen : kChest);
        add_layer(0, centre, Eigen::Vector3d::UnitY(), part, false);
      }
  }

  void head() {
    // Feature-aligned: kNeckSegments layers' spacing up to the narrowest neck section, the rest up
    // to the crown, so that the chin sits at the same layers on every body.
    const double y0 = f_.neck_base.y() + 0.005, y1 = f_.top_y - 0.01;
    const double y_neck = std::clamp(f_.neck_top.y(), y0 + 0.005, y1 - 0.05);
    for (int k = 0; k <= kHeadSegments; ++k) {
      const double y = k <= kNeckSegments ? y0 + (y_neck - y0) * k / kNeckSegments
                                          : y_neck + (y1 - y_neck) * (k - kNeckSegments) / (kHeadSegments - kNeckSegments);
      const double t = (y - f_.neck_base.y()) / std::max(1e-6, f_.neck_top.y() - f_.neck_base.y());
      const Eigen::Vector3d c = f_.neck_base + std::clamp(t, 0.0, 1.0) * (f_.neck_top - f_.neck_base);
      add_layer(1, Eigen::Vector3d(c.x(), y, c.z()), Eigen::Vector3d::UnitY(), kHead, false);
    }
  }

  void leg(int side) {
    auto keys_of = [&](int which) {
      const Eigen::Vector3d knee = f_.knee[which], ankle = f_.ankle[which];
      const Eigen::Vector3d top(knee.x() + 0.5 * (f_.axis_x - knee.x()) * 0.5, f_.crotch_y - 0.015, knee.z());
      const Eigen::Vector3d sole(ankle.x(), f_.floor_y + 0.005, ankle.z() + 0.03);
      return std::array<Eigen::Vector3d, 4>{top, knee, ankle, sole};
    };
    const auto keys = keys_of(side), other = keys_of(1 - side);
    const int parts[] = {side == kLeft ? kLeftThigh : kRightThigh, side == kLeft ? kLeftShank : kRightShank,
                         side == kLeft ? kLeftFoot : kRightFoot};
    for (int s = 0; s < 3; ++s)
      for (int k = 0; k < kLegSegments[s] + (s == 2); ++k) {
        const double t = static_cast<double>(k) / kLegSegments[s];
        const Eigen::Vector3d c = keys[s] + (keys[s + 1] - keys[s]) * t;
        const Eigen::Vector3d mirror = other[s] + (other[s + 1] - other[s]) * t;
        // Low on a high-arched foot the heel and the ball are separate loops 10-15 cm apart: the
        // foot's layers take both, but never a loop on the other leg's side of the two legs' middle.
        add_layer(2 + side, c, Eigen::Vector3d::UnitY(), parts[s], true, nullptr, s == 2 ? 0.15 : 0.05, 0.5 * (c.x() + mirror.x()));
      }
  }

  /// An arm's layer planes: centre, normal (up the limb, towards the body) and part.
  struct ArmPlane {
    Eigen::Vector3d centre, normal;
    int part;
  };
  std::array<Eigen::Vector3d, 4> arm_keys(int side) const {
    const Eigen::Vector3d shoulder = f_.shoulder[side], elbow = f_.elbow[side], wrist = f_.wrist[side];
    const Eigen::Vector3d tip = f_.hand_tip[side] - 0.01 * (f_.hand_tip[side] - wrist).normalized();
    return {shoulder + 0.35 * (elbow - shoulder), elbow, wrist, tip};
  }
  std::vector<ArmPlane> arm_planes(int side) const {
    const std::array<Eigen::Vector3d, 4> keys = arm_keys(side);
    const int parts[] = {side == kLeft ? kLeftUpperArm : kRightUpperArm, side == kLeft ? kLeftForearm : kRightForearm,
                         side == kLeft ? kLeftHand : kRightHand};
    std::vector<ArmPlane> out;
    for (int s = 0; s < 3; ++s)
      for (int k = 0; k < kArmSegments[s] + (s == 2); ++k) {
        const Eigen::Vector3d c = keys[s] + (keys[s + 1] - keys[s]) * (static_cast<double>(k) / kArmSegments[s]);
        Eigen::Vector3d dir = (keys[s + 1] - keys[s]).normalized();
        if (k == 0 && s > 0) dir = (dir + (keys[s] - keys[s - 1]).normalized()).normalized();  // at a joint
        out.push_back({c, -dir, parts[s]});
      }
    return out;
  }
  /// An arm's sections, cut from the faces around the arm only (its box grown by 8 cm).
  std::vector<std::vector<SectionLoop>> arm_sections(int side) const {
    const TriangleMesh arm_mesh = arm_faces(arm_keys(side));
    std::vector<std::vector<SectionLoop>> out;
    for (const ArmPlane& p : arm_planes(side)) {
      const Eigen::Vector3d n = p.normal.normalized();
      out.push_back(slice_mesh(arm_mesh.V, arm_mesh.F, n, n.dot(p.centre)));
    }
    return out;
  }

  void arm(int side) {
    const std::vector<ArmPlane> planes = arm_planes(side);
    for (size_t k = 0; k < planes.size(); ++k)
      add_layer(4 + side, planes[k].centre, planes[k].normal, planes[k].part, true, planning_ ? nullptr : &arm_sections_[side].at(k));
  }

  TriangleMesh arm_faces(const std::array<Eigen::Vector3d, 4>& keys) const {
    Eigen::Vector3d lo = keys[0], hi = keys[0];
    for (const auto& k : keys) lo = lo.cwiseMin(k), hi = hi.cwiseMax(k);
    lo.array() -= 0.08;
    hi.array() += 0.08;
    std::vector<bool> kept_face(static_cast<size_t>(F_.rows()), false);
    for (Eigen::Index f = 0; f < F_.rows(); ++f)
      for (int c = 0; c < 3 && !kept_face[f]; ++c)
        kept_face[f] =
            (V_.row(F_(f, c)).transpose().array() >= lo.array()).all() && (V_.row(F_(f, c)).transpose().array() <= hi.array()).all();
    TriangleMesh whole;
    whole.V = V_;
    whole.F = F_;
    return extract_faces(whole, kept_face);  // re-indexed: a section visits only the arm
  }

  void stitch() {
    rep_.mesh.V = points_;
    std::vector<int> tris, part, layer;
    for (size_t i = 0; i + 1 < rep_.layers.size(); ++i) {
      if (rep_.layers[i].chain != rep_.layers[i + 1].chain) continue;
      const int a = static_cast<int>(i) * n_, b = static_cast<int>(i + 1) * n_;
      for (int k = 0; k < n_; ++k) {
        const int k1 = (k + 1) % n_;
        tris.insert(tris.end(), {a + k, a + k1, b + k1, a + k, b + k1, b + k});
        part.insert(part.end(), 2, rep_.layers[i].part);
        layer.insert(layer.end(), 2, static_cast<int>(i));
      }
    }
    rep_.mesh.F =
        Eigen::Map<Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
    rep_.triangle_part = Eigen::Map<Eigen::VectorXi>(part.data(), static_cast<Eigen::Index>(part.size()));
    rep_.triangle_layer = Eigen::Map<Eigen::VectorXi>(layer.data(), static_cast<Eigen::Index>(layer.size()));
    // Torso and head layers advance along their normals, legs and arms against them: flipping the
    // latter makes every triangle face outwards, with the same connectivity for every body.
    for (Eigen::Index t = 0; t < rep_.mesh.F.rows(); ++t)
      if (rep_.layers[rep_.triangle_layer[t]].chain >= 2) std::swap(rep_.mesh.F(t, 1), rep_.mesh.F(t, 2));
  }

  const Eigen::MatrixXd& V_;
  const Eigen::MatrixXi& F_;
  const BodyFeatures& f_;
  int n_, threads_;
  bool collecting_ = false, planning_ = false;
  std::vector<double> horizontal_heights_;
  std::map<double, std::vector<SectionLoop>> horizontal_sections_;
  std::vector<std::vector<SectionLoop>> arm_sections_[2];  ///< each arm layer's section, in arm_planes' order
  Eigen::MatrixXd points_;
  LayeredRepresentation rep_;
};

}  // namespace

LayeredRepresentation plan_layered_representation(const BodyFeatures& f, int points_per_layer) {
  if (points_per_layer < 8) throw InvalidInput("layered representation: at least 8 points per layer");
  const Eigen::MatrixXd none;
  const Eigen::MatrixXi no_faces;
  return Builder(none, no_faces, f, points_per_layer).plan();
}

int representation_layer_count() {
  int n = 1 + kHeadSegments;
  for (int s : kTorsoSegments) n += s;
  n += 1;
  for (int s : kLegSegments) n += 2 * s;
  n += 2;
  for (int s : kArmSegments) n += 2 * s;
  n += 2;
  return n;
}

LayeredRepresentation build_layered_representation_on_surface(const TriangleMesh& surface, const BodyFeatures& f, int points_per_layer,
                                                              int threads) {
  if (points_per_layer < 8) throw InvalidInput("layered representation: at least 8 points per layer");
  for (int side : {kLeft, kRight})
    if (!f.arm_found[side]) throw InvalidInput("layered representation: an arm was not found (see the features' warnings)");
  return Builder(surface.V, surface.F, f, points_per_layer, threads).build();
}

LayeredRepresentation build_layered_representation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const BodyFeatures& f,
                                                   int points_per_layer) {
  // Sections are cut from the surface the features were found on: floating bits left out and holes
  // closed, so that a section across a scan's hole is a closed loop, not an open polyline.
  return build_layered_representation_on_surface(body_surface(V, F), f, points_per_layer);
}

}  // namespace posekit
