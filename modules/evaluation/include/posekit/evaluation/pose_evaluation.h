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
#include "posekit/deformation/dataset_training.h"
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

/// One posing method on the held-out meshes of a folder: the raw per-vertex error, and the "shape"
/// error left after each part of the posed body is rigidly aligned (Umeyama, no scale) onto the
/// same part of the held-out mesh: raw minus shape is where the part was placed.
struct FolderMethodErrors {
  PoseMethod method;
  ErrorStats raw, shape;
  std::array<ErrorStats, kNumParts> raw_per_part, shape_per_part;
  /// Where the method's posed body puts each joint, against where T^R of the given pose puts it (its
  /// centre carried by the child part), over every mesh and joint. The posed body's joints are read
  /// off it as from any registered mesh: its pose estimated back from its vertices (PartPoseEstimator).
  ErrorStats joints;
  std::array<ErrorStats, kNumJoints> joints_per_joint;
};

struct FolderMeshErrors {
  std::string name, type;                          ///< type: pose_type(name)
  double pose_fit_rms_mm = 0;                      ///< the held-out mesh against its parts' rigid motions
  std::vector<std::string> problems;               ///< pose_estimate_problems of its estimated pose
  std::vector<double> raw_mean_mm, shape_mean_mm;  ///< per method
  /// The largest distance between two methods' placements of one joint (FolderMethodErrors::joints)
  double joint_spread_max_mm = 0;
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
  /// Per mesh and joint, the largest distance between two methods' placements of the joint (issue
  /// 45: the three methods agree on where each joint sits)
  ErrorStats joint_spread;
};

/// Evaluation on a folder of registered meshes of one person (issue 45 part 3): trains on every
/// example but the held-out ones (options.held_out or hold_out_every; else the manifest's split),
/// estimates each held-out mesh's pose from its vertices (PartPoseEstimator, rigid cores learned on
/// the training examples), poses the rest example at it with each method and compares vertex by
/// vertex, the held-out meshes on all cores. Throws InvalidInput when nothing is held out or nothing is
/// left to train on.
FolderPoseEvaluation evaluate_registered_folder(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                                const std::vector<PoseMethod>& methods = {PoseMethod::kLearned, PoseMethod::kRigid,
                                                                                          PoseMethod::kLbs});

struct PeoplePoseEvaluation {
  std::vector<std::string> people;               ///< the person folders, in name order
  std::vector<DatasetTrainingReport> reports;    ///< how each person's folder was read
  std::vector<FolderPoseEvaluation> per_person;  ///< each person's meshes, the model trained on the others
  std::vector<FolderMethodErrors> methods;       ///< every person's meshes pooled
  std::vector<FolderTypeErrors> by_pose_type;
  ErrorStats joint_spread;  ///< as FolderPoseEvaluation's, pooled
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
