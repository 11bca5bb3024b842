#include "posekit/evaluation/scan_comparison.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/parallel.h"
#include "posekit/core/point_grid.h"
#include "posekit/shape/measurements.h"

namespace posekit {
namespace {

DistanceStats stats_of(const Eigen::VectorXd& d, double outlier_threshold) {
  DistanceStats s;
  std::vector<double> inliers;
  inliers.reserve(static_cast<size_t>(d.size()));
  double sum = 0, sum_sq = 0, sum_signed = 0;
  for (Eigen::Index i = 0; i < d.size(); ++i) {
    if (!std::isfinite(d[i])) continue;
    const double a = std::abs(d[i]);
    s.max_mm = std::max(s.max_mm, 1000 * a);
    if (a > outlier_threshold) {
      ++s.outliers;
      continue;
    }
    inliers.push_back(a);
    sum += a;
    sum_sq += a * a;
    sum_signed += d[i];
  }
  s.count = static_cast<long>(inliers.size());
  if (inliers.empty()) return s;
  const double n = static_cast<double>(inliers.size());
  s.mean_mm = 1000 * sum / n;
  s.rms_mm = 1000 * std::sqrt(sum_sq / n);
  s.signed_mean_mm = 1000 * sum_signed / n;
  const size_t k = std::min(inliers.size() - 1, static_cast<size_t>(std::ceil(0.95 * n)) - 1);
  std::nth_element(inliers.begin(), inliers.begin() + static_cast<long>(k), inliers.end());
  s.p95_mm = 1000 * inliers[k];
  return s;
}

}  // namespace

namespace {

/// unit_mismatch on the two largest extents (m, as read).
std::string unit_mismatch_of_extents(double m, double s) {
  if (!(m > 0) || !(s > 0)) return "";
  const double ratio = s / m;
  if (ratio > 0.2 && ratio < 5) return "";
  std::ostringstream msg;
  msg.precision(4);
  // Both extents are in metres as read: the file's unit is what the hint is about.
  msg << "the scan is " << s << " m across as read, against a " << m << " m model";
  if (ratio > 500 && ratio < 2000) msg << ": did you mean mm?";
  else if (ratio > 50 && ratio < 200) msg << ": did you mean cm?";
  else if (ratio > 5 && ratio < 20) msg << ": did you mean dm?";
  else if (ratio < 0.002 && ratio > 0.0005) msg << ": is the model in mm and the scan in m?";
  else msg << ": are they the same body and unit?";
  return msg.str();
}

/// Coverage, both directions' statistics and the Hausdorff distance, from the distances.
void finish_statistics(ScanComparison* r, Eigen::Index vertices, double outlier_threshold) {
  r->coverage = 1.0 - static_cast<double>(r->uncovered_vertices) / static_cast<double>(vertices);
  r->scan_stats = stats_of(r->scan_to_model, outlier_threshold);
  r->model_stats = stats_of(r->model_to_scan, outlier_threshold);
  r->hausdorff_mm = std::max(r->scan_stats.max_mm, r->model_stats.max_mm);
}

/// Four times the median spacing of the scan (at least 10 mm): the automatic coverage radius.
double coverage_radius_of(std::vector<double> spacing) {
  double median = 0;
  if (!spacing.empty()) {
    std::nth_element(spacing.begin(), spacing.begin() + static_cast<long>(spacing.size() / 2), spacing.end());
    median = spacing[spacing.size() / 2];
  }
  return std::max(0.010, 4 * median);
}

}  // namespace

std::string unit_mismatch(const TriangleMesh& model, const PointCloud& scan) {
  if (model.V.rows() == 0 || scan.P.rows() == 0) return "";
  const BoundingBox mb = bounding_box(model.V), sb = bounding_box(scan.P);
  return unit_mismatch_of_extents((mb.max - mb.min).maxCoeff(), (sb.max - sb.min).maxCoeff());
}

ScanComparison compare_with_scan(const TriangleMesh& model, const PointCloud& scan, const ScanComparisonOptions& o) {
  require_usable_mesh(model, "model mesh");
  if (scan.P.rows() == 0) throw InvalidInput("the scan has no points");
  if (!scan.P.allFinite()) throw InvalidInput("the scan has a non-finite point");
  if (const std::string m = unit_mismatch(model, scan); !m.empty()) throw InvalidInput(m);
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  ScanComparison r;

  // Scan to model: exact point-to-triangle distances, signed by the outward normal at the closest point.
  const TriangleTree tree(model.V, model.F);
  r.build_seconds = since(t0);
  auto t = Clock::now();
  const Eigen::MatrixXd vn = vertex_normals(model.V, model.F);
  r.scan_closest_face.resize(scan.P.rows());
  r.scan_to_model.resize(scan.P.rows());
  tree.for_each_closest(scan.P, o.threads, [&](Eigen::Index i, const ClosestHit& h) {
    const Eigen::RowVector3d n =
        h.bary[0] * vn.row(model.F(h.face, 0)) + h.bary[1] * vn.row(model.F(h.face, 1)) + h.bary[2] * vn.row(model.F(h.face, 2));
    const double side = (scan.P.row(i) - h.point.transpose()).dot(n);
    r.scan_to_model[i] = side < 0 ? -h.distance : h.distance;
    r.scan_closest_face[i] = h.face;
  });

  // Model to scan: nearest scan point of every vertex. A grid over the scan is built in linear
  // time; a KD-tree over a million points cost more than all 12k queries together.
  r.scan_to_model_seconds = since(t);
  t = Clock::now();
  const PointGrid grid(scan.P);
  r.build_seconds += since(t);
  t = Clock::now();
  // Coverage radius: four times the median scan spacing (at least 10 mm) unless given.
  r.coverage_radius = o.coverage_radius;
  if (r.coverage_radius <= 0) {
    std::vector<double> spacing;
    const Eigen::Index step = std::max<Eigen::Index>(1, scan.P.rows() / 2000);
    for (Eigen::Index i = 0; i < scan.P.rows(); i += step) {
      double sq;
      if (grid.nearest(scan.P.row(i).transpose(), &sq, std::numeric_limits<double>::infinity(), static_cast<int>(i)) >= 0)
        spacing.push_back(std::sqrt(sq));
    }
    r.coverage_radius = coverage_radius_of(std::move(spacing));
  }
  r.model_to_scan.resize(model.V.rows());
  std::vector<char> uncovered(static_cast<size_t>(model.V.rows()), 0);
  parallel_for_ranges(
      model.V.rows(), o.threads,
      [&](long begin, long end) {
        for (long v = begin; v < end; ++v) {
          double sq;
          // A vertex exactly at the radius still counts as covered, as before.
          const int nearest = grid.nearest(model.V.row(v).transpose(), &sq, std::nextafter(r.coverage_radius, INFINITY));
          if (nearest < 0) {  // nothing within the coverage radius
            r.model_to_scan[v] = std::numeric_limits<double>::quiet_NaN();
            uncovered[static_cast<size_t>(v)] = 1;
            continue;
          }
          const double d = std::sqrt(sq);
          const double side = (scan.P.row(nearest) - model.V.row(v)).dot(vn.row(v));
          // Positive: the scan lies outside the model there (same convention as scan_to_model).
          r.model_to_scan[v] = side < 0 ? -d : d;
        }
      },
      256);
  r.uncovered_vertices = std::count(uncovered.begin(), uncovered.end(), 1);
  r.model_to_scan_seconds = since(t);
  t = Clock::now();
  finish_statistics(&r, model.V.rows(), o.outlier_threshold);
  r.stats_seconds = since(t);
  r.seconds = since(t0);
  return r;
}

namespace {

/// `work(first, points)` on every piece of the scan in turn, releasing each after it.
void for_each_piece(const ScanPieces& scan, const std::function<void(Eigen::Index first, const Eigen::MatrixXd& P)>& work) {
  const Eigen::Index piece = std::max<Eigen::Index>(1, scan.piece);
  Eigen::MatrixXd P;
  for (Eigen::Index first = 0; first < scan.size; first += piece) {
    const Eigen::Index count = std::min(piece, scan.size - first);
    scan.read(first, count, &P);
    work(first, P);
    if (scan.release) scan.release(first + count);
  }
}

/// The first pass over the pieces: finite points, the box against the model's (the unit check) and
/// the coverage radius, automatic from the nearest other point of the same 2000 samples as the
/// whole-scan comparison's, found over every piece.
double checked_coverage_radius(const TriangleMesh& model, const ScanPieces& scan, const ScanComparisonOptions& o) {
  const Eigen::Index n = scan.size;
  const bool automatic_radius = o.coverage_radius <= 0;
  const Eigen::Index step = std::max<Eigen::Index>(1, n / 2000);
  std::vector<Eigen::Index> samples;
  for (Eigen::Index i = 0; i < n && automatic_radius; i += step) samples.push_back(i);
  Eigen::MatrixXd sample_points(static_cast<Eigen::Index>(samples.size()), 3), one;
  for (size_t k = 0; k < samples.size(); ++k) {
    scan.read(samples[k], 1, &one);
    sample_points.row(static_cast<Eigen::Index>(k)) = one.row(0);
  }
  std::vector<double> sample_sq(samples.size(), std::numeric_limits<double>::infinity());
  Eigen::RowVector3d lo = Eigen::RowVector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
  for_each_piece(scan, [&](Eigen::Index first, const Eigen::MatrixXd& P) {
    if (!P.allFinite()) throw InvalidInput("the scan has a non-finite point");
    lo = lo.cwiseMin(P.colwise().minCoeff());
    hi = hi.cwiseMax(P.colwise().maxCoeff());
    if (!automatic_radius) return;
    const PointGrid grid(P);
    parallel_for_ranges(
        static_cast<long>(samples.size()), o.threads,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            const Eigen::Index own = samples[static_cast<size_t>(k)] - first;
            const double bound = std::isfinite(sample_sq[static_cast<size_t>(k)])
                                     ? std::nextafter(std::sqrt(sample_sq[static_cast<size_t>(k)]), INFINITY)
                                     : std::numeric_limits<double>::infinity();
            double sq;
            if (grid.nearest(sample_points.row(k).transpose(), &sq, bound, own >= 0 && own < P.rows() ? static_cast<int>(own) : -1) >= 0 &&
                sq < sample_sq[static_cast<size_t>(k)])
              sample_sq[static_cast<size_t>(k)] = sq;
          }
        },
        64);
  });
  const BoundingBox mb = bounding_box(model.V);
  if (const std::string m = unit_mismatch_of_extents((mb.max - mb.min).maxCoeff(), (hi - lo).maxCoeff()); !m.empty()) throw InvalidInput(m);
  if (!automatic_radius) return o.coverage_radius;
  std::vector<double> spacing;
  for (double sq : sample_sq)
    if (std::isfinite(sq)) spacing.push_back(std::sqrt(sq));
  return coverage_radius_of(std::move(spacing));
}

}  // namespace

