#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "customization_detail.h"
#include "posekit/core/error.h"
#include "posekit/customization/photo_customization.h"

namespace posekit {
namespace {

struct Run {
  int u0 = 0, u1 = -1;  // inclusive
  double centre() const { return 0.5 * (u0 + u1 + 1); }
  int width() const { return u1 - u0 + 1; }
  bool contains(double u) const { return u >= u0 && u < u1 + 1; }
};

std::vector<Run> runs_of(const Silhouette& s, int v) {
  std::vector<Run> out;
  if (v < 0 || v >= s.height) return out;
  for (int u = 0; u < s.width;) {
    if (!s.inside(u, v)) {
      ++u;
      continue;
    }
    Run r;
    r.u0 = u;
    while (u < s.width && s.inside(u, v)) ++u;
    r.u1 = u - 1;
    out.push_back(r);
  }
  return out;
}

/// The run containing u, or the nearest one within max_gap pixels (nullptr).
const Run* run_at(const std::vector<Run>& runs, double u, double max_gap = 3) {
  const Run* best = nullptr;
  double best_d = max_gap;
  for (const Run& r : runs) {
    const double d = r.contains(u) ? 0 : std::min(std::abs(u - r.u0), std::abs(u - (r.u1 + 1)));
    if (d <= best_d) best_d = d, best = &r;
  }
  return best;
}

/// Point nearest both optical axes: where the person stands.
Eigen::Vector3d meeting_point(const PinholeCamera& a, const PinholeCamera& b) {
  const Eigen::Vector3d p = a.centre(), q = b.centre(), d = a.R.row(2).transpose(), e = b.R.row(2).transpose();
  const double dd = d.dot(d), de = d.dot(e), ee = e.dot(e), dw = d.dot(p - q), ew = e.dot(p - q);
  const double den = dd * ee - de * de;
  if (std::abs(den) < 1e-9) throw InvalidInput("the front and side cameras look the same way: not orthogonal views");
  const double s = (de * ew - ee * dw) / den, t = (dd * ew - de * dw) / den;
  return 0.5 * ((p + s * d) + (q + t * e));
}

double ramanujan(double a, double b) { return M_PI * (3 * (a + b) - std::sqrt((3 * a + b) * (a + 3 * b))); }

class Finder {
 public:
  Finder(const Silhouette& front, const Silhouette& side, const PhotoCameras& cams, const ArmChains* arms)
      : fs_(front), ss_(side), fc_(cams.front), sc_(cams.side), arms_(arms) {
    p0_ = meeting_point(fc_, sc_);
    x_dir_ = project(fc_, p0_ + Eigen::Vector3d::UnitX()).x() > project(fc_, p0_).x() ? 1 : -1;
  }

  PhotoLandmarks find() {
    PhotoLandmarks L;
    FrontRows rows;
    rows.top = fs_.top(), rows.bottom = fs_.bottom(), rows.height = rows.bottom - rows.top;
    find_axis(rows);
    find_crotch(&rows, &L);
    find_armpits(&rows);
    find_neck(&rows);
    follow_arms(&rows);
    place_levels(rows, &L);
    std::vector<double> d;
    describe_head_and_arms(rows, &L, &d);
    describe_torso(&L, &d);
    describe_legs(L, &d);
    L.descriptor = Eigen::Map<Eigen::VectorXd>(d.data(), static_cast<Eigen::Index>(d.size()));
    L.side_arm_occlusion = side_arm_occlusion(L);
    return L;
  }

  /// Rows (front photo's pixels) of the landmarks, found top-down.
  struct FrontRows {
    int top = 0, bottom = 0, height = 0;  ///< the figure
    int crotch = -1, armpit[2] = {-1, -1};
    int head = 0, neck = 0;  ///< the head's widest row and the narrowest below it
    double head_width = 0, neck_width = 1e9;
    std::vector<Eigen::Vector2d> arm_track[2];  ///< (u, v) centres of each arm's runs, down from the armpit
  };

  /// The body axis: the torso run's centre a little below the middle of the figure.
  void find_axis(const FrontRows& rows) {
    const int top = rows.top, H = rows.height;
    std::vector<double> centres;
    double mid_u = 0;
    long count = 0;
    for (int v = top + static_cast<int>(0.40 * H); v <= top + static_cast<int>(0.50 * H); ++v)
      for (int u = 0; u < fs_.width; ++u)
        if (fs_.inside(u, v)) mid_u += u + 0.5, ++count;
    mid_u /= std::max(1L, count);
    for (int v = top + static_cast<int>(0.38 * H); v <= top + static_cast<int>(0.48 * H); ++v) {
      const auto runs = runs_of(fs_, v);
      if (const Run* r = run_at(runs, mid_u, 1e9)) centres.push_back(r->centre());
    }
    if (centres.empty()) throw InvalidInput("front photo: no torso found");
    std::nth_element(centres.begin(), centres.begin() + centres.size() / 2, centres.end());
    axis_u_ = centres[centres.size() / 2];
  }

