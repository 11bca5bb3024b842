#pragma once
// The rigid part rotations T^R(i) of a registered example estimated from its vertices alone, for
// pose datasets that come without joint angles (SCAPE, FAUST, 4D captures). Section 3.3.2 of Zhu &
// Mok: "we obtain the rigid deformations ... by rigid part rotation T^R(i) for all pose instances".
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "posekit/body/parts.h"

namespace posekit {

struct PartFitOptions {
  /// Skin slides over joints: a vertex nearer a joint of its part than `joint_zone` times the reach
  /// of the longer part at that joint (largest vertex distance from its joints) starts at weight 0.1
  /// and reaches 1 at twice that distance.
  double joint_zone = 0.2;
  int robust_iterations = 6;        ///< Cauchy reweighting rounds after the first fit
  double min_robust_scale = 0.002;  ///< m: residuals under this are never down-weighted
  /// Parts meet at their joints: after the per-part fits, all 16 motions are refined together with
  /// each joint centre carried by parent and child to one place, weighted like this fraction of
  /// the lighter part's vertices (0: independent parts).
  double joint_coupling = 1.0;
  /// Finally the pose itself is fitted, each vertex placed through the joint chain as posing places
  /// it (T^R about the rest joint centres): Gauss-Newton rounds at most (0: the parts' rotations as
  /// fitted, their places left to the chain).
  int chain_iterations = 5;
};

/// One example's estimated pose and how well rigid parts explain it.
struct PartPoseEstimate {
  PartPose pose;                             ///< refined along the chain (PartFitOptions::chain_iterations); else R_parent^T R_child
  std::array<Eigen::Matrix3d, kNumParts> R;  ///< world rotation of each part
  std::array<Eigen::Vector3d, kNumParts> t;  ///< x_posed = R x_rest + t
  /// Per part, the RMS residual (m) of its rigid fit over the vertices away from the joints (weight
  /// of the joint zone 1), and over all its vertices.
  std::array<double, kNumParts> core_rms{}, part_rms{};
  std::array<double, kNumParts> reach{};  ///< m, largest rest distance of a part's vertex from its joints
  double rms = 0;                         ///< m, over every vertex's rigid-fit residual
  int worst_part = 0;                     ///< the part of largest core_rms
};

/// Fits each of the 16 parts of a rest mesh (per-triangle labels, joints in the rest pose) to a
/// posed copy of the same topology by weighted Procrustes (Kabsch) with the joint zones down-weighted
/// and Cauchy reweighting of the residuals; joint rotations start as R_parent^T R_child, then the
/// pose is refined along the joint chain so that T^R itself places every part (a rest joint centre
/// a little off would otherwise carry its subtree away: 20 mm at a hand in a reach).
class PartPoseEstimator {
 public:
  /// Throws InvalidInput when labels or joints do not fit the mesh or a part has fewer than 3 vertices.
  PartPoseEstimator(const Eigen::MatrixXd& rest_V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                    const Eigen::MatrixXd& joint_centres, const PartFitOptions& options = {});
  /// Throws InvalidInput when `posed_V` has another vertex count or is not finite.
  PartPoseEstimate estimate(const Eigen::MatrixXd& posed_V) const;

  /// Learns which vertices of each part move rigidly with it from a set of posed examples: a vertex
  /// whose rigid-fit residual (RMS over the examples, so one pose that moves it counts) is large for
  /// its part, skin that slides or bulges near a joint, is down-weighted in every later estimate
  /// (Cauchy weight on that residual over the part's median). Returns the per-vertex RMS residuals (m).
  Eigen::VectorXd learn_rigid_cores(const std::vector<const Eigen::MatrixXd*>& examples);

 private:
  void refine_along_chain(const Eigen::MatrixXd& posed_V, const std::array<std::vector<double>, kNumParts>& weights, PartPose* pose) const;
  void couple_at_joints(const Eigen::MatrixXd& posed_V, const std::array<std::vector<double>, kNumParts>& weights,
                        PartPoseEstimate* estimate) const;

  Eigen::MatrixXd rest_V_;
  Eigen::MatrixXd joints_;
  std::array<std::vector<int>, kNumParts> part_vertices_;
  std::array<std::vector<double>, kNumParts> joint_weight_;
  std::array<std::vector<char>, kNumParts> away_from_joints_;  ///< weight 1 from the joint zones
  std::array<double, kNumParts> reach_{};
  PartFitOptions options_;
};

/// Angle (radians) of the rotation between two joint rotations given as axis-angle vectors.
double rotation_difference(const Eigen::Vector3d& a, const Eigen::Vector3d& b);

/// What is implausible in an estimated pose, the worst first (empty: nothing): a part whose rigid
/// fit leaves a core RMS over `max_core_rms` (m) or over a quarter of its reach (a flipped or
/// mislabelled part, a wrong rest example; a pelvis under a hip flexed 100 degrees bulges 25 mm),
/// and joints bent beyond what a body does (any joint over 175 degrees).
std::vector<std::string> pose_estimate_problems(const PartPoseEstimate& estimate, double max_core_rms = 0.05);

}  // namespace posekit
