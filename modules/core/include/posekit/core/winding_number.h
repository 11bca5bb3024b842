#pragma once
#include <Eigen/Core>

namespace posekit {

/// Generalized winding number of a closed, outward-oriented mesh at point p (Jacobson et al. 2013):
/// about 1 inside, 0 outside, robust to small holes. Sum of signed solid angles / 4 pi.
double winding_number(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& p);

}  // namespace posekit
