#include "posekit/shape/body_orientation.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <numeric>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/units.h"

namespace posekit {
namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kMinElongation = 1.3;                            ///< largest over second spread: below, no long axis
constexpr double kSlab = 0.03;                                    ///< of the height: the lowest and highest slabs compared
constexpr double kSlabRatioCue = 3;                               ///< surface in the lowest slab over the highest's, typical
constexpr double kCentreCue = 0.03;                               ///< of the height, the surface's centre above mid-height, typical
constexpr double kMinUpScore = 0.5;                               ///< below, the head end is a guess
constexpr double kChestBand[2] = {0.55, 0.75};                    ///< of the height: where width beats depth
constexpr double kHipBand[2] = {0.42, 0.55};                      ///< of the height: compared with the chest's
constexpr double kTwistWarning = 8;                               ///< degrees between chest and hips said
constexpr double kMinWidthOverDepth = 1.1;                        ///< spreads (SD) of the chest band
constexpr double kFootBand = 0.04, kShankBand[2] = {0.06, 0.10};  ///< of the height
constexpr double kFootCue = 0.01;                                 ///< of the height: the feet's lead over the shanks, to count

/// The axis nearest `d` (signed unit vector) when within `degrees`, else `d` itself.
Eigen::Vector3d snap_to_axis(const Eigen::Vector3d& d, double degrees) {
  Eigen::Index axis = 0;
  d.cwiseAbs().maxCoeff(&axis);
  if (std::abs(d[axis]) < std::cos(degrees * kPi / 180)) return d;
  return Eigen::Vector3d::Unit(axis) * (d[axis] > 0 ? 1.0 : -1.0);
}

/// Weighted quantile of values (unsorted copy taken).
double quantile(const std::vector<double>& values, const std::vector<double>& w, double q) {
  std::vector<size_t> order(values.size());
  std::iota(order.begin(), order.end(), size_t{0});
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return values[a] < values[b]; });
  const double total = std::accumulate(w.begin(), w.end(), 0.0);
  double seen = 0;
  for (size_t i : order) {
    seen += w[i];
    if (seen >= q * total) return values[i];
  }
  return values[order.back()];
}

struct Band {
  double weight = 0;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
};

/// Weight and weighted mean of the samples whose height lies in [from, to) and, when `side` is not
/// zero, whose coordinate along `side` lies in [side_from, side_to].
Band band_of(const Eigen::MatrixXd& P, const std::vector<double>& w, const std::vector<double>& h, double from, double to,
             const Eigen::Vector3d& side = Eigen::Vector3d::Zero(), double side_from = 0, double side_to = 0) {
  const bool sideways = side.squaredNorm() > 0;
  Band b;
  for (size_t i = 0; i < h.size(); ++i) {
    if (h[i] < from || h[i] >= to) continue;
    const auto p = P.row(static_cast<Eigen::Index>(i));
    if (sideways && (p.dot(side) < side_from || p.dot(side) > side_to)) continue;
    b.weight += w[i];
    b.mean += w[i] * p.transpose();
  }
  if (b.weight > 0) b.mean /= b.weight;
  return b;
}

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

}  // namespace

Eigen::Vector3d parse_axis(const std::string& text) {
  std::string t = text;
  double sign = 1;
  if (!t.empty() && (t[0] == '+' || t[0] == '-')) {
    sign = t[0] == '-' ? -1 : 1;
    t = t.substr(1);
  }
  if (t.size() == 1) {
    const char c = static_cast<char>(std::tolower(static_cast<unsigned char>(t[0])));
    if (c >= 'x' && c <= 'z') return sign * Eigen::Vector3d::Unit(c - 'x');
  }
  throw InvalidInput("axis '" + text + "': expected one of +X, -X, +Y, -Y, +Z, -Z (or x, y, z)");
}

