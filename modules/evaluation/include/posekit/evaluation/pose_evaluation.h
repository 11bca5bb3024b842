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
  bool template_poses = true;    ///< (a) held-out poses of the pose dataset
  bool subjects = true;          ///< (b) posed ground truth of the dataset's subjects
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
  double segmentation_agreement = -1;   ///< area fraction vs ground truth (-1: unknown)
  double joint_error_max_mm = -1, joint_error_mean_mm = -1;  ///< vs the rig's joints (-1: unknown)
  std::vector<MethodErrors> methods;
};

struct PoseEvaluation {
  int test_poses = 0;
  std::vector<MethodErrors> template_errors;     ///< (a)
  std::vector<SubjectPoseReport> subjects;       ///< (b) one per subject
  std::vector<MethodErrors> subject_errors;      ///< (b) all subjects pooled
  double pose_ms_median = 0;                     ///< learned method, one pose of one subject
};

/// Evaluates `model` on a posekit dataset folder. Throws InvalidInput when the model was trained on
/// another template than the dataset's and IoError on unreadable files.
PoseEvaluation evaluate_poses(const std::string& dataset_dir, std::shared_ptr<const PoseModel> model,
                              const PoseEvaluationOptions& options = {});

/// Trains on the dataset's training split with its template labels and joints (template/parts.json,
/// template/joints.json) or, without them, the template's own segmentation and skeleton.
PoseModel train_on_dataset(const std::string& dataset_dir, const TrainingOptions& base = {});

}  // namespace posekit
