#pragma once
// Triangle correspondence by nearest centroid with a normal test (Eq. 2b/2c of Zhu & Mok).
#include <Eigen/Core>
#include <memory>

namespace posekit {

/// A KD-tree over the triangles of a (deformed) source mesh, built once (FLANN).
class CentroidIndex {
 public:
  /// V #V x 3, F #F x 3 of the source mesh.
  CentroidIndex(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
  ~CentroidIndex();
  CentroidIndex(const CentroidIndex&) = delete;
  CentroidIndex& operator=(const CentroidIndex&) = delete;

  /// For each target triangle (centroids C #T x 3, unit normals N #T x 3): the source triangle with
  /// the nearest centroid whose normal is within 90 degrees (Eq. 2b with the penalty of Eq. 2c).
  /// Among `candidates` nearest; when none agrees in normal the nearest is used and counted in
  /// `normal_failures` (optional). The queries are split over `threads` threads (0: the
  /// hardware's); the answer does not depend on how many.
  Eigen::VectorXi match(const Eigen::MatrixXd& C, const Eigen::MatrixXd& N, int candidates = 16, int* normal_failures = nullptr,
                        int threads = 1) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Convenience: target triangle -> source triangle for two meshes already in place.
Eigen::VectorXi nearest_centroid_correspondence(const Eigen::MatrixXd& source_V, const Eigen::MatrixXi& source_F,
                                                const Eigen::MatrixXd& target_V, const Eigen::MatrixXi& target_F,
                                                int* normal_failures = nullptr, int threads = 1);

}  // namespace posekit