ScanComparison compare_with_scan(const TriangleMesh& model, const ScanPieces& scan, const ScanComparisonOptions& o) {
  require_usable_mesh(model, "model mesh");
  const Eigen::Index n = scan.size;
  if (n <= 0) throw InvalidInput("the scan has no points");
  using Clock = std::chrono::steady_clock;
  const auto t0 = Clock::now();
  auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  ScanComparison r;
  r.coverage_radius = checked_coverage_radius(model, scan, o);

  // Then the distances: scan to model as the whole-scan comparison's; model to scan as the nearest
  // point over the pieces.
  auto t = Clock::now();
  const TriangleTree tree(model.V, model.F);
  const Eigen::MatrixXd vn = vertex_normals(model.V, model.F);
  r.build_seconds = since(t);
  r.scan_to_model.resize(n);
  const Eigen::Index nv = model.V.rows();
  std::vector<double> best_sq(static_cast<size_t>(nv), std::numeric_limits<double>::infinity());
  Eigen::MatrixXd best_point(nv, 3);
  const double reach = std::nextafter(r.coverage_radius, INFINITY);  // a vertex exactly at the radius is covered
  for_each_piece(scan, [&](Eigen::Index first, const Eigen::MatrixXd& P) {
    auto ts = Clock::now();
    tree.for_each_closest(P, o.threads, [&](Eigen::Index i, const ClosestHit& h) {
      const Eigen::RowVector3d nrm =
          h.bary[0] * vn.row(model.F(h.face, 0)) + h.bary[1] * vn.row(model.F(h.face, 1)) + h.bary[2] * vn.row(model.F(h.face, 2));
      const double side = (P.row(i) - h.point.transpose()).dot(nrm);
      r.scan_to_model[first + i] = side < 0 ? -h.distance : h.distance;
    });
    r.scan_to_model_seconds += since(ts);
    ts = Clock::now();
    const PointGrid grid(P);
    r.build_seconds += since(ts);
    ts = Clock::now();
    parallel_for_ranges(
        nv, o.threads,
        [&](long begin, long end) {
          for (long v = begin; v < end; ++v) {
            const double known = best_sq[static_cast<size_t>(v)];
            const double bound = std::isfinite(known) ? std::min(reach, std::nextafter(std::sqrt(known), INFINITY)) : reach;
            double sq;
            const int nearest = grid.nearest(model.V.row(v).transpose(), &sq, bound);
            if (nearest >= 0 && sq < known) {
              best_sq[static_cast<size_t>(v)] = sq;
              best_point.row(v) = P.row(nearest);
            }
          }
        },
        256);
    r.model_to_scan_seconds += since(ts);
  });
  t = Clock::now();
  r.model_to_scan.resize(nv);
  for (Eigen::Index v = 0; v < nv; ++v) {
    if (!std::isfinite(best_sq[static_cast<size_t>(v)])) {
      r.model_to_scan[v] = std::numeric_limits<double>::quiet_NaN();
      ++r.uncovered_vertices;
      continue;
    }
    const double d = std::sqrt(best_sq[static_cast<size_t>(v)]);
    const double side = (best_point.row(v) - model.V.row(v)).dot(vn.row(v));
    r.model_to_scan[v] = side < 0 ? -d : d;
  }
  finish_statistics(&r, nv, o.outlier_threshold);
  r.stats_seconds = since(t);
  r.seconds = since(t0);
  return r;
}

