#pragma once
// Accuracy of pose synthesis against ground truth (issue "Pose deformation"): the held-out poses of
// a registered pose dataset on its template, and the posed ground truth of customized subjects.
#include <Eigen/Core>
#include <array>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"

namespace posekit {

/// Per-vertex error statistics, millimetres.
struct ErrorStats {
  double mean_mm = 0, p95_mm = 0, max_mm = 0;
  long count = 0;
};
/// Statistics of a sample of distances in metres.
ErrorStats error_stats(const std::vector<double>& distances_m);

struct PoseEvaluationOptions {
  std::vector<PoseMethod> methods = {PoseMethod::kLearned, PoseMethod::kRigid, PoseMethod::kLbs};
  bool template_poses = true;  ///< (a) held-out poses of the pose dataset
  bool subjects = true;        ///< (b) posed ground truth of the dataset's subjects
  std::function<void(int, int, const std::string&)> progress;
};

struct MethodErrors {
  PoseMethod method;
  ErrorStats all;
  std::array<ErrorStats, kNumParts> per_part;  ///< by the ground-truth part of each vertex
};

struct SubjectPoseReport {
  std::string id;
  double setup_seconds = 0;
  double segmentation_agreement = -1;                        ///< area fraction vs ground truth (-1: unknown)
  double joint_error_max_mm = -1, joint_error_mean_mm = -1;  ///< vs the rig's joints (-1: unknown)
  std::vector<MethodErrors> methods;
};

/// Mean per-vertex error per method of one kind of pose (pose_type), template and subjects apart.
struct PoseTypeErrors {
  std::string type;
  int template_poses = 0, subject_meshes = 0;
  std::vector<double> template_mean_mm, subject_mean_mm;  ///< per method, as in the options
};

/// The kind of a pose by its name: "walk", "reach", "squat" (squats, lunge), "sit", "torso",
/// "combined" (random, guard, t_pose) or "single joint".
std::string pose_type(const std::string& pose_name);

struct PoseEvaluation {
  int test_poses = 0;
  std::vector<PoseTypeErrors> by_pose_type;   ///< (a) and (b) per kind of pose, in a fixed order
  std::vector<MethodErrors> template_errors;  ///< (a)
  std::vector<SubjectPoseReport> subjects;    ///< (b) one per subject
  std::vector<MethodErrors> subject_errors;   ///< (b) all subjects pooled
  double pose_ms_median = 0;                  ///< learned method, one pose of one subject
};

/// Evaluates `model` on a posekit dataset folder. Throws InvalidInput when the model was trained on
/// another template than the dataset's and IoError on unreadable files.
PoseEvaluation evaluate_poses(const std::string& dataset_dir, std::shared_ptr<const PoseModel> model,
                              const PoseEvaluationOptions& options = {});

/// Where train_on_dataset takes each training example's 16-part pose from.
enum class TrainingPoses {
  kAuto,     ///< the pose JSONs when every training example has one, else estimated from the meshes
  kJson,     ///< the pose JSONs; an example without one is an error
  kEstimate  ///< estimated from the meshes (PartPoseEstimator); JSONs, where present, only check
};
TrainingPoses parse_training_poses(const std::string& name);  ///< "auto", "json" or "estimate"

class BodyModel;

struct DatasetTrainingOptions {
  TrainingPoses poses = TrainingPoses::kAuto;
  /// The rest-pose example (the template). Empty: the manifest's, else the first whose pose JSON is
  /// all zero, else one whose name holds "rest" or "template", else the first in name order.
  std::string rest_name;
  std::string unit = "m";                 ///< m, dm, cm, mm, or auto (from the rest mesh's extent)
  std::string up = "+Y", forward = "+Z";  ///< file axes of the body, or auto (from the rest mesh)
  PartFitOptions fit;
  /// When set, a rest example without shipped labels takes its parts and joints from this body
  /// model fitted to it (any rest pose) instead of from the rules about its sections; a poor fit
  /// throws BelowConfidence unless `accept_poor_fit` (then it is a warning of the report).
  const BodyModel* body_model = nullptr;
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
  bool labels_from_body_model = false;   ///< DatasetTrainingOptions::body_model's fit
  std::vector<ExamplePoseFit> examples;  ///< every example, when the poses were estimated
  std::vector<std::string> warnings;
};

/// Trains on the dataset's training split with its template labels and joints (template/parts.json,
/// template/joints.json) or, without them, the template's own segmentation and skeleton. Poses are
/// the JSONs or, for a folder of meshes alone, estimated per example from its parts' rigid motions.
/// Throws InvalidInput when the rest example is unknown, a JSON pose is required but missing, or a
/// part cannot be fitted.
PoseModel train_on_dataset(const std::string& dataset_dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                           DatasetTrainingReport* report = nullptr);
PoseModel train_on_dataset(const std::string& dataset_dir, const TrainingOptions& base = {});

/// One posing method on the held-out meshes of a folder: the raw per-vertex error, and the "shape"
/// error left after each part of the posed body is rigidly aligned (Umeyama, no scale) onto the
/// same part of the held-out mesh: raw minus shape is where the part was placed.
struct FolderMethodErrors {
  PoseMethod method;
  ErrorStats raw, shape;
  std::array<ErrorStats, kNumParts> raw_per_part, shape_per_part;
};

struct FolderMeshErrors {
  std::string name, type;                          ///< type: pose_type(name)
  double pose_fit_rms_mm = 0;                      ///< the held-out mesh against its parts' rigid motions
  std::vector<std::string> problems;               ///< pose_estimate_problems of its estimated pose
  std::vector<double> raw_mean_mm, shape_mean_mm;  ///< per method
};

struct FolderTypeErrors {
  std::string type;
  int meshes = 0;
  std::vector<double> raw_mean_mm, shape_mean_mm;  ///< per method
};

struct FolderPoseEvaluation {
  DatasetTrainingReport training;
  int training_poses = 0;
  double train_seconds = 0;
  std::vector<FolderMethodErrors> methods;
  std::vector<FolderMeshErrors> meshes;
  std::vector<FolderTypeErrors> by_pose_type;
};

/// Evaluation on a folder of registered meshes of one person (issue 45 part 3): trains on every
/// example but the held-out ones (options.held_out or hold_out_every; else the manifest's split),
/// estimates each held-out mesh's pose from its vertices (PartPoseEstimator, rigid cores learned on
/// the training examples), poses the rest example at it with each method and compares vertex by
/// vertex. Throws InvalidInput when nothing is held out or nothing is left to train on.
FolderPoseEvaluation evaluate_registered_folder(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                                const std::vector<PoseMethod>& methods = {PoseMethod::kLearned, PoseMethod::kRigid,
                                                                                          PoseMethod::kLbs});

struct PeoplePoseEvaluation {
  std::vector<std::string> people;               ///< the person folders, in name order
  std::vector<DatasetTrainingReport> reports;    ///< how each person's folder was read
  std::vector<FolderPoseEvaluation> per_person;  ///< each person's meshes, the model trained on the others
  std::vector<FolderMethodErrors> methods;       ///< every person's meshes pooled
  std::vector<FolderTypeErrors> by_pose_type;
};

/// The same for several people of one topology (issue 45 part 3): `dir` holds one folder of
/// registered meshes per person. Each person in turn: a model trained on the other people's examples
/// (each example's deformation measured from its own person's rest, Eq. 5 pooled), this person's
/// rest mesh posed by it (the correspondence is the shared topology; this person's own parts and
/// joints) at each of this person's other meshes' poses estimated from their vertices. Throws
/// InvalidInput with fewer than two person folders or another topology in one of them.
PeoplePoseEvaluation evaluate_registered_people(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                                const std::vector<PoseMethod>& methods = {PoseMethod::kLearned, PoseMethod::kRigid,
                                                                                          PoseMethod::kLbs},
                                                const std::function<void(int, int, const std::string&)>& progress = {});

}  // namespace posekit
