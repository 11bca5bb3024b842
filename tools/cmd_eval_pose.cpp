// posekit eval: the learned pose model against held-out poses of the dataset.
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
#include <tuple>

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

/// `counted`: what the statistics are over ("vertices"; "joints" for meshes x joints).
nlohmann::ordered_json stats_json(const ErrorStats& s, const char* counted = "vertices") {
  return {{"mean_mm", s.mean_mm}, {"p95_mm", s.p95_mm}, {"max_mm", s.max_mm}, {counted, s.count}};
}

std::vector<std::string> split_names(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream in(list);
  std::string name;
  while (std::getline(in, name, ','))
    if (!name.empty()) out.push_back(name);
  if (out.empty()) throw UsageError("--held-out expects names separated by commas, got '" + list + "'");
  return out;
}

nlohmann::ordered_json parts_json(const std::array<ErrorStats, kNumParts>& a) {
  nlohmann::ordered_json j;
  for (int p = 0; p < kNumParts; ++p) j[part_name(p)] = stats_json(a[static_cast<size_t>(p)]);
  return j;
}

nlohmann::ordered_json joints_json(const std::array<ErrorStats, kNumJoints>& a) {
  nlohmann::ordered_json j;
  for (int k = 0; k < kNumJoints; ++k) j[joint_name(k)] = stats_json(a[static_cast<size_t>(k)], "meshes");
  return j;
}

nlohmann::ordered_json per_method_json(const std::vector<FolderMethodErrors>& methods, const std::vector<double>& v) {
  nlohmann::ordered_json j;
  for (size_t m = 0; m < methods.size(); ++m) j[pose_method_name(methods[m].method)] = v[m];
  return j;
}

/// Methods (with per part), meshes and kinds of pose of a folder evaluation, as JSON fields.
void add_folder_json(const std::vector<FolderMethodErrors>& methods, const std::vector<FolderTypeErrors>& by_type,
                     const ErrorStats& joint_spread, const std::vector<FolderMeshErrors>* meshes, nlohmann::ordered_json* out) {
  nlohmann::ordered_json m = nlohmann::ordered_json::array(), t = nlohmann::ordered_json::array();
  for (const auto& e : methods)
    m.push_back({{"method", pose_method_name(e.method)},
                 {"raw", stats_json(e.raw)},
                 {"shape", stats_json(e.shape)},
                 {"raw_per_part", parts_json(e.raw_per_part)},
                 {"shape_per_part", parts_json(e.shape_per_part)},
                 {"joints_from_given_pose", stats_json(e.joints, "joints")},
                 {"joints_from_given_pose_per_joint", joints_json(e.joints_per_joint)}});
  for (const auto& e : by_type)
    t.push_back({{"type", e.type},
                 {"meshes", e.meshes},
                 {"raw_mean_mm", per_method_json(methods, e.raw_mean_mm)},
                 {"shape_mean_mm", per_method_json(methods, e.shape_mean_mm)}});
  (*out)["methods"] = m;
  (*out)["by_pose_type"] = t;
  (*out)["joint_spread"] = stats_json(joint_spread, "joints");
  if (!meshes) return;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (const auto& e : *meshes)
    rows.push_back({{"name", e.name},
                    {"type", e.type},
                    {"pose_fit_rms_mm", e.pose_fit_rms_mm},
                    {"raw_mean_mm", per_method_json(methods, e.raw_mean_mm)},
                    {"shape_mean_mm", per_method_json(methods, e.shape_mean_mm)},
                    {"joint_spread_max_mm", e.joint_spread_max_mm},
                    {"problems", e.problems}});
  (*out)["meshes"] = rows;
}

