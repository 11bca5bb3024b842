// What the posing commands read: the subject (pose, fit), the poses (pose, retarget, batch, register) and the subject's set-up.
#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <numeric>
#include <sstream>

#include "posing_inputs.h"

#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/point_grid.h"
#include "posekit/core/timer.h"
#include "posekit/datasets/dataset.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_sequence.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/deformation/segmentation_calibration.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/fitting/body_model.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/population/survey_fit.h"
#include "posekit/registration/shape_space.h"
#include "posekit/segmentation/body_segmentation.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/segmentation_prior.h"
#include "posekit/segmentation/skeleton_checks.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/layered_representation.h"

namespace fs = std::filesystem;

namespace posekit::cli {
namespace {

/// Subject meshes for posing must be closed bodies in one piece: say so before any work.
void check_subject(const TriangleMesh& mesh, const std::string& path) {
  const MeshReport r = validate_mesh(mesh);
  if (r.components != 1)
    throw InvalidInput(path + ": the subject mesh has " + std::to_string(r.components) +
                       " connected components; posing needs one connected body");
  if (r.boundary_loops > 0)
    std::cerr << "posekit: warning: " << path << " has " << r.boundary_loops
              << " holes; segmentation and posing proceed, features near the holes may be off\n";
}

}  // namespace

std::shared_ptr<const PoseModel> read_posing_model(const std::string& path, const std::string& command) {
  auto model = std::make_shared<const PoseModel>(read_pose_model(path));
  if (model->triangle_rms.size() == 0)
    std::cerr << "posekit " << command << ": " << path
              << " holds no per-triangle training residuals (a model of an older posekit): Eq. 6 weighs every triangle by its area"
                 " alone; retrain it (posekit train) for the residual weights\n";
  return model;
}

/// The subject of pose or fit (--subject, --unit, --up, --forward): read, turned into posekit's
/// frame, and checked to be one body.
TriangleMesh read_posing_subject(const ArgParser& args, const std::string& command, BodyOrientation* orientation, BodyUnit* unit) {
  BodyInput input = read_body_input(args.get("subject"), args.get("unit"), command, unit);
  if (input.is_cloud) throw InvalidInput(args.get("subject") + ": the subject must be a mesh (triangles); this file has only points");
  *orientation = orient_body_input(&input, args.get("up"), args.get("forward"), args.get("subject"), command);
  check_subject(input.mesh, args.get("subject"));
  return std::move(input.mesh);
}

LoadedPoses load_poses(const std::string& path, const std::string& frames, const std::string& data_root, const Eigen::MatrixXd& rest_joints,
                       const std::string& joint_map, const std::string& root_motion, const BvhMotion* parsed) {
  PoseSequenceOptions o;
  o.data_root = data_root;
  if (root_motion == "none") o.root_motion = RetargetOptions::RootMotion::kNone;
  else if (root_motion == "all") o.root_motion = RetargetOptions::RootMotion::kAll;
  else if (root_motion != "vertical") throw UsageError("--root-motion expects none, vertical or all, got '" + root_motion + "'");
  if (!joint_map.empty()) o.joint_map = read_bvh_joint_map(joint_map);
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  BvhMotion read;
  if (ext == ".bvh" && !parsed) read = read_bvh(path, Unit::kMetre, io_warnings()), parsed = &read;
  if (parsed && !frames.empty() && parsed->num_frames() > 0) {
    const auto [a, b] = parse_number_pair(frames, ':', "--frames");
    o.first = static_cast<int>(a), o.last = static_cast<int>(b);
    if (o.first < 0 || o.last > parsed->num_frames() || o.first >= o.last)
      throw UsageError("--frames " + frames + " is outside the " + std::to_string(parsed->num_frames()) + " frames of " + path);
  }
  return load_pose_sequence(path, rest_joints, o, parsed);
}

PoseSynthesizer set_up_subject(std::shared_ptr<const PoseModel> model, const TriangleMesh& subject, const std::string& path,
                               const SubjectSetupOptions& options) {
  try {
    return PoseSynthesizer(std::move(model), subject, options);
  } catch (const InvalidInput& e) {
    throw InvalidInput(path + ": cannot be set up for posing: " + e.what() +
                       (options.joint_centres.size()
                            ? std::string()
                            : "; a subject must stand upright in the standard pose, arms away from the body (or give --body-model)"));
  }
}

/// With --body-model, the subject's parts and joints from the body model's fit; else computed by set-up.
SubjectSetupOptions subject_setup(const ArgParser& args, const TriangleMesh& subject) {
  SubjectSetupOptions o;
  if (!args.has("body-model")) return o;
  const std::unique_ptr<BodyModel> body_model = load_body_model(args);
  segment_subject_by_body_model(*body_model, subject, args.get("subject"), args, &o.triangle_part, &o.joint_centres);
  return o;
}

/// What a user needs to hear about the template and the estimated poses, on stderr.
void report_pose_estimation(const DatasetTrainingReport& r, std::ostream& err, const std::string& command) {
  err << "posekit " << command << ": template '" << r.rest_name << "' (" << r.rest_reason << "), unit " << r.unit << ", " << r.orientation
      << "; labels "
      << (r.labels_from_dataset      ? "from the dataset"
          : r.labels_from_body_model ? "from the body model's fit"
                                     : "from its own segmentation (Eq. 2)")
      << "\n";
  if (!r.poses_estimated) return;
  std::vector<double> rms, joint;
  const ExamplePoseFit* worst = nullptr;
  for (const auto& e : r.examples) {
    rms.push_back(e.rms_mm);
    if (e.joint_error_mean_deg >= 0) joint.push_back(e.joint_error_mean_deg);
    if (!worst || e.worst_core_rms_mm > worst->worst_core_rms_mm) worst = &e;
  }
  const Stats s = stats_of(rms);
  err << std::fixed << std::setprecision(1) << "posekit " << command << ": poses of " << r.examples.size()
      << " examples estimated from their meshes: rigid-part residual median " << s.median << " mm, max " << s.max << " mm";
  if (worst) err << "; worst part " << worst->worst_part << " of '" << worst->name << "' " << worst->worst_core_rms_mm << " mm";
  if (!joint.empty()) {
    const Stats j = stats_of(joint);
    err << "; against the " << joint.size() << " given pose JSONs: joint error median " << j.median << ", max " << j.max << " degrees";
  }
  err << "\n";
  const size_t shown = std::min<size_t>(r.warnings.size(), 10);
  for (size_t i = 0; i < shown; ++i) err << "warning: " << r.warnings[i] << "\n";
  if (r.warnings.size() > shown) err << "warning: ... and " << r.warnings.size() - shown << " more (see --fit-report)\n";
}

void add_dataset_training_options(ArgParser* args) {
  args->option("poses", "auto|json|estimate",
               "training poses: the JSONs, estimated from the meshes, or auto (JSONs when every example has one)", "auto")
      .option("rest", "NAME", "the rest-pose example (default: the manifest's, a zero pose, a name with rest/template, else the first)")
      .option("unit", "UNIT", "unit of the meshes: m, dm, cm, mm or auto (from the rest mesh's extent)", "auto")
      .flag("joint-offsets",
            "extension beyond the paper: learn where each joint sits as a function of its twist (a shoulder girdle\n"
            "                          that rises with the arm), kept per joint where it lowers the training error")
      .option("smooth", "N",
              "extension beyond the paper, for noisy meshes: smooth each example's non-rigid deformation over N rounds of neighbouring "
              "triangles before Eq. 5",
              "0");
  add_orientation_options(args, "", "the meshes' body");
}

DatasetTrainingOptions dataset_training_options(const ArgParser& args, std::unique_ptr<BodyModel>* body_model) {
  DatasetTrainingOptions dto;
  try {
    dto.poses = parse_training_poses(args.get("poses"));
  } catch (const InvalidInput&) {
    throw UsageError("--poses expects auto, json or estimate, got '" + args.get("poses") + "'");
  }
  if (args.has("rest")) dto.rest_name = args.get("rest");
  dto.unit = args.get("unit");
  if (dto.unit != "auto") parse_unit(dto.unit);
  dto.up = args.get("up");
  dto.forward = args.get("forward");
  if (args.has("body-model")) {
    BodyFitOptions fit;
    fit.threads = body_fit_threads(args);
    *body_model = load_body_model(args), dto.label_rest = body_model_labeller(**body_model, fit);
  }
  dto.accept_poor_fit = args.flag_set("accept-poor");
  return dto;
}

TrainingOptions training_options(const ArgParser& args) {
  TrainingOptions o;
  o.learn_joint_offsets = args.flag_set("joint-offsets");
  const long smoothing = args.get_int("smooth");
  if (smoothing < 0 || smoothing > 1000) throw UsageError("--smooth expects 0 to 1000 iterations, got " + args.get("smooth"));
  o.smoothing_iterations = static_cast<int>(smoothing);
  return o;
}

}  // namespace posekit::cli
