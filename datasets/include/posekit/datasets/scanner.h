#pragma once
// A simulated body-scanning booth: several depth cameras around the subject, rays cast to the
// surface, noise along the ray, natural occlusion holes, optional outliers.
#include <Eigen/Geometry>
#include <vector>

#include "posekit/core/point_cloud.h"
#include "posekit/core/rasterizer.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct ScannerOptions {
  int views_around = 4;                        ///< pillars, at 45, 135, 225, 315 degrees
  std::vector<double> heights = {0.55, 1.35};  ///< camera heights above the floor (m)
  double distance = 1.3;                       ///< from the booth axis (m)
  int width = 480, height = 640;               ///< pixels per camera
  double focal_px = 460;
  double noise_sigma = 0.0015;      ///< Gaussian noise along the ray (m)
  double outlier_fraction = 0.001;  ///< extra points scattered around the subject
  double min_incidence_cos = 0.15;  ///< grazing returns below this are dropped
  unsigned seed = 1;
};

/// Cloud in metres with point scalars "view" (camera index, -1 for outliers) and "outlier" (0/1).
struct SimulatedScan {
  PointCloud cloud;
  std::vector<PinholeCamera> cameras;
  int outliers = 0;
};

/// Scans a mesh standing on the floor (its lowest point), booth axis through its centre.
SimulatedScan simulate_scan(const TriangleMesh& mesh, const ScannerOptions& options = {});

/// A scanner's watertight reconstruction of a body whose surfaces press into each other (thighs
/// together): the triangles within `region` inside the body elsewhere are removed, and each pair of facing holes
/// this leaves (one on each surface, along the curve where they meet) is zipped into one seam, so
/// the touching thighs become one surface, as a scan's reconstruction makes them. `mesh` must be
/// closed and outward-oriented. `face_origin` (optional) receives, for each triangle of the result,
/// the triangle of `mesh` it is or whose hole it closes. Throws InvalidInput when a hole has no
/// facing partner or the result is not a closed manifold; returns `mesh` unchanged where nothing
/// interpenetrates.
TriangleMesh fuse_interpenetrating_surfaces(const TriangleMesh& mesh, const Eigen::AlignedBox3d& region,
                                            std::vector<int>* face_origin = nullptr);

}  // namespace posekit