  /// The crotch: the top of the gap between the legs, 3 rows of it at least.
  void find_crotch(FrontRows* rows, PhotoLandmarks* L) const {
    const int top = rows->top, H = rows->height;
    for (int v = top + static_cast<int>(0.42 * H); v < rows->bottom - 3 && rows->crotch < 0; ++v) {
      bool gap = true;
      for (int k = 0; k < 3 && gap; ++k) gap = !fs_.inside(static_cast<int>(axis_u_), v + k);
      if (gap) rows->crotch = v - 1;
    }
    if (rows->crotch < 0 || rows->crotch > top + 0.66 * H)
      throw InvalidInput(
          "front photo: no gap between the legs below the torso: the person must stand facing the camera, "
          "feet apart (is the side photo given as front?)");
    if (rows->crotch > top + 0.58 * H) L->warnings.push_back("front photo: the legs touch below the crotch; its level is uncertain");
  }

  /// The armpits: the top of the gap between the torso and each arm, searched down from below the
  /// head (a thick arm may touch the waist lower down).
  void find_armpits(FrontRows* rows) const {
    const int top = rows->top, H = rows->height;
    for (int side : {kLeft, kRight}) {
      const int dir = side == kLeft ? x_dir_ : -x_dir_;
      for (int v = top + static_cast<int>(0.12 * H); v < rows->crotch && rows->armpit[side] < 0; ++v) {
        bool open = true;  // 8 rows: a noisy outline may open a gap for a row or two
        for (int k = 0; k < 8 && open; ++k) open = gap_beside_torso(v + k, dir);
        if (open) rows->armpit[side] = v;
      }
      if (rows->armpit[side] < 0)
        throw InvalidInput(std::string("front photo: the ") + (side == kLeft ? "left" : "right") +
                           " arm touches the torso all the way: hold the arms away from the body (the standard pose)");
    }
    const int armpit_top = std::min(rows->armpit[0], rows->armpit[1]);
    if (armpit_top < top + 0.1 * H || armpit_top > rows->crotch - 0.12 * H)
      throw InvalidInput("front photo: armpits found at implausible heights (is the person standing in the standard pose?)");
  }

  /// The neck: the narrowest torso row between the head's widest and the armpits.
  void find_neck(FrontRows* rows) const {
    const int top = rows->top;
    rows->head = rows->neck = top;
    for (int v = top; v <= top + 0.13 * rows->height; ++v) {
      const auto runs = runs_of(fs_, v);
      if (const Run* r = run_at(runs, axis_u_))
        if (r->width() > rows->head_width) rows->head_width = r->width(), rows->head = v;
    }
    for (int v = rows->head; v < std::min(rows->armpit[0], rows->armpit[1]); ++v) {
      const auto runs = runs_of(fs_, v);
      if (const Run* r = run_at(runs, axis_u_))
        if (r->width() < rows->neck_width) rows->neck_width = r->width(), rows->neck = v;
    }
  }

  /// Each arm followed down from below its armpit by overlapping runs.
  void follow_arms(FrontRows* rows) const {
    for (int side : {kLeft, kRight}) {
      const int dir = side == kLeft ? x_dir_ : -x_dir_;
      std::vector<Eigen::Vector2d>& track = rows->arm_track[side];
      Run prev;
      bool have = false;
      for (int v = rows->armpit[side] + 3; v < rows->bottom; ++v) {
        const auto runs = runs_of(fs_, v);
        const Run* torso = run_at(runs, axis_u_);
        const Run* next = nullptr;
        if (!have) {
          for (const Run& r : runs)
            if (torso && (dir > 0 ? r.u0 > torso->u1 : r.u1 < torso->u0) &&
                (!next || std::abs(r.centre() - axis_u_) < std::abs(next->centre() - axis_u_)))
              next = &r;
        } else {
          int best = 0;
          for (const Run& r : runs) {
            const int overlap = std::min(r.u1, prev.u1 + 2) - std::max(r.u0, prev.u0 - 2) + 1;
            if (overlap > best && !r.contains(axis_u_)) best = overlap, next = &r;
          }
          if (next && next->width() > 2.5 * prev.width() + 4) next = nullptr;  // merged with a thigh
        }
        if (!next && !have && v < rows->armpit[side] + 3 + 0.05 * rows->height) continue;  // a bridge of noise under the armpit
        if (!next) break;
        prev = *next;
        have = true;
        track.emplace_back(next->centre(), v + 0.5);
      }
      if (track.size() < 10)
        throw InvalidInput(std::string("front photo: the ") + (side == kLeft ? "left" : "right") +
                           " arm cannot be followed below the armpit");
    }
  }

