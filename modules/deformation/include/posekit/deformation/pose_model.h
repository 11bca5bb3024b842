#pragma once
// The learned non-rigid pose deformation T^Q (Eq. 3-5, section 3.3.2 of Zhu & Mok): per template
// triangle, a 9 x 7 linear map from the twists of the two joints next to its part (and a bias) to
// the entries of its 3 x 3 deformation in the part's frame.
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/segmentation/segmentation_prior.h"

namespace posekit {

struct PoseDataset;

constexpr int kPoseFeatures = 7;                      ///< twists of two joints (3 + 3) and a bias
constexpr int kPoseCoefficients = 9 * kPoseFeatures;  ///< per triangle: each entry of T^Q times each feature

struct PoseModel {
  Eigen::MatrixXd template_V;       ///< #V x 3 rest pose of the training template (m)
  Eigen::MatrixXi template_F;       ///< #F x 3
  Eigen::VectorXi triangle_part;    ///< #F, L(k) of Eq. 1
  Eigen::MatrixXd joint_centres;    ///< #joints x 3, rest pose
  Eigen::MatrixXi triangle_joints;  ///< #F x 2, the joints driving each triangle (-1: none)
  /// #F x 63: row k holds b_k of Eq. 4, entry (m, f) at m * 7 + f, m the row-major index into T^Q,
  /// f the feature [twist_1 (3), twist_2 (3), 1].
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> coefficients;
  /// Pose-dependent joint placement learned from the examples (rigid_pose.h, part_transforms with
  /// offsets), #joints x 27; empty: the joints stay where T^R puts them.
  Eigen::MatrixXd joint_offsets;
  int training_poses = 0;
  double fit_rms = 0;  ///< RMS residual of Eq. 5 over all entries and poses
  /// #F: per triangle the RMS residual of Eq. 5 over its 9 entries and the training poses; empty
  /// where unknown (a model file of an older posekit).
  Eigen::VectorXd triangle_rms;
  /// Labelled bodies that segment and embed the skeleton of a customized model (segmentation_prior.h);
  /// empty: the template alone.
  SegmentationPrior segmentation_prior;
};

/// The model's segmentation prior, or when it has none, one made of the template with its labels
/// and joints (the paper's single labelling of the representation).
SegmentationPrior segmentation_prior_of(const PoseModel& model);

struct TrainingOptions {
  /// Template labels and joints when the dataset has none (a posekit dataset supplies both).
  Eigen::VectorXi triangle_part;
  Eigen::MatrixXd joint_centres;
  double pca_energy = 1e-4;  ///< drop twist directions with variance below this fraction
  double ridge = 1e-4;       ///< Tikhonov weight on the reduced coefficients
  /// Fix the bias of Eq. 4 to the identity, so that the rest pose reproduces the template exactly;
  /// otherwise the bias is fitted like the other weights.
  bool identity_at_rest = true;
  /// An extension beyond the paper (off by default, which is Eq. 3-5 as published; issue 18, part 5).
  /// Learn where each joint sits as a function of its twist (a rising shoulder girdle, a head turned
  /// over its neck bones, a chest bending over two thoracic bones): from each part's rigid fit to
  /// every training example (part_pose_estimation.h), where the child must carry the joint for its
  /// own child joints to land where their parts do, relative to the posed parent; fitted as the point
  /// the joint effectively turns about, then a ridge regression on the twist and its quadratic terms
  /// of what that leaves; per joint, regression, pivot alone or nothing, whichever poses held-out
  /// examples best (five folds).
  bool learn_joint_offsets = false;
  /// An extension beyond the paper (0, the default, is Eq. 5 as published; issue 18, part 5): a
  /// smoothness prior for noisy training meshes. Each example's observed T^Q field is smoothed this many
  /// times over edge-adjacent triangles of the same part (each moved halfway to its neighbours' mean)
  /// before the regression.
  int smoothing_iterations = 0;
  std::function<void(int, int)> progress;
};

/// Fits Eq. 5 on every training example of a registered pose dataset (held-out examples skipped)
/// whose 16-part pose is known. Throws InvalidInput when there are fewer than 2 such examples or the
/// template labels/joints are missing or inconsistent.
PoseModel train_pose_model(const PoseDataset& dataset, const TrainingOptions& options);

/// Twist features x (7) of each joint pair of a pose: the joint rotations as axis-angle vectors.
/// Eq. 4: T^Q_k = reshape(B_k x). Returns #F x 9 (row-major 3 x 3 per row).
Eigen::MatrixXd predict_nonrigid(const PoseModel& model, const PartPose& pose);

/// Deformation gradient of each triangle from rest (V0) to deformed (V1), made well-posed with a
/// fourth vertex along the normal (Sumner & Popovic 2004): #F x 9, row-major.
Eigen::MatrixXd deformation_gradients(const Eigen::MatrixXd& V0, const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F);

/// Binary model file (.pkm, little-endian, see README). Written atomically; reading checks sizes,
/// labels and finiteness and throws IoError naming the file.
void write_pose_model(const std::string& path, const PoseModel& model);
PoseModel read_pose_model(const std::string& path);
/// The .pkm file's bytes (checksum trailer included), and back; `context` names the source in errors.
std::string pose_model_bytes(const PoseModel& model);
PoseModel pose_model_from_bytes(std::string bytes, const std::string& context);

}  // namespace posekit
