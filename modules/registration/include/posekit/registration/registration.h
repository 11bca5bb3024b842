#pragma once
// Registering a source body (e.g. the template) to a target body (a customized model) and the
// triangle correspondence that follows (section 3.3.3 of Zhu & Mok): ct-FFD, or the rigid ICP
// baseline of the paper's Table 1.
#include <Eigen/Core>
#include <string>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

enum class RegistrationMethod { kCtffd, kIcp, kNicp };

struct RegistrationOptions {
  RegistrationMethod method = RegistrationMethod::kCtffd;
  int icp_iterations = 6;            ///< PCL IterativeClosestPoint iterations (kIcp)
  int points_per_layer = 32;         ///< layered representation resolution (kCtffd)
};

struct RegistrationResult {
  Eigen::MatrixXd deformed_source;   ///< #Vs x 3: the source moved onto the target
  Eigen::VectorXi correspondence;    ///< #Ft: for each target triangle, its source triangle (Eq. 2b/2c)
  int normal_failures = 0;           ///< target triangles with no source triangle facing the same way
  double seconds = 0;                ///< wall time of the whole registration
};

/// Registers source to target and matches triangles by nearest centroid. Throws InvalidInput when a
/// body's features cannot be found (ct-FFD) or a mesh is unusable.
RegistrationResult register_bodies(const TriangleMesh& source, const TriangleMesh& target, const RegistrationOptions& options = {});

RegistrationMethod parse_registration_method(const std::string& name);  ///< "ctffd", "icp" or "nicp"

}  // namespace posekit