  /// World height of a front photo row on the body's axis, at the depth of the views' meeting point.
  double y_of_row(double v) const { return point_at_depth(fc_, axis_u_, v, depth_of(fc_, p0_)).y(); }

  /// The world levels of the rows, the body's axis (the torso's centre in both views), the floor,
  /// the crown and the stature.
  void place_levels(const FrontRows& rows, PhotoLandmarks* L) const {
    const double crotch_y = y_of_row(rows.crotch + 1), armpit_y[2] = {y_of_row(rows.armpit[0]), y_of_row(rows.armpit[1])};
    L->axis_x = point_at_depth(fc_, axis_u_, 0.5 * (rows.top + rows.bottom), depth_of(fc_, p0_)).x();
    L->axis_z = p0_.z();
    // The torso's depth centre: the median over its height of the side run's centre (forearms in
    // front of the belly widen a few of them).
    std::vector<double> zs, xs;
    const double lo = crotch_y, hi = std::min(armpit_y[0], armpit_y[1]);
    for (int k = 1; k < 10; ++k) {
      const Section s = torso_section(lo + (hi - lo) * k / 10.0, L->axis_x, L->axis_z);
      if (s.valid) zs.push_back(s.zc), xs.push_back(s.xc);
    }
    if (zs.size() < 3) throw InvalidInput("photos: the torso is not found in the side photo at the front photo's levels");
    std::nth_element(zs.begin(), zs.begin() + zs.size() / 2, zs.end());
    std::nth_element(xs.begin(), xs.begin() + xs.size() / 2, xs.end());
    L->axis_z = zs[zs.size() / 2];
    L->axis_x = xs[xs.size() / 2];
    L->crotch_y = crotch_y;
    L->armpit_y[0] = armpit_y[0], L->armpit_y[1] = armpit_y[1];
    L->neck_y = y_of_row(rows.neck + 0.5);
    // Floor and crown from both views.
    L->floor_y = floor_level(*L);
    L->crown_y = crown_level();
    L->stature = L->crown_y - L->floor_y;
    if (!(L->stature > 0.5 && L->stature < 2.6))
      throw InvalidInput("photos: a stature of " + std::to_string(L->stature) + " m: check the camera file or the stated height");
  }

  /// The descriptor's levels, neck and head, and six points down each arm (the hand tips kept).
  void describe_head_and_arms(const FrontRows& rows, PhotoLandmarks* L, std::vector<double>* d) const {
    const double mid_y = 0.5 * (L->crotch_y + std::min(L->armpit_y[0], L->armpit_y[1]));
    const double body_depth = depth_of(fc_, Eigen::Vector3d(L->axis_x, mid_y, L->axis_z));
    auto world_xy = [&](const Eigen::Vector2d& uv, int side) {
      const Eigen::Vector3d p = arms_ && arms_->chain[side].size() >= 2 ? nearest_on_ray(fc_, uv, arms_->chain[side])
                                                                        : point_at_depth(fc_, uv.x(), uv.y(), body_depth);
      return Eigen::Vector2d(p.x() - L->axis_x, p.y() - L->floor_y);
    };
    d->insert(d->end(),
              {L->stature, L->crotch_y - L->floor_y, L->armpit_y[0] - L->floor_y, L->armpit_y[1] - L->floor_y, L->neck_y - L->floor_y,
               rows.neck_width * body_depth / fc_.fx, rows.head_width * body_depth / fc_.fx, y_of_row(rows.head) - L->floor_y});
    for (int side : {kLeft, kRight}) {
      const auto& track = rows.arm_track[side];
      const Eigen::Vector2d tip = world_xy(track.back(), side);
      L->hand_tip[side] = Eigen::Vector2d(tip.x() + L->axis_x, tip.y() + L->floor_y);
      for (double f : {0.0, 0.2, 0.4, 0.6, 0.8, 1.0}) {
        const Eigen::Vector2d p = world_xy(track[static_cast<size_t>(f * (track.size() - 1))], side);
        d->insert(d->end(), {p.x(), p.y()});
      }
    }
  }

