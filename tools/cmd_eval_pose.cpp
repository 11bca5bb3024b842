// posekit eval: the learned pose model against held-out poses of the dataset.
#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <sstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <numeric>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/datasets/dataset.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/fitting/body_model.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/deformation/segmentation_calibration.h"
#include "posekit/population/survey_fit.h"
#include "posekit/registration/shape_space.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/io/bvh.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/point_grid.h"
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

nlohmann::ordered_json stats_json(const ErrorStats& s) {
  return {{"mean_mm", s.mean_mm}, {"p95_mm", s.p95_mm}, {"max_mm", s.max_mm}, {"vertices", s.count}};
}

}  // namespace

int run_eval(int argc, char** argv) {
  if (argc >= 1 && std::string(argv[0]) == "bodies") return run_eval_bodies(argc - 1, argv + 1);
  if (argc >= 1 && std::string(argv[0]) == "fit") return run_eval_fit(argc - 1, argv + 1);
  if (argc < 1 || std::string(argv[0]) != "pose") {
    std::cout << "usage: posekit eval pose --dataset DIR [--model FILE] [--json]\n"
                 "       posekit eval bodies --dataset DIR [--model FILE] [--json]\n"
                 "       posekit eval fit --dataset DIR --model FILE [--subjects N] [--json]\n\n"
                 "  pose     pose accuracy on a posekit dataset's held-out poses and subjects\n"
                 "  bodies   body understanding on a robustness set (posekit dataset make --robustness)\n"
                 "  fit      posekit fit on the dataset's scans of posed subjects, against their true poses\n";
    return argc >= 1 && (std::string(argv[0]) == "--help" || std::string(argv[0]) == "-h") ? 0 : 2;
  }
  ArgParser args("eval pose",
                 "Pose accuracy against ground truth: (a) the template in the held-out poses of the pose dataset,\n"
                 "(b) each customized subject in its ground-truth posed meshes; per method (learned = the paper's\n"
                 "T^R T^Q, rigid = parts only, lbs = 16-part skinning) mean, 95th percentile and max per-vertex\n"
                 "error in mm, overall and per part. Also segmentation agreement and joint error per subject.");
  args.option("dataset", "DIR", "a posekit dataset")
      .option("model", "FILE", "trained model (default: train on the dataset's training split first)")
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc - 1, argv + 1)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  const std::string dir = args.get("dataset");
  Stopwatch t0;
  std::shared_ptr<const PoseModel> model;
  if (args.has("model")) {
    model = std::make_shared<const PoseModel>(read_pose_model(args.get("model")));
  } else {
    PoseModel trained = train_on_dataset(dir);
    const PriorReport prior = add_segmentation_prior(&trained);
    if (!prior.not_made.empty()) std::cerr << "posekit eval: segmentation prior is the template alone: " << prior.not_made << "\n";
    model = std::make_shared<const PoseModel>(std::move(trained));
  }
  const double train_seconds = t0.seconds();
  PoseEvaluationOptions o;
  std::unique_ptr<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress = std::make_unique<Progress>("eval pose", total);
    progress->update(done);
  };
  const PoseEvaluation ev = evaluate_poses(dir, model, o);
  if (progress) progress->finish();
  auto methods_json = [](const std::vector<MethodErrors>& ms) {
    nlohmann::ordered_json a = nlohmann::ordered_json::array();
    for (const auto& m : ms) {
      nlohmann::ordered_json parts;
      for (int p = 0; p < kNumParts; ++p) parts[part_name(p)] = stats_json(m.per_part[static_cast<size_t>(p)]);
      a.push_back({{"method", pose_method_name(m.method)}, {"all", stats_json(m.all)}, {"per_part", parts}});
    }
    return a;
  };
  nlohmann::ordered_json subjects = nlohmann::ordered_json::array();
  for (const auto& s : ev.subjects)
    subjects.push_back({{"id", s.id}, {"setup_seconds", s.setup_seconds}, {"segmentation_agreement", s.segmentation_agreement},
                        {"joint_error_mean_mm", s.joint_error_mean_mm}, {"joint_error_max_mm", s.joint_error_max_mm},
                        {"methods", methods_json(s.methods)}});
  nlohmann::ordered_json types = nlohmann::ordered_json::array();
  for (const auto& t : ev.by_pose_type) {
    if (!t.template_poses && !t.subject_meshes) continue;
    nlohmann::ordered_json tj = {{"type", t.type}, {"template_poses", t.template_poses}, {"subject_meshes", t.subject_meshes}};
    for (size_t m = 0; m < ev.template_errors.size() || m < ev.subject_errors.size(); ++m) {
      const PoseMethod method = m < ev.template_errors.size() ? ev.template_errors[m].method : ev.subject_errors[m].method;
      tj["template_mean_mm"][pose_method_name(method)] = t.template_mean_mm[m];
      tj["subject_mean_mm"][pose_method_name(method)] = t.subject_mean_mm[m];
    }
    types.push_back(tj);
  }
  nlohmann::ordered_json out = {{"dataset", dir}, {"units", "mm"}, {"model_seconds", train_seconds},
                                {"template_test_poses", ev.test_poses}, {"template", methods_json(ev.template_errors)},
                                {"subjects_pooled", methods_json(ev.subject_errors)}, {"subjects", subjects},
                                {"by_pose_type", types},
                                {"pose_ms_median", ev.pose_ms_median}, {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(2);
  auto table = [](const std::vector<MethodErrors>& ms) {
    std::cout << "| method | mean mm | 95th pct mm | max mm |\n|---|---|---|---|\n";
    for (const auto& m : ms)
      std::cout << "| " << pose_method_name(m.method) << " | " << m.all.mean_mm << " | " << m.all.p95_mm << " | "
                << m.all.max_mm << " |\n";
  };
  std::cout << "(a) template, " << ev.test_poses << " held-out poses\n\n";
  table(ev.template_errors);
  std::cout << "\n(b) " << ev.subjects.size() << " customized subjects, their ground-truth posed meshes\n\n";
  table(ev.subject_errors);
  std::cout << "\n| subject | segmentation agreement % | joint error mean / max mm |";
  for (const auto& m : ev.subject_errors) std::cout << " " << pose_method_name(m.method) << " mean mm |";
  std::cout << "\n|---|---|---|";
  for (size_t m = 0; m < ev.subject_errors.size(); ++m) std::cout << "---|";
  std::cout << "\n";
  for (const auto& s : ev.subjects) {
    std::cout << "| " << s.id << " | " << std::setprecision(1) << 100 * s.segmentation_agreement << " | "
              << s.joint_error_mean_mm << " / " << s.joint_error_max_mm << " |";
    for (const auto& m : s.methods) std::cout << " " << std::setprecision(2) << m.all.mean_mm << " |";
    std::cout << "\n";
  }
  const std::vector<MethodErrors>& methods = ev.template_errors.empty() ? ev.subject_errors : ev.template_errors;
  std::cout << "\nmean mm per kind of pose (template poses / subject meshes):\n\n| pose type | poses |";
  for (const auto& m : methods) std::cout << " " << pose_method_name(m.method) << " template | " << pose_method_name(m.method) << " subjects |";
  std::cout << "\n|---|---|";
  for (size_t m = 0; m < methods.size(); ++m) std::cout << "---|---|";
  std::cout << "\n";
  for (const auto& t : ev.by_pose_type) {
    if (!t.template_poses && !t.subject_meshes) continue;
    std::cout << "| " << t.type << " | " << t.template_poses << " / " << t.subject_meshes << " |";
    for (size_t m = 0; m < methods.size(); ++m) {
      auto cell = [](int n, double v) { return n ? [&] { std::ostringstream o; o << std::fixed << std::setprecision(2) << v; return o.str(); }() : std::string("-"); };
      std::cout << " " << cell(t.template_poses, t.template_mean_mm[m]) << " | " << cell(t.subject_meshes, t.subject_mean_mm[m]) << " |";
    }
    std::cout << "\n";
  }
  std::cout << "\nmedian time per pose (learned): " << ev.pose_ms_median << " ms\n";
  return 0;
}

}  // namespace posekit::cli
