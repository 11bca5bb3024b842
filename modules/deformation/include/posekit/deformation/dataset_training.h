#pragma once
// Training the pose model (Eq. 3-4) on a registered pose dataset on disk: its template's labels
// and joints, shipped or found, and each example's 16-part pose, given or estimated from the meshes.
#include <Eigen/Core>
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/deformation/pose_model.h"

namespace posekit {

/// Where train_on_dataset takes each training example's 16-part pose from.
enum class TrainingPoses {
  kAuto,     ///< the pose JSONs when every training example has one, else estimated from the meshes
  kJson,     ///< the pose JSONs; an example without one is an error
  kEstimate  ///< estimated from the meshes (PartPoseEstimator); JSONs, where present, only check
};
TrainingPoses parse_training_poses(const std::string& name);  ///< "auto", "json" or "estimate"

/// Labels of a rest example without shipped ones: its triangles' parts and its joint centres, and
/// why the labelling is poor ("" when it is not). fitting/body_fit.h's body_model_labeller gives
/// them by a body model's fit.
struct RestLabels {
  Eigen::VectorXi triangle_part;
  Eigen::MatrixXd joint_centres;
  std::string poor_fit;
};
using RestLabeller = std::function<RestLabels(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F)>;

struct DatasetTrainingOptions {
  TrainingPoses poses = TrainingPoses::kAuto;
  /// The rest-pose example (the template). Empty: the manifest's, else the first whose pose JSON is
  /// all zero, else one whose name holds "rest" or "template", else the first in name order.
  std::string rest_name;
  std::string unit = "m";                 ///< m, dm, cm, mm, or auto (from the rest mesh's extent)
  std::string up = "+Y", forward = "+Z";  ///< file axes of the body, or auto (from the rest mesh)
  PartFitOptions fit;
  /// When set, a rest example without shipped labels takes its parts and joints from it (a body
  /// model fitted to it, in any rest pose) instead of from the rules about its sections; a poor
  /// labelling throws BelowConfidence unless `accept_poor_fit` (then it is a warning of the report).
  RestLabeller label_rest;
  bool accept_poor_fit = false;
  /// The held-out split, instead of the manifest's: these examples by name, or every N-th example in
  /// name order with the rest example skipped (0: the manifest's split).
  std::vector<std::string> held_out;
  int hold_out_every = 0;
};

/// How one example's estimated pose fits (millimetres, degrees).
struct ExamplePoseFit {
  std::string name;
  bool test = false;
  double rms_mm = 0;             ///< every vertex against its part's rigid motion
  double worst_core_rms_mm = 0;  ///< the worst part away from its joints
  std::string worst_part;
  /// Against the example's pose JSON, where it has one (-1: none): the angle between estimated and
  /// given joint rotations, mean and max over the 15 joints and the root.
  double joint_error_mean_deg = -1, joint_error_max_deg = -1;
  std::string worst_joint;
  std::vector<std::string> problems;  ///< pose_estimate_problems, and the dataset-level check
  bool left_out = false;              ///< not the rest body posed: not trained on
  PartPose pose;                      ///< the estimated pose, in posekit's frame (the rest example's: zero)
};

struct DatasetTrainingReport {
  std::string rest_name, rest_reason;  ///< the template and why it was chosen
  bool poses_estimated = false;
  std::string unit, orientation;         ///< as read
  bool labels_from_dataset = false;      ///< template/parts.json and joints.json, else segmented (Eq. 2)
  bool labels_from_body_model = false;   ///< DatasetTrainingOptions::label_rest
  std::vector<ExamplePoseFit> examples;  ///< every example, when the poses were estimated
  std::vector<std::string> warnings;
};

/// A dataset read for training: examples in posekit's frame and unit with their poses (given or
/// estimated), the split applied (DatasetTrainingOptions), and the template's labels and joints in
/// `options`. The first stage of train_on_dataset; `report` receives what was chosen and found.
struct PreparedTraining {
  PoseDataset data;
  TrainingOptions options;
  int rest = 0;  ///< the rest example
};
PreparedTraining prepare_training(const std::string& dataset_dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                  DatasetTrainingReport* report);

/// Trains on the dataset's training split with its template labels and joints (template/parts.json,
/// template/joints.json) or, without them, the template's own segmentation and skeleton. Poses are
/// the JSONs or, for a folder of meshes alone, estimated per example from its parts' rigid motions.
/// Throws InvalidInput when the rest example is unknown, a JSON pose is required but missing, or a
/// part cannot be fitted.
PoseModel train_on_dataset(const std::string& dataset_dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                           DatasetTrainingReport* report = nullptr);
PoseModel train_on_dataset(const std::string& dataset_dir, const TrainingOptions& base = {});

}  // namespace posekit