  /// The torso's profile at 9 levels from the crotch to the lower armpit and at the neck, and the
  /// elliptic girths every centimetre that place the hip, waist and bust.
  void describe_torso(PhotoLandmarks* L, std::vector<double>* d) const {
    const double span = std::min(L->armpit_y[0], L->armpit_y[1]) - L->crotch_y;
    for (int k = 0; k <= 8; ++k) {
      const Section s = torso_section(L->crotch_y + 0.03 + (span - 0.05) * k / 8.0, L->axis_x, L->axis_z);
      if (!s.valid)
        throw InvalidInput("photos: the torso is not seen in both photos at " + std::to_string(k) + "/8 of the crotch-to-armpit span");
      d->insert(d->end(), {s.x1 - s.x0, s.xc - L->axis_x, s.z1 - s.z0, s.zc - L->axis_z});
    }
    const Section neck = torso_section(L->neck_y, L->axis_x, L->axis_z);
    d->insert(d->end(), {neck.valid ? neck.z1 - neck.z0 : 0, neck.valid ? neck.zc - L->axis_z : 0});
    double best_hip = -1, best_waist = 1e9, best_bust = -1, hip_ratio = 0;
    for (double y = L->crotch_y + 0.01; y < L->crotch_y + span - 0.01; y += 0.01) {
      const Section s = torso_section(y, L->axis_x, L->axis_z);
      if (!s.valid) continue;
      const double g = ramanujan(0.5 * (s.x1 - s.x0), 0.5 * (s.z1 - s.z0)), t = (y - L->crotch_y) / span;
      if (t < 0.4 && g > best_hip) best_hip = g, L->hip_y = y, hip_ratio = (s.x1 - s.x0) / (s.z1 - s.z0);
      if (t > 0.3 && t < 0.8 && g < best_waist) best_waist = g, L->waist_y = y;
      if (t > 0.6 && g > best_bust) best_bust = g, L->bust_y = y;
    }
    // A pelvis is wider than deep, whatever the belly does (the side view's hands may add depth).
    L->front_to_side_ratio = hip_ratio;
    if (hip_ratio > 0 && hip_ratio < 0.6)
      L->warnings.push_back("photos: the hips look deeper in the side photo than wide in the front one (ratio " +
                            std::to_string(hip_ratio).substr(0, 4) + "): front and side swapped, or the hands held in front?");
    d->insert(d->end(), {L->hip_y - L->floor_y, L->waist_y - L->floor_y, L->bust_y - L->floor_y, best_hip, best_waist, best_bust});
  }

  /// The legs: centre and width in front, depth and centre in the side view, at 4 levels.
  void describe_legs(const PhotoLandmarks& L, std::vector<double>* d) const {
    for (double f : {0.15, 0.4, 0.65, 0.9}) {
      const double y = L.crotch_y - f * (L.crotch_y - L.floor_y);
      for (int side : {kLeft, kRight}) {
        const Section s = leg_section(y, side, L);
        d->insert(d->end(), {s.x1 - s.x0, s.xc - L.axis_x});
        if (side == kLeft) d->insert(d->end(), {s.z1 - s.z0, s.zc - L.axis_z});
      }
    }
  }

  /// The point of the ray through pixel uv nearest the polyline `chain`.
  static Eigen::Vector3d nearest_on_ray(const PinholeCamera& c, const Eigen::Vector2d& uv, const std::vector<Eigen::Vector3d>& chain) {
    const Eigen::Vector3d o = c.centre(), d = c.ray(uv.x(), uv.y());
    double best = std::numeric_limits<double>::max();
    Eigen::Vector3d out = o + depth_of(c, chain.front()) / d.dot(c.R.row(2).transpose()) * d;
    for (size_t k = 0; k + 1 < chain.size(); ++k) {
      // Closest points of the line o + t d and the segment a + s (b - a), s in [0, 1].
      const Eigen::Vector3d a = chain[k], e = chain[k + 1] - a, w = o - a;
      const double ee = e.dot(e), de = d.dot(e), dw = d.dot(w), ew = e.dot(w), den = ee - de * de;
      double s = den > 1e-12 ? std::clamp((ew - de * dw) / den, 0.0, 1.0) : 0.0;
      const double t = std::max(0.0, de * s - dw);
      s = ee > 1e-12 ? std::clamp((t * de + ew) / ee, 0.0, 1.0) : 0.0;
      const Eigen::Vector3d on_ray = o + t * d;
      const double dist = (on_ray - (a + s * e)).squaredNorm();
      if (dist < best) best = dist, out = on_ray;
    }
    return out;
  }

  struct Section {
    bool valid = false;
    double x0 = 0, x1 = 0, z0 = 0, z1 = 0, xc = 0, zc = 0;
  };

 private:
  bool gap_beside_torso(int v, int dir) const {
    const auto runs = runs_of(fs_, v);
    const Run* torso = run_at(runs, axis_u_);
    if (!torso) return false;
    for (const Run& r : runs)
      if (dir > 0 ? r.u0 > torso->u1 : r.u1 < torso->u0) return true;
    return false;
  }

  /// World interval along X (front) or Z (side) of the run nearest a reference point's image.
  bool interval(const Silhouette& s, const PinholeCamera& c, const Eigen::Vector3d& ref, int axis, double* lo, double* hi,
                double max_gap = 3) const {
    const Eigen::Vector2d uv = project(c, ref);
    const int v = static_cast<int>(std::floor(uv.y()));
    const auto runs = runs_of(s, v);
    const Run* r = run_at(runs, uv.x(), max_gap);
    if (!r) return false;
    const double depth = depth_of(c, ref);
    const double a = point_at_depth(c, r->u0, uv.y(), depth)[axis], b = point_at_depth(c, r->u1 + 1, uv.y(), depth)[axis];
    *lo = std::min(a, b), *hi = std::max(a, b);
    return true;
  }

