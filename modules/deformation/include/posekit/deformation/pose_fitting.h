#pragma once
// The 16-part pose of a body that makes it match a target (a scan with holes, noise and outliers, or
// a mesh of any topology), with no markers: articulated ICP with the posing method in the loop
// (issue 18, part 2). To compare a posed model with a posed scan (Figure 9 of Zhu & Mok) the scan's
// pose must be known; the paper picked markers by hand.
#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"

namespace posekit {

struct PoseFitOptions {
  PoseMethod method = PoseMethod::kLearned;  ///< the posing run inside the loop
  /// Levenberg-Marquardt steps of the final refinement at most (it stops earlier when a step lowers
  /// the objective by under a millionth, or `stall_window` accepted steps together by under
  /// `stall_gain` of it), and of each start hypothesis's brief refinement.
  int iterations = 100, search_iterations = 8;
  /// A refinement crawling on ends early when set (0: off, the default): `stall_window` accepted
  /// steps together lowering the objective by under `stall_gain` of it. The body model's fit sets
  /// 1e-3 over 5 steps (see fit_body_model); `posekit fit`'s figures (docs/pose-model.md) were
  /// measured without it.
  int stall_window = 5;
  double stall_gain = 0;
  int model_samples = 3000;  ///< model vertices and target points matched each way per iteration
  /// Model vertices matched per iteration in the final refinement (target points: model_samples):
  /// every vertex of a body of up to this many. Every fourth vertex of a 12.4k-vertex subject, as
  /// while searching, left the fitted joints 3.12 degrees off over the 48 scans of eval fit, every
  /// vertex 2.46 (docs/pose-model.md).
  int refinement_model_samples = 12000;
  /// Correspondences farther than this are ignored; the Cauchy scale of the weights is a third of
  /// it. The distance shrinks from `start` to `end` (m) while the start hypotheses are refined, and
  /// stays at `end` after: a part whose data all lay beyond a smaller distance would lose it and
  /// fall back to the rest prior.
  double max_distance_start = 0.5, max_distance_end = 0.1;
  /// Prior on the joint rotations: a weak pull towards the rest pose, and a strong one beyond each
  /// joint's range (joint_limit_degrees), relative to the data term.
  double rest_prior = 1e-3, limit_prior = 1.0;
  /// In the final refinement the rest prior pulls each joint's swing, and its twist about the bone
  /// only with this weight (relative to the swing; 1: about as the whole rotation): pulling the
  /// whole rotation towards the rest favours the smallest rotation that points a limb, which twisted
  /// arms reaching forward 27 degrees away from their true pose. Some weight still settles how a
  /// twist is shared along a limb (elbow against wrist), which the surface hardly shows.
  double refinement_twist_weight = 0.1;
  /// The rest prior's weight in the final refinement, weaker than while searching: by then the
  /// hypotheses have brought the pose near the target's, and a pull towards the rest only holds large
  /// rotations back (a half squat's lower back ended 10 degrees short at rest_prior). Over the 48
  /// scans of eval fit, 0.3 rest_prior gave the least angle error of 0, 0.1, 0.3, 1 and 3 (see
  /// docs/pose-model.md).
  double refinement_rest_prior = 3e-4;
  /// Prior on the swing of elbows and knees off their hinge (about the axis across both the bone and
  /// the flexion axis), relative to the data term like rest_prior: 0 treats them as ball joints.
  double hinge_prior = 0.1;
  /// Weight of the point-to-point term beside the point-to-plane one (along the body's normal): low
  /// while the distance shrinks, so that the body slides into place, high after, so that a limb
  /// cannot slide along itself (point-to-plane alone drifts from the true pose of a squat).
  double point_to_point_start = 1, point_to_point = 10;
  /// A body vertex is pulled to its nearest target point only when that point's nearest vertex lies
  /// within this distance (m) of it.
  double mutual_distance = 0.03;
  /// When set, the fit starts from this pose (e.g. the previous frame of a sequence) instead of
  /// searching headings and whole-body hypotheses.
  std::optional<PartPose> start;
  /// When set, the joint priors (rest_prior, refinement_rest_prior) pull towards this pose's joint
  /// rotations instead of the rest: a pose the caller recognised (a library pose). Where the surface leaves a choice open (a sitting
  /// body's pelvis tipped back with the hips flexed less and the lower back more: 35-43 degrees off
  /// on the robustness set's chair sitters) it then decides as that pose does, not towards standing.
  std::optional<PartPose> prior_pose;
  /// Threads matching the pairs of each iteration (0: the hardware's). The pairs are summed in
  /// fixed blocks, in order: the result does not depend on it.
  int threads = 1;
};

/// What fit_pose moves: a body at rest with a part per vertex, posed by a 16-part pose. A
/// PoseSynthesizer with a method is one; a shape-space body posed by skinning (fitting/body_model.h)
/// is another.
class PosableBody {
 public:
  virtual ~PosableBody() = default;
  virtual const Eigen::MatrixXd& rest_vertices() const = 0;  ///< #V x 3, m, Y up, facing +Z
  virtual const Eigen::MatrixXi& faces() const = 0;
  virtual const Eigen::VectorXi& vertex_parts() const = 0;   ///< #V, in [0, 16)
  virtual const Eigen::MatrixXd& joint_centres() const = 0;  ///< #joints x 3 at rest
  /// Where each joint effectively turns (#joints x 3, at rest): the Jacobian's centres of rotation.
  virtual Eigen::MatrixXd joint_pivots() const = 0;
  /// The posed body into X (#V x 3). Safe to call from several threads at once.
  virtual void pose(const PartPose& pose, Eigen::MatrixXd* X) const = 0;
  /// The rigid motion of each part in the pose.
  virtual PartTransforms part_motions(const PartPose& pose) const = 0;
};

/// The largest rotation (degrees) each joint takes before the limit prior acts, by joint index.
double joint_limit_degrees(int joint);

struct PoseFitResult {
  PartPose pose;
  Eigen::MatrixXd V;                       ///< the fitted body (#V x 3, m)
  Eigen::VectorXd residual;                ///< #V: distance of each fitted vertex to the nearest target point (m)
  double target_mean = 0, target_p95 = 0;  ///< target points to the fitted surface's vertices (m), outliers included
  double coverage = 0;                     ///< fraction of fitted vertices within 1 cm of a target point
  int iterations = 0;
  double seconds = 0;
  std::vector<std::string> warnings;  ///< poor coverage or residual, a joint at its limit
  /// Joints whose part (the one each moves) the target does not show (cut off or hidden, see the
  /// warnings): their rotations come from the priors, their centres from the parts before them.
  std::array<bool, kNumJoints> joint_guessed{};
};

/// Fits `synth`'s subject to target points T (#T x 3, m, Y up; any heading). No markers: the rest
/// pose stands on the target's lowest points at four headings, then whole-body hypotheses (arms
/// forward or up, half squat, sitting, a stride either way) at the best heading; each is refined
/// briefly and the best fully. Throws InvalidInput for a target of under 100 finite points or one
/// with no point near the body.
PoseFitResult fit_pose(const PoseSynthesizer& synth, const Eigen::MatrixXd& T, const PoseFitOptions& options = {});
/// The same for any posable body (options.method is then unused).
PoseFitResult fit_pose(const PosableBody& body, const Eigen::MatrixXd& T, const PoseFitOptions& options = {});

}  // namespace posekit
