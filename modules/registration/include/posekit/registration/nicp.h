#pragma once
// Optimal-step non-rigid ICP (Amberg, Romdhani and Vetter 2007): the accuracy baseline for template
// fitting. Each source vertex gets an affine map X_i (4 x 3); minimise
//   alpha^2 ||(M (x) G) X||^2 + ||W (D X - U)||^2
// (M: edge-vertex incidence, G = diag(1, 1, 1, gamma), D: vertex rows [x y z 1], U: closest target
// points, W: 0 for rejected pairs) for a decreasing stiffness alpha, by sparse Cholesky.
#include <Eigen/Core>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct NicpOptions {
  std::vector<double> stiffness = {50, 20, 10, 5, 2};  ///< alpha schedule
  int iterations_per_stiffness = 2;
  double gamma = 1.0;               ///< weight of the translation part in the stiffness term
  double max_distance = 0.1;        ///< m: pairs farther apart are rejected
  double max_normal_angle_deg = 60; ///< pairs whose normals disagree more are rejected
};

struct NicpResult {
  Eigen::MatrixXd V;       ///< #V x 3 deformed source
  int solves = 0;
  double final_mean_distance = 0;  ///< m, over accepted pairs
};

/// Deforms source towards target. Throws InvalidInput for unusable meshes.
NicpResult nonrigid_icp(const TriangleMesh& source, const TriangleMesh& target, const NicpOptions& options = {});

}  // namespace posekit