std::vector<GirthDiscrepancy> girth_discrepancies(const TriangleMesh& model, const PointCloud& scan) {
  auto measured = [](const std::string& which, const auto& measure) {
    try {
      return measure();
    } catch (const InvalidInput& e) {
      throw InvalidInput("measuring the " + which + ": " + e.what());
    }
  };
  const BodyMeasurements a = measured("model", [&] { return measure_body(model.V, model.F); });
  const BodyMeasurements b = measured("scan", [&] { return measure_point_cloud(scan.P); });
  std::vector<GirthDiscrepancy> out;
  GirthDiscrepancy stature;
  stature.name = "stature";
  stature.model_cm = 100 * a.stature;
  stature.scan_cm = 100 * b.stature;
  stature.difference_cm = stature.model_cm - stature.scan_cm;
  stature.measured = a.stature > 0 && b.stature > 0;
  stature.tolerance_mm = 4;
  out.push_back(stature);
  for (const Girth& g : a.girths) {
    GirthDiscrepancy d;
    d.name = g.name;
    const bool large = g.name == "bust" || g.name == "underbust" || g.name == "waist" || g.name == "hip" || g.name == "thigh";
    d.tolerance_mm = large ? 9 : 4;
    const Girth* s = b.find(g.name);
    d.model_cm = g.measured ? 100 * g.value : 0;
    d.scan_cm = s && s->measured ? 100 * s->value : 0;
    d.measured = g.measured && s && s->measured;
    if (d.measured) d.difference_cm = d.model_cm - d.scan_cm;
    if (!g.measured) d.note = "model: " + (g.note.empty() ? std::string("not measured") : g.note);
    else if (!s || !s->measured) d.note = "scan: " + (s && !s->note.empty() ? s->note : std::string("not measured"));
    out.push_back(d);
  }
  return out;
}

}  // namespace posekit
