#include "posekit/core/winding_number.h"

#include <Eigen/Geometry>
#include <cmath>

namespace posekit {

double winding_number(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& p) {
  double total = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Vector3d a = V.row(F(f, 0)).transpose() - p, b = V.row(F(f, 1)).transpose() - p, c = V.row(F(f, 2)).transpose() - p;
    const double la = a.norm(), lb = b.norm(), lc = c.norm();
    // Van Oosterom & Strackee: tan(Omega / 2) = det / denominator.
    const double det = a.dot(b.cross(c));
    const double den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    total += 2.0 * std::atan2(det, den);
  }
  return total / (4.0 * M_PI);
}

}  // namespace posekit