std::string axis_name(const Eigen::Vector3d& d) {
  for (int a = 0; a < 3; ++a)
    for (double s : {1.0, -1.0})
      if ((d - s * Eigen::Vector3d::Unit(a)).norm() < 1e-9) return std::string(s > 0 ? "+" : "-") + static_cast<char>('X' + a);
  return "(" + fixed(d.x(), 3) + ", " + fixed(d.y(), 3) + ", " + fixed(d.z(), 3) + ")";
}

std::string BodyOrientation::describe() const {
  return "up " + axis_name(up()) + (up_detected ? " (detected)" : " (given)") + ", facing " + axis_name(forward()) +
         (forward_detected ? " (detected)" : " (given)");
}

BodyOrientation orientation_from_axes(const Eigen::Vector3d& up_in, const Eigen::Vector3d& forward_in) {
  if (up_in.norm() == 0 || forward_in.norm() == 0) throw InvalidInput("orientation: an axis has zero length");
  const Eigen::Vector3d up = up_in.normalized(), forward = forward_in.normalized();
  if (std::abs(up.dot(forward)) > std::sin(kPi / 180))
    throw InvalidInput("orientation: up " + axis_name(up) + " and forward " + axis_name(forward) + " are not perpendicular");
  const Eigen::Vector3d f = (forward - up.dot(forward) * up).normalized();
  BodyOrientation o;
  o.rotation.row(0) = up.cross(f).transpose();  // posekit: X = Y x Z, the subject's left
  o.rotation.row(1) = up.transpose();
  o.rotation.row(2) = f.transpose();
  return o;
}

