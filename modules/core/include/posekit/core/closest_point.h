#pragma once
// Exact closest points on a triangle mesh: point-to-triangle distance through an AABB tree.
#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <vector>

namespace posekit {

/// The point of triangle (a, b, c) nearest to p, exactly (Voronoi regions of vertices, edges and
/// face; Ericson, Real-Time Collision Detection, 5.1.5). `bary` (optional) receives its
/// barycentric coordinates.
Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c, Eigen::Vector3d* bary = nullptr);

/// Closest points of many query points.
struct ClosestPoints {
  Eigen::VectorXi face;      ///< #P, the triangle holding the closest point
  Eigen::MatrixXd point;     ///< #P x 3
  Eigen::MatrixXd bary;      ///< #P x 3, barycentric coordinates in that triangle
  Eigen::VectorXd distance;  ///< #P, unsigned (m)
};

/// One query's closest point, as TriangleTree::for_each_closest reports it.
struct ClosestHit {
  int face = -1;          ///< the triangle holding the closest point
  Eigen::Vector3d point;  ///< the closest point
  Eigen::Vector3d bary;   ///< its barycentric coordinates in that triangle
  double distance = 0;    ///< unsigned (m)
};

/// An axis-aligned bounding-box tree over the triangles of a mesh, built once.
class TriangleTree {
 public:
  TriangleTree(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
  ~TriangleTree();
  TriangleTree(const TriangleTree&) = delete;
  TriangleTree& operator=(const TriangleTree&) = delete;

  /// Nearest point on the mesh to p. `max_distance` bounds the search (face -1 when nothing is closer).
  int closest(const Eigen::Vector3d& p, Eigen::Vector3d* point, double* distance,
              double max_distance = std::numeric_limits<double>::infinity()) const;

  /// All rows of P (#P x 3), split over `threads` threads (0: the hardware's). `start_faces`
  /// (optional, #P; -1 for none) names a face near each point, e.g. the last iteration's: its
  /// distance bounds the search from the start. The result is exact either way.
  ClosestPoints closest(const Eigen::MatrixXd& P, int threads = 0, const Eigen::VectorXi* start_faces = nullptr) const;

  /// The same search as closest(P, ...), without its #P x 3 arrays: `visit(i, hit)` is called once
  /// for every row i, from the worker threads (rows in no particular order, each by one thread).
  void for_each_closest(const Eigen::MatrixXd& P, int threads, const std::function<void(Eigen::Index, const ClosestHit&)>& visit,
                        const Eigen::VectorXi* start_faces = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace posekit
