#pragma once
// Exact nearest neighbours in a point cloud through a uniform grid.
#include <Eigen/Core>
#include <limits>
#include <vector>

namespace posekit {

/// The points of a cloud bucketed in a uniform grid, built in linear time (a counting sort into
/// cells). Cheaper than a KD-tree when there are far fewer queries than points: a model's
/// vertices against a million-point scan. Queries are exact.
class PointGrid {
 public:
  /// P #P x 3 (m). `cell` is the cell size (m); 0 takes twice the cube root of the box volume per point.
  /// Throws InvalidInput for an empty or non-finite cloud, or one whose points are too far apart
  /// (over about 1e308) for their distances to be finite.
  explicit PointGrid(const Eigen::MatrixXd& P, double cell = 0);

  /// Index (a row of P) of the point nearest to p within `max_distance`, and its squared distance;
  /// -1 when there is none. `skip` excludes one row (a point's own index, for its nearest other point).
  int nearest(const Eigen::Vector3d& p, double* sq_distance, double max_distance = std::numeric_limits<double>::infinity(),
              int skip = -1) const;

  double cell() const { return cell_; }

 private:
  Eigen::Vector3d lo_;
  double cell_ = 0;
  Eigen::Vector3i dims_;
  std::vector<int> cell_start_;  ///< first slot of each cell, one past the end at the back
  std::vector<int> index_;       ///< row of P of each slot
  std::vector<double> xyz_;      ///< coordinates of each slot, 3 per slot, in cell order
};

}  // namespace posekit
