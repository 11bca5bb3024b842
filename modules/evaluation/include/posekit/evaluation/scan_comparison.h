#pragma once
// Comparing a body model with a scan (issue "Validation against body scans"): scan-to-model
// point-to-triangle distances, model-to-scan distances where the scan has data, and girth
// discrepancies with the ISO 20685-1 tolerances.
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "posekit/core/point_cloud.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct ScanComparisonOptions {
  double outlier_threshold = 0.02;  ///< m: points farther than this count as outliers, not error
  double coverage_radius = 0;       ///< m: a vertex with no scan point this close is uncovered; 0: automatic
  int threads = 0;                  ///< 0: all cores
};

/// Statistics of distances, millimetres. Mean, RMS and 95th percentile of |d| over inliers.
struct DistanceStats {
  double mean_mm = 0, rms_mm = 0, p95_mm = 0, max_mm = 0, signed_mean_mm = 0;
  long count = 0, outliers = 0;
};

struct ScanComparison {
  Eigen::VectorXd scan_to_model;  ///< #P signed distance (m), + outside the model (its outward normal)
  Eigen::VectorXi scan_closest_face;
  Eigen::VectorXd model_to_scan;  ///< #V signed distance (m) to the nearest scan point; NaN when uncovered
  DistanceStats scan_stats, model_stats;
  double hausdorff_mm = 0;  ///< the larger of the two directions' maxima (covered vertices, all points)
  double coverage = 0;      ///< fraction of model vertices with scan data near them
  long uncovered_vertices = 0;
  double coverage_radius = 0;  ///< m, as used
  double seconds = 0;
  /// Seconds per stage: the triangle tree and the scan grid, scan-to-model distances (with signs),
  /// model-to-scan distances (with the coverage radius), statistics.
  double build_seconds = 0, scan_to_model_seconds = 0, model_to_scan_seconds = 0, stats_seconds = 0;
};

/// Throws InvalidInput for an empty scan, a mesh with non-finite vertices, or a scan whose size
/// says it is in other units than the model (the message suggests the unit).
ScanComparison compare_with_scan(const TriangleMesh& model, const PointCloud& scan, const ScanComparisonOptions& options = {});

/// A scan read by ranges of its points (metres, posekit's frame), for scans too large to hold whole.
struct ScanPieces {
  Eigen::Index size = 0;  ///< points
  /// Points [first, first + count) into `points` (count x 3).
  std::function<void(Eigen::Index first, Eigen::Index count, Eigen::MatrixXd* points)> read;
  /// Optional: the points before `end` are done with for now (their memory may go).
  std::function<void(Eigen::Index end)> release;
  Eigen::Index piece = Eigen::Index(1) << 20;  ///< points read at a time
};

/// compare_with_scan on a scan read piece by piece: the same distances, statistics and coverage
/// (scan_closest_face left empty) while holding one piece and the per-point distances, so that a
/// 10M-point scan needs a fraction of its size. The points are read twice: first to check them and
/// their scale against the model (and for the automatic coverage radius, the scan's spacing), then
/// for the distances.
ScanComparison compare_with_scan(const TriangleMesh& model, const ScanPieces& scan, const ScanComparisonOptions& options = {});

/// Girth discrepancy of a model against a scan, with the ISO 20685-1 maximum allowable error.
struct GirthDiscrepancy {
  std::string name;
  double model_cm = 0, scan_cm = 0, difference_cm = 0;
  bool measured = false;    ///< both sides measured
  double tolerance_mm = 0;  ///< ISO 20685-1: 9 mm large girths, 4 mm small girths and stature
  std::string note;
};

/// Measures both (modules/shape) and pairs up stature and every girth.
std::vector<GirthDiscrepancy> girth_discrepancies(const TriangleMesh& model, const PointCloud& scan);

/// A sanity check of the scan's unit against the model: empty when plausible, otherwise a message
/// like "the scan is 1712 m across as read, against a 1.71 m model: did you mean mm?".
std::string unit_mismatch(const TriangleMesh& model, const PointCloud& scan);

}  // namespace posekit
