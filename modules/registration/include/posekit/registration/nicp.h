#pragma once
// Optimal-step non-rigid ICP (Amberg, Romdhani and Vetter, CVPR 2007). Each source vertex i gets an
// affine map X_i (4 x 3); for each stiffness alpha of a decreasing schedule, iterate
//   min  alpha^2 ||(M (x) G) X||^2 + ||W (D X - U)||^2 + beta^2 ||D_L X - U_L||^2
// (M: edge-vertex incidence, G = diag(1, 1, 1, gamma), D: rows [x y z 1] of the source, U: the
// targets of the accepted pairs, D_L/U_L: landmarks) until X stops changing, by sparse Cholesky
// whose symbolic analysis is done once. The data term is point-to-plane: each vertex is pulled along
// the target's normal at its closest surface point (plus a small point-to-point share), which has
// the same minimisers as the plane distance and keeps the three coordinates' systems one matrix.
#include <Eigen/Core>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// A point of the source surface (triangle, barycentric coordinates) that must land on `target`.
struct NicpLandmark {
  int source_face = 0;
  Eigen::Vector3d source_bary = Eigen::Vector3d::Constant(1.0 / 3);
  Eigen::Vector3d target = Eigen::Vector3d::Zero();
};

struct NicpOptions {
  /// Stiffness schedule alpha, from nearly rigid to soft (in the source's normalised frame: centred,
  /// unit RMS radius; with unit gamma).
  std::vector<double> stiffness = {100, 50, 25, 12, 6, 3, 1.5};
  int max_iterations_per_stiffness = 5;
  double convergence = 1e-3;  ///< next stiffness when the RMS change of vertex positions is below this (m)
  double gamma = 1.0;         ///< weight of the translation part in the stiffness term
  /// beta at the first stiffness (landmarks together weigh beta^2 times all data pairs); it falls in
  /// proportion to alpha. 10 measured best of 1, 3, 10, 30 on the 16 dataset subjects.
  double landmark_weight = 10.0;
  double point_to_point = 0.1;        ///< share of the point-to-point pull in the data term (0: pure point-to-plane)
  double max_distance = 0.1;          ///< m: pairs farther apart are rejected
  double max_normal_angle_deg = 60;   ///< pairs whose normals disagree more are rejected
  bool reject_boundary = true;        ///< reject pairs whose target point is on a hole's border
  bool align_landmarks_first = true;  ///< similarity transform onto the landmarks before the first step
};

struct NicpResult {
  Eigen::MatrixXd V;              ///< #V x 3 deformed source
  std::vector<double> stiffness;  ///< the schedule run
  std::vector<int> iterations;    ///< iterations run at each stiffness
  int solves = 0;
  double final_mean_distance = 0;  ///< m, over the accepted pairs of the last iteration
  double accepted_fraction = 0;    ///< of the source vertices, in the last iteration
  int landmarks = 0;
};

/// Deforms source towards target. `start` (optional, #V x 3): initial positions of the source's
/// vertices (e.g. ct-FFD's result), from which the affine maps are fitted; otherwise the source's own.
/// Landmarks refer to the source's triangles. Deterministic. Throws InvalidInput for unusable meshes
/// or options.
NicpResult nonrigid_icp(const TriangleMesh& source, const TriangleMesh& target, const NicpOptions& options = {},
                        const std::vector<NicpLandmark>& landmarks = {}, const Eigen::MatrixXd* start = nullptr);

}  // namespace posekit