namespace {

/// Feet at the bottom: turns `up` (and the heights h, lo, hi along it) end over end when the surface
/// says the head is at the other end.
void orient_head_end(const Eigen::MatrixXd& P, const std::vector<double>& w, double total, const Eigen::Vector3d& centre, double height,
                     Eigen::Vector3d* up, std::vector<double>* h, double* lo, double* hi, std::vector<std::string>* warnings) {
  // Feet at the bottom: more surface in the lowest slab than in the highest (the crown's dome,
  // or hands raised). The surface's centre above mid-height: legs are thinner than torso and arms.
  const double bottom = band_of(P, w, *h, *lo, *lo + kSlab * height).weight;
  const double top = band_of(P, w, *h, *hi - kSlab * height, *hi + 1e-12 * height).weight;
  const double centre_h = (centre.dot(*up) - 0.5 * (*lo + *hi)) / height;
  // Each cue scaled to about 1 on a standing body (feet hold ~3x the crown's surface; the centre
  // ~3% of the height above mid-height), capped, and summed: a footless scan still has its centre.
  const double slab_cue = std::clamp(std::log((bottom + 1e-30) / (top + 1e-30)) / std::log(kSlabRatioCue), -2.0, 2.0);
  const double centre_cue = std::clamp(centre_h / kCentreCue, -2.0, 2.0);
  const double score = slab_cue + centre_cue;
  const int vote = score >= 0 ? 1 : -1;
  if (std::abs(score) < kMinUpScore)
    warnings->push_back("could not tell the head end from the feet (surface in the end slabs " + fixed(bottom / total, 3) + " and " +
                        fixed(top / total, 3) + " of the whole, its centre " + fixed(centre_h * 100, 1) +
                        "% of the height from mid-height); assuming " + axis_name(static_cast<double>(vote) * *up) +
                        " is up: give --up if not");
  else if (std::abs(slab_cue) > kMinUpScore && std::abs(centre_cue) > kMinUpScore && slab_cue * centre_cue < 0)
    warnings->push_back("the head end is uncertain: the feet's surface and the surface's centre disagree; taking " +
                        axis_name(static_cast<double>(vote) * *up) + " as up: give --up if wrong");
  if (vote < 0) {
    *up = -*up;
    for (double& v : *h) v = -v;
    std::swap(*lo, *hi);
    *lo = -*lo;
    *hi = -*hi;
  }
}

/// Forward, perpendicular to `up`: the chest band's narrower direction (left-right is its wider one),
/// snapped to the nearest file axis, and pointing where the feet point ahead of the shanks.
Eigen::Vector3d detect_forward(const Eigen::MatrixXd& P, const std::vector<double>& w, const std::vector<double>& h, double lo,
                               double height, const Eigen::Vector3d& up, const OrientationOptions& options,
                               std::vector<std::string>* warnings) {
  const Eigen::Index n = P.rows();
  const Eigen::Vector3d e1 = up.unitOrthogonal(), e2 = up.cross(e1);
  Eigen::Vector3d forward;
  // Left-right is the wider direction of the chest band (shoulders and arms), which the body's
  // features and representation need; a torso twisted on the pelvis turns it away from where the
  // hips and feet face, which is said.
  auto band_spread = [&](const double(&band)[2], Eigen::Vector3d* depth, double* width_over_depth) {
    const Band b = band_of(P, w, h, lo + band[0] * height, lo + band[1] * height);
    Eigen::Matrix2d c2 = Eigen::Matrix2d::Zero();
    for (Eigen::Index i = 0; i < n; ++i) {
      const double hv = h[static_cast<size_t>(i)];
      if (hv < lo + band[0] * height || hv >= lo + band[1] * height) continue;
      const Eigen::Vector3d d = P.row(i).transpose() - b.mean;
      const Eigen::Vector2d q(d.dot(e1), d.dot(e2));
      c2 += w[static_cast<size_t>(i)] * q * q.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> pca2(c2);
    const Eigen::Vector2d spread2 = pca2.eigenvalues().cwiseMax(0).cwiseSqrt();
    const Eigen::Vector2d d2 = pca2.eigenvectors().col(0);
    *depth = (d2[0] * e1 + d2[1] * e2).normalized();
    *width_over_depth = spread2[1] / (spread2[0] + 1e-30);
  };
  double ratio = 0, hip_ratio = 0;
  Eigen::Vector3d hip_forward;
  band_spread(kChestBand, &forward, &ratio);
  band_spread(kHipBand, &hip_forward, &hip_ratio);
  if (!(ratio > kMinWidthOverDepth))
    warnings->push_back("could not tell side from front: the chest band is about as deep as it is wide (" + fixed(ratio, 2) +
                        "); give --forward");
  const double twist = std::acos(std::min(1.0, std::abs(forward.dot(hip_forward)))) * 180 / kPi;
  if (ratio > kMinWidthOverDepth && hip_ratio > kMinWidthOverDepth && twist > kTwistWarning)
    warnings->push_back("the chest is turned " + fixed(twist, 0) +
                        " degrees from the hips (a twisted torso): posekit's frame follows the chest; give --forward for the hips'");
  // Snap to the file's axis nearest in the horizontal plane.
  const Eigen::Vector3d snapped = snap_to_axis(forward, options.forward_snap_degrees);
  if (std::abs(snapped.dot(up)) < 1e-9) forward = snapped;

  // Front from back: the feet point forward of the shanks above them (toes far ahead, heels just
  // behind). Only shank samples within the feet's sideways span count: a raised foot is elsewhere.
  const Eigen::Vector3d side = up.cross(forward);
  const Band feet = band_of(P, w, h, lo, lo + kFootBand * height);
  std::vector<double> feet_side, feet_w;
  for (Eigen::Index i = 0; i < n; ++i)
    if (h[static_cast<size_t>(i)] < lo + kFootBand * height) {
      feet_side.push_back(P.row(i).dot(side));
      feet_w.push_back(w[static_cast<size_t>(i)]);
    }
  Band shanks;
  if (!feet_side.empty())
    shanks = band_of(P, w, h, lo + kShankBand[0] * height, lo + kShankBand[1] * height, side, quantile(feet_side, feet_w, 0.02),
                     quantile(feet_side, feet_w, 0.98));
  const double lead = feet.weight > 0 && shanks.weight > 0 ? (feet.mean - shanks.mean).dot(forward) / height : 0;
  if (std::abs(lead) > kFootCue) {
    if (lead < 0) forward = -forward;
  } else {
    if (forward.z() + 1e-9 * forward.x() < 0) forward = -forward;
    warnings->push_back("could not tell front from back (no feet pointing forward of the shanks); assuming the body faces " +
                        axis_name(forward) + ": give --forward if not");
  }
  return forward;
}

}  // namespace

BodyOrientation detect_body_orientation(const Eigen::MatrixXd& P, const Eigen::VectorXd& weights, const OrientationOptions& options) {
  const Eigen::Index n = P.rows();
  if (n < 10 || P.cols() != 3) throw InvalidInput("orientation: too few points to tell a body's orientation");
  if (weights.size() != 0 && weights.size() != n) throw InvalidInput("orientation: one weight per point expected");
  // A dense scan (or a fine mesh's faces) on an evenly spread sample: its moments and quantiles are
  // the same to well under a degree, in milliseconds instead of a sort of every point.
  constexpr Eigen::Index kSample = 200000;
  if (n > kSample) {
    const Eigen::Index stride = (n + kSample - 1) / kSample, m = (n + stride - 1) / stride;
    Eigen::MatrixXd sample(m, 3);
    Eigen::VectorXd sample_weights(weights.size() == n ? m : 0);
    for (Eigen::Index i = 0; i < m; ++i) {
      sample.row(i) = P.row(i * stride);
      if (sample_weights.size() > 0) sample_weights[i] = weights[i * stride];
    }
    return detect_body_orientation(sample, sample_weights, options);
  }
  std::vector<double> w(static_cast<size_t>(n), 1.0);
  if (weights.size() == n)
    for (Eigen::Index i = 0; i < n; ++i) w[static_cast<size_t>(i)] = std::max(0.0, weights[i]);
  double total = 0;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    total += w[static_cast<size_t>(i)];
    centre += w[static_cast<size_t>(i)] * P.row(i).transpose();
  }
  if (!(total > 0)) throw InvalidInput("orientation: the body has no surface");
  centre /= total;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < n; ++i) {
    const Eigen::Vector3d d = P.row(i).transpose() - centre;
    cov += w[static_cast<size_t>(i)] * d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(cov / total);
  const Eigen::Vector3d spread = pca.eigenvalues().cwiseMax(0).cwiseSqrt();  // ascending

  BodyOrientation o;
  Eigen::Vector3d up;
  if (options.up.norm() > 0) {
    up = options.up.normalized();
    const Eigen::Vector3d longest = pca.eigenvectors().col(2);
    if (spread[2] > kMinElongation * spread[1] && std::abs(longest.dot(up)) < std::cos(30 * kPi / 180))
      o.warnings.push_back("the up axis given, " + axis_name(up) + ", is not the body's long axis (" +
                           axis_name(snap_to_axis(longest, options.up_snap_degrees)) + "): is the body lying down?");
  } else {
    if (!(spread[2] > kMinElongation * spread[1]))
      throw InvalidInput("orientation: the body has no clear long axis (its spreads are " + fixed(spread[2], 3) + ", " +
                         fixed(spread[1], 3) + " and " + fixed(spread[0], 3) +
                         "): not a standing body, or a part of one; give its axes (--up, --forward)");
    up = snap_to_axis(pca.eigenvectors().col(2), options.up_snap_degrees);
    o.up_detected = true;
  }

  // Heights along the up axis, and the body's robust extent along it (stray points aside).
  std::vector<double> h(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) h[static_cast<size_t>(i)] = P.row(i).dot(up);
  double lo = quantile(h, w, 0.0005), hi = quantile(h, w, 0.9995);
  const double height = hi - lo;
  if (!(height > 0)) throw InvalidInput("orientation: the body is flat along its long axis");

  if (o.up_detected) orient_head_end(P, w, total, centre, height, &up, &h, &lo, &hi, &o.warnings);

  Eigen::Vector3d forward;
  if (options.forward.norm() > 0) {
    forward = options.forward.normalized();
    if (std::abs(forward.dot(up)) > std::sin(kPi / 180))
      throw InvalidInput("orientation: forward " + axis_name(forward) + " is not perpendicular to up " + axis_name(up));
  } else {
    forward = detect_forward(P, w, h, lo, height, up, options, &o.warnings);
    o.forward_detected = true;
  }
  BodyOrientation result = orientation_from_axes(up, forward);
  result.up_detected = o.up_detected;
  result.forward_detected = o.forward_detected;
  result.warnings = std::move(o.warnings);
  return result;
}