  Section torso_section(double y, double x, double z) const {
    Section s;
    for (int pass = 0; pass < 2; ++pass) {
      if (!interval(fs_, fc_, Eigen::Vector3d(x, y, z), 0, &s.x0, &s.x1) ||
          !interval(ss_, sc_, Eigen::Vector3d(x, y, z), 2, &s.z0, &s.z1, 40))
        return s;
      x = s.xc = 0.5 * (s.x0 + s.x1);
      z = s.zc = 0.5 * (s.z0 + s.z1);
    }
    s.valid = true;
    return s;
  }

  Section leg_section(double y, int side, const PhotoLandmarks& L) const {
    Section s;
    // The leg's run: the first beyond the axis on its side (the hand, if any, is farther out).
    const int dir = side == kLeft ? x_dir_ : -x_dir_;
    const Eigen::Vector2d a = project(fc_, Eigen::Vector3d(L.axis_x, y, L.axis_z));
    const auto runs = runs_of(fs_, static_cast<int>(std::floor(a.y())));
    const Run* leg = nullptr;
    for (const Run& r : runs) {
      const double far = dir > 0 ? r.u1 + 1 - a.x() : a.x() - r.u0;
      if (far <= 0) continue;
      if (!leg || std::abs(r.centre() - a.x()) < std::abs(leg->centre() - a.x())) leg = &r;
    }
    if (!leg) return s;
    // Touching legs: the part on this side of the axis.
    const double u0 = dir > 0 ? std::max<double>(leg->u0, a.x()) : leg->u0,
                 u1 = dir > 0 ? leg->u1 + 1 : std::min<double>(leg->u1 + 1, a.x());
    const double depth = depth_of(fc_, Eigen::Vector3d(L.axis_x, y, L.axis_z));
    const double xa = point_at_depth(fc_, u0, a.y(), depth).x(), xb = point_at_depth(fc_, u1, a.y(), depth).x();
    s.x0 = std::min(xa, xb), s.x1 = std::max(xa, xb), s.xc = 0.5 * (s.x0 + s.x1);
    if (!interval(ss_, sc_, Eigen::Vector3d(s.xc, y, L.axis_z), 2, &s.z0, &s.z1, 40)) return s;
    s.zc = 0.5 * (s.z0 + s.z1);
    s.valid = true;
    return s;
  }