/// The tables of a folder evaluation: methods, parts, kinds of pose, then one row per `rows` entry.
void print_folder_tables(const std::vector<FolderMethodErrors>& methods, const std::vector<FolderTypeErrors>& by_type,
                         const ErrorStats& joint_spread, const std::string& row_head,
                         const std::vector<std::tuple<std::string, const std::vector<double>*, const std::vector<double>*>>& rows) {
  std::cout
      << std::fixed << std::setprecision(2)
      << "raw: per-vertex error; shape: after each part is rigidly aligned onto the held-out mesh (raw - shape: placement);\n"
         "joints: where the posed body puts them (its pose estimated back) against the given pose's T^R\n\n"
         "| method | raw mean mm | raw 95th pct | shape mean mm | shape 95th pct | joints mean / max mm |\n|---|---|---|---|---|---|\n";
  for (const auto& m : methods)
    std::cout << "| " << pose_method_name(m.method) << " | " << m.raw.mean_mm << " | " << m.raw.p95_mm << " | " << m.shape.mean_mm << " | "
              << m.shape.p95_mm << " | " << m.joints.mean_mm << " / " << m.joints.max_mm << " |\n";
  std::cout << "\nthe methods' joints, per mesh and joint, at most " << joint_spread.max_mm << " mm apart (mean " << joint_spread.mean_mm
            << ", 95th pct " << joint_spread.p95_mm << ")\n";
  auto head = [&](const std::string& first, const char* columns = "raw / shape") {
    std::cout << "\n| " << first << " |";
    for (const auto& m : methods) std::cout << " " << pose_method_name(m.method) << " " << columns << " |";
    std::cout << "\n|---|";
    for (size_t m = 0; m < methods.size(); ++m) std::cout << "---|";
    std::cout << "\n";
  };
  head("part (mean mm)");
  for (int p = 0; p < kNumParts; ++p) {
    std::cout << "| " << part_name(p) << " |";
    for (const auto& m : methods)
      std::cout << " " << m.raw_per_part[static_cast<size_t>(p)].mean_mm << " / " << m.shape_per_part[static_cast<size_t>(p)].mean_mm
                << " |";
    std::cout << "\n";
  }
  head("joint (mm from the given pose's)", "mean / max");
  for (int j = 0; j < kNumJoints; ++j) {
    std::cout << "| " << joint_name(j) << " |";
    for (const auto& m : methods)
      std::cout << " " << m.joints_per_joint[static_cast<size_t>(j)].mean_mm << " / " << m.joints_per_joint[static_cast<size_t>(j)].max_mm
                << " |";
    std::cout << "\n";
  }
  head("kind of pose (meshes)");
  for (const auto& t : by_type) {
    std::cout << "| " << t.type << " (" << t.meshes << ") |";
    for (size_t m = 0; m < methods.size(); ++m) std::cout << " " << t.raw_mean_mm[m] << " / " << t.shape_mean_mm[m] << " |";
    std::cout << "\n";
  }
  head(row_head);
  for (const auto& [name, raw, shape] : rows) {
    std::cout << "| " << name << " |";
    for (size_t m = 0; m < methods.size(); ++m) std::cout << " " << (*raw)[m] << " / " << (*shape)[m] << " |";
    std::cout << "\n";
  }
}

