// posekit train: the pose model of section 3.3 (Eq. 3-4) learned from a registered pose dataset.
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
#include "posing_inputs.h"

namespace fs = std::filesystem;

namespace posekit::cli {
namespace {

nlohmann::ordered_json fit_report_json(const DatasetTrainingReport& r) {
  nlohmann::ordered_json examples = nlohmann::ordered_json::array();
  for (const auto& e : r.examples) {
    nlohmann::ordered_json x = {{"name", e.name},
                                {"split", e.test       ? "test"
                                          : e.left_out ? "left out"
                                                       : "train"},
                                {"rms_mm", e.rms_mm},
                                {"worst_part", e.worst_part},
                                {"worst_part_rms_mm", e.worst_core_rms_mm}};
    if (e.joint_error_mean_deg >= 0)
      x["against_json"] = {
          {"joint_error_mean_deg", e.joint_error_mean_deg}, {"joint_error_max_deg", e.joint_error_max_deg}, {"worst_joint", e.worst_joint}};
    x["problems"] = e.problems;
    examples.push_back(x);
  }
  return {{"rest", r.rest_name},
          {"rest_reason", r.rest_reason},
          {"unit", r.unit},
          {"orientation", r.orientation},
          {"labels", r.labels_from_dataset      ? "template/parts.json, template/joints.json"
                     : r.labels_from_body_model ? "the body model's fit"
                                                : "segmented (Eq. 2)"},
          {"poses", r.poses_estimated ? "estimated from the meshes" : "pose JSONs"},
          {"examples", examples},
          {"warnings", r.warnings}};
}

/// The joints whose learned offsets training kept.
std::vector<std::string> offsets_kept(const PoseModel& model) {
  std::vector<std::string> kept;
  for (Eigen::Index j = 0; j < model.joint_offsets.rows(); ++j)
    if (!model.joint_offsets.row(j).isZero(0)) kept.push_back(joint_name(static_cast<int>(j)));
  return kept;
}

}  // namespace

int run_train(int argc, char** argv) {
  ArgParser args("train",
                 "Learns the non-rigid pose deformation T^Q (Eq. 3-5): for every template triangle a 9 x 7 linear\n"
                 "model on the twists of the two joints next to its part, from the training split of a registered\n"
                 "pose dataset. Template labels and joints come from the dataset (template/parts.json, joints.json)\n"
                 "or, when absent, from the template's own segmentation (Eq. 2). When the template is the MakeHuman\n"
                 "base mesh, the model also keeps a segmentation prior: random MakeHuman bodies labelled by the rig,\n"
                 "from which a customized body takes the part labels and joints of the bodies shaped most like it.\n"
                 "A folder of registered meshes alone (SCAPE, FAUST, your own 4D captures: one topology, no joint\n"
                 "angles) is learned from too: each example's part rotations T^R(i) are estimated from its vertices\n"
                 "(weighted Procrustes per part, joint zones down-weighted, robust to sliding skin) and the joint\n"
                 "twists follow; pose JSONs, where present, then only check the estimates. With --body-model, the rest\n"
                 "example's parts and joints come from the body model fitted to it (a natural stance, arms close).");
  args.option("dataset", "DIR", "a posekit dataset, or a folder of registered meshes (OBJ/PLY/OFF), with or without .json poses")
      .output("out", "FILE", "model file to write (.pkm)", "model.pkm")
      .output("fit-report", "FILE", "per-example fit of the estimated poses (JSON: residuals, joint errors against given JSONs)")
      .output_folder("poses-out", "DIR",
                     "each example's estimated pose as DIR/<name>.json (posekit's pose JSON, its frame;\n"
                     "                          poses estimated from the meshes: a folder of meshes alone, or --poses estimate)")
      .option("calibration-bodies", "N", "random MakeHuman bodies in the segmentation prior; 0: the template alone (default: 128)")
      .option("calibration-population", "P",
              "the segmentation prior's bodies: makehuman (random sliders) or ansur (MakeHuman\n"
              "                          fitted to ANSUR II subjects drawn at random, women and men alternately: real proportions)\n"
              "                          or both (N of each)",
              "makehuman")
      .option("survey", "DIR|FILE",
              "--calibration-population ansur: ANSUR II's folder or a survey CSV (default: $POSEKIT_ANSUR, "
              "else ansur2 beside the data root)")
      .data_option("for the prior")
      .flag("json", "summary as JSON on stdout")
      .example("posekit train --dataset out/dataset --out model.pkm")
      .example("posekit train --dataset scape_meshes/ --rest mesh000 --fit-report fits.json");
  add_dataset_training_options(&args);
  add_body_model_options(&args, false);
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  std::unique_ptr<BodyModel> body_model;
  const DatasetTrainingOptions dto = dataset_training_options(args, &body_model);
  Progress progress("train", 100);
  TrainingOptions o = training_options(args);
  o.progress = [&](int done, int total) { progress.update(100L * done / std::max(total, 1)); };
  const Stopwatch t0;
  DatasetTrainingReport fits;
  PoseModel model = train_on_dataset(args.get("dataset"), o, dto, &fits);
  const double seconds = t0.seconds();
  progress.finish();
  if (args.has("poses-out") && !fits.poses_estimated)
    throw UsageError("--poses-out: the training poses were the dataset's pose JSONs, nothing was estimated (add --poses estimate)");
  const nlohmann::ordered_json fit_json = fit_report_json(fits);
  report_pose_estimation(fits, std::cerr, "train");
  if (args.has("fit-report"))
    write_file_atomically(
        args.get("fit-report"), [&](std::ostream& f) { f << fit_json.dump(2) << "\n"; }, false);
  if (args.has("poses-out")) {
    const fs::path dir = args.get("poses-out");
    std::error_code ec;
    fs::create_directories(dir, ec);
    if (ec) throw IoError(dir.string() + ": cannot create the folder for --poses-out: " + ec.message());
    for (const ExamplePoseFit& e : fits.examples) write_part_pose((dir / (e.name + ".json")).string(), e.pose);
  }
  const long calibration_bodies = args.has("calibration-bodies") ? args.get_int("calibration-bodies") : 128;
  if (calibration_bodies < 0) throw UsageError("--calibration-bodies must not be negative");
  PriorReport prior;
  if (calibration_bodies > 0) {
    Progress calibration("segmentation prior", calibration_bodies + 1);
    CalibrationOptions co;
    co.bodies = static_cast<int>(calibration_bodies);
    co.progress = [&](int done, int) { calibration.update(done); };
    co.specs = survey_population_specs(args, "calibration-population", static_cast<int>(calibration_bodies), co.seed);
    prior = add_segmentation_prior(&model, args.has("data") ? args.get("data") : "", co);
    calibration.finish();
    if (!prior.not_made.empty()) std::cerr << "posekit train: segmentation prior is the template alone: " << prior.not_made << "\n";
  }
  write_pose_model(args.get("out"), model);
  nlohmann::ordered_json s = {{"model", args.get("out")},
                              {"training_poses", model.training_poses},
                              {"template_vertices", model.template_V.rows()},
                              {"template_triangles", model.template_F.rows()},
                              {"fit_rms", model.fit_rms},
                              {"seconds", seconds},
                              {"calibration_bodies", prior.bodies},
                              {"calibration_skipped", prior.skipped},
                              {"calibration_seconds", prior.seconds},
                              {"rest", fits.rest_name},
                              {"poses", fit_json["poses"]},
                              {"labels", fit_json["labels"]},
                              {"joint_offsets_kept", offsets_kept(model)},
                              {"warnings", fits.warnings},
                              {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "trained on " << model.training_poses << " poses of a " << model.template_V.rows() << "-vertex template in " << std::fixed
            << std::setprecision(2) << seconds << " s (RMS residual of Eq. 5: " << std::setprecision(4) << model.fit_rms << ")";
  if (prior.bodies > 0)
    std::cout << "; segmentation prior of " << prior.bodies << " bodies in " << std::setprecision(2) << prior.seconds << " s"
              << (prior.skipped ? " (" + std::to_string(prior.skipped) + " left out: features not found)" : "");
  if (o.learn_joint_offsets) {
    const auto kept = offsets_kept(model);
    std::cout << "; joint offsets kept for " << kept.size() << " of 15 joints";
    for (size_t k = 0; k < kept.size(); ++k) std::cout << (k ? ", " : " (") << kept[k] << (k + 1 == kept.size() ? ")" : "");
  }
  std::cout << "; peak RSS " << std::setprecision(0) << peak_rss_mib() << " MiB; wrote " << args.get("out") << "\n";
  return 0;
}

}  // namespace posekit::cli