  /// Levels where a forearm held in front of the body hides the torso's front outline in the side
  /// photo: each hand is followed up from its tip while it stands clear in front of the torso, the
  /// forearm's band (a line fit to its centres, its mean width) is carried on upwards, and the
  /// levels where it reaches the outline are returned as (low, high) world heights.
  std::vector<std::pair<double, double>> side_arm_occlusion(const PhotoLandmarks& L) const {
    std::vector<std::pair<double, double>> out;
    const Eigen::Vector3d centre(L.axis_x, 0.5 * (L.crotch_y + L.armpit_y[0]), L.axis_z);
    const double fdir = project(sc_, centre + 0.1 * Eigen::Vector3d::UnitZ()).x() > project(sc_, centre).x() ? 1 : -1;
    auto row_of = [&](double y) { return project(sc_, Eigen::Vector3d(L.axis_x, y, L.axis_z)); };
    auto y_of = [&](double v) { return point_at_depth(sc_, row_of(centre.y()).x(), v, depth_of(sc_, centre)).y(); };
    const int top_row = static_cast<int>(row_of(std::min(L.armpit_y[0], L.armpit_y[1])).y());
    const int tip_row = static_cast<int>(row_of(std::min(L.hand_tip[0].y(), L.hand_tip[1].y())).y());
    struct Band {
      int v;
      double c, w;
    };
    std::vector<Band> track;
    for (int v = tip_row; v > top_row; --v) {
      const auto runs = runs_of(ss_, v);
      const Run* torso = run_at(runs, row_of(y_of(v + 0.5)).x(), 40);
      if (!torso) break;
      const Run* arm = nullptr;
      for (const Run& r : runs) {
        const bool in_front = fdir < 0 ? r.u1 < torso->u0 : r.u0 > torso->u1;
        if (in_front && (!arm || std::abs(r.centre() - torso->centre()) < std::abs(arm->centre() - torso->centre()))) arm = &r;
      }
      if (arm) track.push_back({v, arm->centre(), static_cast<double>(arm->width())});
      else if (!track.empty() && track.back().v - v > 3) break;  // merged with the torso
    }
    if (track.size() < 12) return out;
    // The forearm near the merge: the last 40 rows followed (fingers and palm lie lower).
    const size_t first = track.size() > 40 ? track.size() - 40 : 0;
    double sv = 0, sc = 0, svv = 0, svc = 0, sw = 0;
    const double m = static_cast<double>(track.size() - first);
    for (size_t k = first; k < track.size(); ++k)
      sv += track[k].v, sc += track[k].c, svv += double(track[k].v) * track[k].v, svc += track[k].v * track[k].c, sw += track[k].w;
    const double den = m * svv - sv * sv;
    if (std::abs(den) < 1e-9) return out;
    const double slope = (m * svc - sv * sc) / den, offset = (sc - slope * sv) / m;
    // Its width across the band: the horizontal run times the cosine of the band's tilt.
    const double half = 0.5 * (sw / m);
    const int merge = track.back().v;
    const double reach_px = 0.3 * sc_.fx / depth_of(sc_, centre);  // a forearm and elbow: 30 cm at most
    int lo = -1, hi = -1;
    for (int v = merge; v > std::max(top_row, merge - static_cast<int>(reach_px)); --v) {
      const auto runs = runs_of(ss_, v);
      const Run* torso = run_at(runs, row_of(y_of(v + 0.5)).x(), 40);
      if (!torso) continue;
      const double c = offset + slope * v;
      const double torso_front = fdir < 0 ? torso->u0 : torso->u1 + 1;
      const double arm_back = fdir < 0 ? c + half : c - half, arm_front = fdir < 0 ? c - half : c + half;
      // The arm hides the outline while its band reaches it and it is not already inside the torso.
      const bool reaches = fdir < 0 ? arm_back + 2 >= torso_front : arm_back - 2 <= torso_front;
      const bool outside = fdir < 0 ? arm_front <= torso_front + 2 : arm_front >= torso_front - 2;
      if (reaches && outside) {
        if (lo < 0) lo = v;
        hi = v;
      } else if (lo >= 0) {
        break;
      }
    }
    if (lo >= 0) out.emplace_back(y_of(lo + 1), y_of(hi));
    return out;
  }

  /// The soles: the lowest row of each view taken at the depth of the feet's nearest extent seen in
  /// the other view (the toes for the front camera, the outer foot for the side camera). The extents
  /// are read over the feet's rows (10 cm up from each view's lowest row): a camera above the feet
  /// sees the toe tip well above the side view's lowest rows (60 px at 2.3 m and 1.3 m high).
  double floor_level(const PhotoLandmarks& L) const {
    const int fb = fs_.bottom(), sb = ss_.bottom();
    double toe = -1e9, outer = -1e9;
    const Eigen::Vector3d front_dir = -fc_.R.row(2).transpose(), side_dir = -sc_.R.row(2).transpose();  // towards each camera
    const double ref_depth_f = depth_of(fc_, p0_), ref_depth_s = depth_of(sc_, p0_);
    const int band_s = static_cast<int>(std::ceil(0.1 * sc_.fy / ref_depth_s)),
              band_f = static_cast<int>(std::ceil(0.1 * fc_.fy / ref_depth_f));
    for (int v = sb - band_s; v <= sb; ++v)
      for (const Run& r : runs_of(ss_, v))
        for (double u : {double(r.u0), r.u1 + 1.0}) toe = std::max(toe, point_at_depth(sc_, u, v, ref_depth_s).dot(front_dir));
    for (int v = fb - band_f; v <= fb; ++v)
      for (const Run& r : runs_of(fs_, v))
        for (double u : {double(r.u0), r.u1 + 1.0}) outer = std::max(outer, point_at_depth(fc_, u, v, ref_depth_f).dot(side_dir));
    const double df = depth_of(fc_, p0_) - (toe - p0_.dot(front_dir)), ds = depth_of(sc_, p0_) - (outer - p0_.dot(side_dir));
    const double yf = point_at_depth(fc_, axis_u_, fb + 1, df).y();
    const double us = project(sc_, Eigen::Vector3d(L.axis_x, L.crotch_y, L.axis_z)).x();
    const double ys = point_at_depth(sc_, us, sb + 1, ds).y();
    return 0.5 * (yf + ys);
  }

  /// The crown: the two views' top points triangulated.
  double crown_level() const {
    const int ft = fs_.top(), st = ss_.top();
    const Run* a = nullptr;
    const auto fr = runs_of(fs_, ft), sr = runs_of(ss_, st);
    a = &fr.front();
    const Run* b = &sr.front();
    const Eigen::Vector3d p = fc_.centre(), q = sc_.centre(), d = fc_.ray(a->centre(), ft), e = sc_.ray(b->centre(), st);
    const double dd = d.dot(d), de = d.dot(e), ee = e.dot(e), dw = d.dot(p - q), ew = e.dot(p - q);
    const double den = dd * ee - de * de;
    if (std::abs(den) < 1e-12) return point_at_depth(fc_, a->centre(), ft, depth_of(fc_, p0_)).y();
    const double s = (de * ew - ee * dw) / den, t = (dd * ew - de * dw) / den;
    return 0.5 * ((p + s * d).y() + (q + t * e).y());
  }