BodyOrientation detect_mesh_orientation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const OrientationOptions& options) {
  if (F.rows() == 0) throw InvalidInput("orientation: the mesh has no faces");
  // Floating bits (a scan's floor patch, a strap) would sway the end slabs and the feet's lead.
  Eigen::VectorXd area = face_areas(V, F);
  const FloatingBits bits = find_floating_bits(V, F);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (!bits.keep_face[static_cast<size_t>(f)]) area[f] = 0;
  return detect_body_orientation(face_centroids(V, F), area, options);
}

std::string BodyFrame::describe() const {
  std::ostringstream text;
  text << "unit " << unit;
  if (unit_detected) text << " (detected from the body's largest extent, " << std::setprecision(4) << extent << ")";
  else text << " (given)";
  text << "; " << orientation.describe();
  return text.str();
}

BodyFrame scale_body_to_metres(Eigen::MatrixXd* points, const std::string& unit) {
  BodyFrame frame;
  Unit u = Unit::kMetre;
  if (unit == "auto") {
    frame.extent = robust_largest_extent(*points);
    if (!guess_body_unit(frame.extent, &u)) {
      std::ostringstream msg;
      msg << "cannot tell its unit: its largest extent (stray points aside), " << std::setprecision(4) << frame.extent
          << ", is no standing body or torso (0.5 to 3 m) in m, dm, cm or mm; give the unit";
      throw InvalidInput(msg.str());
    }
    frame.unit_detected = true;
  } else {
    u = parse_unit(unit);
  }
  frame.unit = unit_name(u);
  frame.metres_per_unit = metres_per_unit(u);
  if (frame.metres_per_unit != 1) *points *= frame.metres_per_unit;
  return frame;
}