/// eval pose --held-out / --every: a folder of registered meshes of one person; --people: a folder
/// of such folders, one per person (issue 45 part 3).
int eval_registered_folder(const ArgParser& args) {
  if (args.has("model")) throw UsageError("--held-out, --every and --people train on the folder; --model cannot be given with them");
  const std::string dir = args.get("dataset");
  std::unique_ptr<BodyModel> body_model;
  DatasetTrainingOptions dto = dataset_training_options(args, &body_model);
  if (args.has("held-out")) dto.held_out = split_names(args.get("held-out"));
  if (args.has("every")) {
    const long every = args.get_int("every");
    if (every < 2) throw UsageError("--every expects N >= 2 (every N-th example held out), got " + args.get("every"));
    dto.hold_out_every = static_cast<int>(every);
  }
  const bool people = args.flag_set("people");
  if (int(!dto.held_out.empty()) + int(dto.hold_out_every > 0) + int(people) > 1)
    throw UsageError("--held-out, --every and --people each choose the split: give one");
  TrainingOptions o = training_options(args);
  nlohmann::ordered_json out = {{"dataset", dir}, {"units", "mm"}};
  if (people) {
    std::unique_ptr<Progress> progress;
    const PeoplePoseEvaluation ev = evaluate_registered_people(dir, o, dto, {PoseMethod::kLearned, PoseMethod::kRigid, PoseMethod::kLbs},
                                                               [&](int done, int total, const std::string&) {
                                                                 if (!progress) progress = std::make_unique<Progress>("eval pose", total);
                                                                 progress->update(done);
                                                               });
    if (progress) progress->finish();
    for (size_t p = 0; p < ev.people.size(); ++p) report_pose_estimation(ev.reports[p], std::cerr, "eval pose: " + ev.people[p]);
    out["people"] = ev.people.size();
    add_folder_json(ev.methods, ev.by_pose_type, ev.joint_spread, nullptr, &out);
    nlohmann::ordered_json persons = nlohmann::ordered_json::array();
    for (size_t p = 0; p < ev.people.size(); ++p) {
      const FolderPoseEvaluation& e = ev.per_person[p];
      nlohmann::ordered_json j = {{"person", ev.people[p]},
                                  {"rest", ev.reports[p].rest_name},
                                  {"trained_on_others_poses", e.training_poses},
                                  {"train_seconds", e.train_seconds}};
      add_folder_json(e.methods, e.by_pose_type, e.joint_spread, &e.meshes, &j);
      persons.push_back(j);
    }
    out["per_person"] = persons;
    out["peak_rss_mib"] = peak_rss_mib();
    if (args.flag_set("json")) {
      print_json(out);
      return 0;
    }
    std::cout << ev.people.size()
              << " people of one topology; each person's rest mesh posed, by a model trained on the others,\n"
                 "at each of their other meshes' poses estimated from its vertices\n";
    std::vector<std::vector<double>> raw(ev.people.size()), shape(ev.people.size());
    std::vector<std::tuple<std::string, const std::vector<double>*, const std::vector<double>*>> rows;
    for (size_t p = 0; p < ev.people.size(); ++p) {
      for (const auto& m : ev.per_person[p].methods) raw[p].push_back(m.raw.mean_mm), shape[p].push_back(m.shape.mean_mm);
      rows.emplace_back(ev.people[p] + " (" + std::to_string(ev.per_person[p].meshes.size()) + ")", &raw[p], &shape[p]);
    }
    print_folder_tables(ev.methods, ev.by_pose_type, ev.joint_spread, "person (meshes)", rows);
    return 0;
  }
  Progress progress("eval pose: train", 100);
  o.progress = [&](int done, int total) { progress.update(100L * done / std::max(total, 1)); };
  const FolderPoseEvaluation ev = evaluate_registered_folder(dir, o, dto);
  progress.finish();
  report_pose_estimation(ev.training, std::cerr, "eval pose");
  for (const auto& m : ev.meshes)
    for (const auto& problem : m.problems) std::cerr << "warning: held-out '" << m.name << "': " << problem << "\n";
  out["rest"] = ev.training.rest_name;
  out["training_poses"] = ev.training_poses;
  out["held_out"] = ev.meshes.size();
  out["train_seconds"] = ev.train_seconds;
  out["poses_estimated_for_training"] = ev.training.poses_estimated;
  add_folder_json(ev.methods, ev.by_pose_type, ev.joint_spread, &ev.meshes, &out);
  out["warnings"] = ev.training.warnings;
  out["peak_rss_mib"] = peak_rss_mib();
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(2) << "rest '" << ev.training.rest_name << "', trained on " << ev.training_poses
            << " poses in " << ev.train_seconds << " s; " << ev.meshes.size()
            << (ev.meshes.size() == 1 ? " held-out mesh" : " held-out meshes") << ", each posed at its pose estimated from its vertices\n";
  std::vector<std::tuple<std::string, const std::vector<double>*, const std::vector<double>*>> rows;
  for (const auto& m : ev.meshes) rows.emplace_back(m.name, &m.raw_mean_mm, &m.shape_mean_mm);
  print_folder_tables(ev.methods, ev.by_pose_type, ev.joint_spread, "held-out mesh", rows);
  return 0;
}

}  // namespace