  const Silhouette &fs_, &ss_;
  const PinholeCamera &fc_, &sc_;
  const ArmChains* arms_;
  Eigen::Vector3d p0_;
  int x_dir_ = 1;
  double axis_u_ = 0;
};

/// Inside intervals of a walk along `dir` from `c` (1 mm steps over +-reach), seen by one camera:
/// the one holding c, or the nearest within 8 cm.
bool walk(const Silhouette& s, const PinholeCamera& cam, const Eigen::Vector3d& c, const Eigen::Vector3d& dir, double lo_limit,
          double hi_limit, double* lo, double* hi) {
  constexpr double kStep = 0.001;
  const int n0 = static_cast<int>(std::floor(lo_limit / kStep)), n1 = static_cast<int>(std::ceil(hi_limit / kStep));
  auto in = [&](int k) {
    const Eigen::Vector2d uv = project(cam, c + (k * kStep) * dir);
    return s.inside(static_cast<int>(std::floor(uv.x())), static_cast<int>(std::floor(uv.y())));
  };
  int start = 0;
  if (!in(0)) {
    start = std::numeric_limits<int>::max();
    for (int k = 1; k <= 80 && start == std::numeric_limits<int>::max(); ++k) {
      if (k <= n1 && in(k)) start = k;
      else if (-k >= n0 && in(-k)) start = -k;
    }
    if (start == std::numeric_limits<int>::max()) return false;
  }
  int a = start, b = start;
  while (a - 1 >= n0 && in(a - 1)) --a;
  while (b + 1 <= n1 && in(b + 1)) ++b;
  *lo = (a - 0.5) * kStep;
  *hi = (b + 0.5) * kStep;
  return true;
}

}  // namespace

std::vector<int> descriptor_arm_entries(int side) {
  // The order of Finder::find's pushes: stature, crotch, the armpits (left, right), neck level, neck
  // and head width, head level, then each arm's 12 profile numbers (left, right).
  std::vector<int> out = {side == kLeft ? 2 : 3};
  for (int k = 0; k < 12; ++k) out.push_back((side == kLeft ? 8 : 20) + k);
  return out;
}

ArmChains arm_chains(const BodyFeatures& f) {
  ArmChains out;
  for (int side : {kLeft, kRight})
    for (const Eigen::Vector3d& p : {f.shoulder[side], f.elbow[side], f.wrist[side], f.hand_tip[side]})
      if (p.allFinite()) out.chain[side].push_back(p);
  return out;
}

PhotoLandmarks find_photo_landmarks(const Silhouette& front, const Silhouette& side, const PhotoCameras& cameras, const ArmChains* arms) {
  check_silhouette(front, "front photo");
  check_silhouette(side, "side photo");
  for (const auto& [s, c, what] :
       {std::tuple<const Silhouette&, const PinholeCamera&, const char*>{front, cameras.front, "front"}, {side, cameras.side, "side"}})
    if (s.width != c.width || s.height != c.height)
      throw InvalidInput(std::string(what) + " photo is " + std::to_string(s.width) + "x" + std::to_string(s.height) + " but its camera " +
                         std::to_string(c.width) + "x" + std::to_string(c.height));
  return Finder(front, side, cameras, arms).find();
}

std::vector<LayerExtent> measure_layers(const LayeredRepresentation& rep, const Silhouette& front, const Silhouette& side,
                                        const PhotoCameras& cams, double legs_middle_x,
                                        const std::vector<std::pair<double, double>>& side_occlusion) {
  std::vector<LayerExtent> out(rep.layers.size());
  for (size_t i = 0; i < rep.layers.size(); ++i) {
    const RepresentationLayer& L = rep.layers[i];
    const bool leg = L.chain == 2 || L.chain == 3, arm = L.chain >= 4;
    double lo_limit = -0.6, hi_limit = 0.6;
    if (leg) {  // not past the legs' middle
      const double to_middle = (legs_middle_x - L.centre.x()) / (std::abs(L.side.x()) > 1e-6 ? L.side.x() : 1e-6);
      (to_middle > 0 ? hi_limit : lo_limit) = std::clamp(to_middle, -0.6, 0.6);
    }
    double w0, w1;
    if (!walk(front, cams.front, L.centre, L.side, lo_limit, hi_limit, &w0, &w1))
      throw InvalidInput("photos: layer " + std::to_string(i) + " of the " + rep.chain_names[L.chain] + " (at " +
                         std::to_string(L.centre.y()).substr(0, 5) + " m) is not in the front silhouette");
    LayerExtent e;
    e.half_width = 0.5 * (w1 - w0);
    e.box_centre = L.centre + 0.5 * (w0 + w1) * L.side;
    if (!arm) {
      double d0, d1;
      if (!walk(side, cams.side, e.box_centre, L.front, -0.6, 0.6, &d0, &d1))
        throw InvalidInput("photos: layer " + std::to_string(i) + " of the " + rep.chain_names[L.chain] + " (at " +
                           std::to_string(L.centre.y()).substr(0, 5) + " m) is not in the side silhouette");
      e.half_depth = 0.5 * (d1 - d0);
      e.box_centre += 0.5 * (d0 + d1) * L.front;
    }
    out[i] = e;
  }
  // Torso layers whose front outline an arm hides in the side photo: the front edge interpolated
  // between the nearest layers below and above that are seen.
  auto hidden = [&](size_t i) {
    for (const auto& [lo, hi] : side_occlusion)
      if (rep.layers[i].centre.y() >= lo - 0.005 && rep.layers[i].centre.y() <= hi + 0.005) return true;
    return false;
  };
  std::vector<size_t> torso;
  for (size_t i = 0; i < rep.layers.size(); ++i)
    if (rep.layers[i].chain == 0) torso.push_back(i);
  auto front_edge = [&](size_t i) { return (out[i].box_centre + out[i].half_depth * rep.layers[i].front).z(); };
  std::vector<double> fixed(torso.size());
  std::vector<bool> replace(torso.size(), false);
  for (size_t a = 0; a < torso.size(); ++a) {
    fixed[a] = front_edge(torso[a]);
    if (!hidden(torso[a])) continue;
    int below = -1, above = -1;
    for (int b = static_cast<int>(a) - 1; b >= 0 && below < 0; --b)
      if (!hidden(torso[static_cast<size_t>(b)])) below = b;
    for (size_t b = a + 1; b < torso.size() && above < 0; ++b)
      if (!hidden(torso[b])) above = static_cast<int>(b);
    if (below < 0 || above < 0) continue;
    const double y0 = rep.layers[torso[static_cast<size_t>(below)]].centre.y(),
                 y1 = rep.layers[torso[static_cast<size_t>(above)]].centre.y();
    const double t = (rep.layers[torso[a]].centre.y() - y0) / std::max(1e-6, y1 - y0);
    fixed[a] =
        std::min(fixed[a], (1 - t) * front_edge(torso[static_cast<size_t>(below)]) + t * front_edge(torso[static_cast<size_t>(above)]));
    replace[a] = true;
  }
  for (size_t a = 0; a < torso.size(); ++a) {
    if (!replace[a]) continue;
    LayerExtent& e = out[torso[a]];
    const RepresentationLayer& L = rep.layers[torso[a]];
    const double back = (e.box_centre - e.half_depth * L.front).z();
    if (!(fixed[a] > back) || std::abs(L.front.z()) < 0.5) continue;
    const Eigen::Vector3d lateral = e.box_centre - e.box_centre.dot(L.front) * L.front;
    e.half_depth = 0.5 * (fixed[a] - back) / std::abs(L.front.z());
    e.box_centre = lateral + (0.5 * (fixed[a] + back) / L.front.z()) * L.front;
  }
  return out;
}

double representation_torso_girth(const LayeredRepresentation& rep, double y) {
  int best = -1;
  for (size_t i = 0; i < rep.layers.size(); ++i)
    if (rep.layers[i].chain == 0 && (best < 0 || std::abs(rep.layers[i].centre.y() - y) < std::abs(rep.layers[best].centre.y() - y)))
      best = static_cast<int>(i);
  if (best < 0) return 0;
  const int n = rep.points_per_layer;
  std::vector<Eigen::Vector2d> p;
  for (int k = 0; k < n; ++k) {
    const Eigen::Vector3d q = rep.mesh.V.row(static_cast<Eigen::Index>(best) * n + k).transpose();
    p.emplace_back(q.x(), q.z());
  }
  // Convex hull (monotone chain) perimeter.
  std::sort(p.begin(), p.end(), [](const auto& a, const auto& b) { return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y(); });
  std::vector<Eigen::Vector2d> h(2 * p.size());
  size_t k = 0;
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  for (size_t i = 0; i < p.size(); ++i) {
    while (k >= 2 && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  for (size_t i = p.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(h[k - 2], h[k - 1], p[i]) <= 0) --k;
    h[k++] = p[i];
  }
  double perimeter = 0;
  for (size_t i = 0; i + 1 < k; ++i) perimeter += (h[i + 1] - h[i]).norm();
  return perimeter;
}

}  // namespace posekit