BodyOrientation turn_body_to_posekit_frame(std::vector<Eigen::MatrixXd*> turned, const Eigen::MatrixXd& points,
                                           const Eigen::MatrixXi* faces, const std::string& up, const std::string& forward) {
  OrientationOptions o;
  if (up != "auto") o.up = parse_axis(up);
  if (forward != "auto") o.forward = parse_axis(forward);
  const BodyOrientation orientation =
      faces ? (faces->rows() > 0 ? detect_mesh_orientation(points, *faces, o) : throw InvalidInput("the mesh has no faces"))
            : detect_body_orientation(points, {}, o);
  if (!orientation.is_identity()) {
    const Eigen::Matrix3d Rt = orientation.rotation.transpose();
    for (Eigen::MatrixXd* M : turned)
      if (M && M->rows() > 0) *M = (*M * Rt).eval();
  }
  return orientation;
}

BodyFrame bring_to_posekit_frame(Eigen::MatrixXd* points, const Eigen::MatrixXi* faces, Eigen::MatrixXd* normals, const std::string& unit,
                                 const std::string& up, const std::string& forward) {
  BodyFrame frame = scale_body_to_metres(points, unit);
  frame.orientation = turn_body_to_posekit_frame({points, normals}, *points, faces, up, forward);
  return frame;
}

}  // namespace posekit