int run_eval(int argc, char** argv) {
  if (argc >= 1 && std::string(argv[0]) == "bodies") return run_eval_bodies(argc - 1, argv + 1);
  if (argc >= 1 && std::string(argv[0]) == "fit") return run_eval_fit(argc - 1, argv + 1);
  if (argc < 1 || std::string(argv[0]) != "pose") {
    std::cout << "usage: posekit eval pose --dataset DIR [--model FILE | --held-out A,B | --every N | --people] [--json]\n"
                 "       posekit eval bodies --dataset DIR [--model FILE] [--json]\n"
                 "       posekit eval fit --dataset DIR --model FILE [--subjects N] [--json]\n\n"
                 "  pose     pose accuracy on a posekit dataset's held-out poses and subjects, or on any folder of\n"
                 "           registered meshes (one person, or --people: one folder per person)\n"
                 "  bodies   body understanding on a robustness set (posekit dataset make --robustness)\n"
                 "  fit      posekit fit on the dataset's scans of posed subjects, against their true poses\n";
    return argc >= 1 && (std::string(argv[0]) == "--help" || std::string(argv[0]) == "-h") ? 0 : 2;
  }
  ArgParser args("eval pose",
                 "Pose accuracy against ground truth: (a) the template in the held-out poses of the pose dataset,\n"
                 "(b) each customized subject in its ground-truth posed meshes; per method (learned = the paper's\n"
                 "T^R T^Q, rigid = parts only, lbs = 16-part skinning) mean, 95th percentile and max per-vertex\n"
                 "error in mm, overall and per part. Also segmentation agreement and joint error per subject.\n"
                 "With --held-out or --every: any folder of registered meshes of one person (SCAPE-style: one topology,\n"
                 "no joint angles needed). Trains on the rest of the folder, estimates each held-out mesh's pose from\n"
                 "its vertices, poses the rest mesh at it with each method and reports the raw error and the shape\n"
                 "error (each part rigidly aligned first), per method, part, kind of pose and mesh, and where each\n"
                 "method puts the joints (its posed body's pose estimated back) against the given pose and each other.");
  args.option("dataset", "DIR", "a posekit dataset, or with --held-out/--every any folder of registered meshes")
      .pose_model_option("default: train on the dataset's training split first")
      .option("held-out", "A,B,...", "these examples are held out (by file name without extension); the rest is trained on")
      .option("every", "N", "every N-th example in name order (the rest example skipped) is held out")
      .flag("people",
            "the folder holds one folder of registered meshes per person, one topology: each person's rest mesh\n"
            "                          posed into their other meshes by a model trained on the other people")
      .flag("json", "results as JSON on stdout")
      .example("posekit eval pose --dataset out/dataset")
      .example("posekit eval pose --dataset scape_meshes/ --rest mesh000 --every 6");
  add_dataset_training_options(&args);
  add_body_model_options(&args);
  if (!args.parse(argc - 1, argv + 1)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  if (args.has("held-out") || args.has("every") || args.flag_set("people")) return eval_registered_folder(args);
  const std::string dir = args.get("dataset");
  Stopwatch t0;
  std::shared_ptr<const PoseModel> model;
  if (args.has("model")) {
    model = read_posing_model(args.get("model"), "eval pose");
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
    subjects.push_back({{"id", s.id},
                        {"setup_seconds", s.setup_seconds},
                        {"segmentation_agreement", s.segmentation_agreement},
                        {"joint_error_mean_mm", s.joint_error_mean_mm},
                        {"joint_error_max_mm", s.joint_error_max_mm},
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
  nlohmann::ordered_json out = {{"dataset", dir},
                                {"units", "mm"},
                                {"model_seconds", train_seconds},
                                {"template_test_poses", ev.test_poses},
                                {"template", methods_json(ev.template_errors)},
                                {"subjects_pooled", methods_json(ev.subject_errors)},
                                {"subjects", subjects},
                                {"by_pose_type", types},
                                {"pose_ms_median", ev.pose_ms_median},
                                {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(2);
  auto table = [](const std::vector<MethodErrors>& ms) {
    std::cout << "| method | mean mm | 95th pct mm | max mm |\n|---|---|---|---|\n";
    for (const auto& m : ms)
      std::cout << "| " << pose_method_name(m.method) << " | " << m.all.mean_mm << " | " << m.all.p95_mm << " | " << m.all.max_mm << " |\n";
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
    std::cout << "| " << s.id << " | " << std::setprecision(1) << 100 * s.segmentation_agreement << " | " << s.joint_error_mean_mm << " / "
              << s.joint_error_max_mm << " |";
    for (const auto& m : s.methods) std::cout << " " << std::setprecision(2) << m.all.mean_mm << " |";
    std::cout << "\n";
  }
  const std::vector<MethodErrors>& methods = ev.template_errors.empty() ? ev.subject_errors : ev.template_errors;
  std::cout << "\nmean mm per kind of pose (template poses / subject meshes):\n\n| pose type | poses |";
  for (const auto& m : methods)
    std::cout << " " << pose_method_name(m.method) << " template | " << pose_method_name(m.method) << " subjects |";
  std::cout << "\n|---|---|";
  for (size_t m = 0; m < methods.size(); ++m) std::cout << "---|---|";
  std::cout << "\n";
  for (const auto& t : ev.by_pose_type) {
    if (!t.template_poses && !t.subject_meshes) continue;
    std::cout << "| " << t.type << " | " << t.template_poses << " / " << t.subject_meshes << " |";
    for (size_t m = 0; m < methods.size(); ++m) {
      auto cell = [](int n, double v) {
        return n ? [&] { std::ostringstream o; o << std::fixed << std::setprecision(2) << v; return o.str(); }() : std::string("-");
      };
      std::cout << " " << cell(t.template_poses, t.template_mean_mm[m]) << " | " << cell(t.subject_meshes, t.subject_mean_mm[m]) << " |";
    }
    std::cout << "\n";
  }
  std::cout << "\nmedian time per pose (learned): " << ev.pose_ms_median << " ms\n";
  return 0;
}

}  // namespace posekit::cli
