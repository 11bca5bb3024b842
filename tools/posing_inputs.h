#pragma once
// What the posing commands read (pose, fit, batch pose): the subject, and how it is set up.
#include <iosfwd>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/fitting/body_model.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::cli {

/// The pose model a posing command poses with (--model FILE.pkm). A model of an older posekit has no
/// per-triangle training residuals: Eq. 6 then weighs by area alone, as the paper does, and the
/// user is told so on stderr (retraining gives the residual weights).
std::shared_ptr<const PoseModel> read_posing_model(const std::string& path, const std::string& command);

/// The subject of pose or fit (--subject, --unit, --up, --forward): read, turned into posekit's
/// frame, and checked to be one closed body.
TriangleMesh read_posing_subject(const ArgParser& args, const std::string& command, BodyOrientation* orientation, BodyUnit* unit);

/// With --body-model, the subject's parts and joints from the body model's fit; else computed by set-up.
SubjectSetupOptions subject_setup(const ArgParser& args, const TriangleMesh& subject);

/// The options of training on a registered dataset or folder, shared by train and eval pose:
/// --poses, --rest, --unit, --joint-offsets, --smooth, --up/--forward, --body-model/--accept-poor.
void add_dataset_training_options(ArgParser* args);
/// Their values; a --body-model is loaded into `body_model`, which must outlive the options.
DatasetTrainingOptions dataset_training_options(const ArgParser& args, std::unique_ptr<BodyModel>* body_model);
/// What a user needs to hear about the template and the estimated poses, on stderr.
void report_pose_estimation(const DatasetTrainingReport& r, std::ostream& err, const std::string& command);
/// --joint-offsets and --smooth.
TrainingOptions training_options(const ArgParser& args);

/// A pose fit's summary for --json (fit, eval fit).
nlohmann::ordered_json fit_summary_json(const PoseFitResult& result);

}  // namespace posekit::cli
