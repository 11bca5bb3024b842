// posekit segment: the 16 rigid parts (Eq. 2) and the skeleton of a body, by the rules or by the body model's fit.
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

namespace fs = std::filesystem;

namespace posekit::cli {
namespace {

/// A joint the rule-based segmentation puts this far (m) from the body model's: one of them is wrong.
constexpr double kJointDisagreement = 0.05;

/// The paper's rule-based segmentation (Eq. 2) of a mesh stood upright by the fit, as a cross-check of
/// the body model's joints: warnings naming each joint over kJointDisagreement apart; why it did not
/// run when it cannot (kneeling, arms touching: not its standing pose).
nlohmann::ordered_json rule_based_cross_check(const TriangleMesh& file_mesh, const BodyFit& fit, std::vector<std::string>* warnings) {
  nlohmann::ordered_json out = {{"method", "rule-based (posekit segment without --body-model)"}};
  try {
    TriangleMesh upright = file_mesh;
    upright.V = file_mesh.V * fit.to_fit_frame.transpose();
    upright.N.resize(0, 3);
    const BodyOrientation facing = detect_mesh_orientation(upright.V, upright.F);
    upright.V = (upright.V * facing.rotation.transpose()).eval();
    const TriangleMesh surface = body_surface(upright.V, upright.F, nullptr, nullptr);
    const BodyFeatures features = find_body_features(upright.V, upright.F);
    const LayeredRepresentation rep = build_layered_representation(surface.V, surface.F, features);
    const BodySegmentation result = segment_standing_body(surface.V, surface.F, rep, features, nullptr);
    if (!result.check.ok()) return out["ran"] = false, out["why"] = "fails its sanity checks: " + result.check.summary(), out;
    const Eigen::Matrix3d to_file = (facing.rotation * fit.to_fit_frame).transpose();
    out["ran"] = true;
    for (int j = 0; j < kNumJoints; ++j) {
      const Eigen::Vector3d theirs = to_file * result.joints.row(j).transpose();
      const double apart = (theirs - fit.joints.row(j).transpose()).norm();
      out["joints_apart_mm"][joint_name(j)] = 1000 * apart;
      // The rules place the back's two joints at the waist's and chest's sections, the rig at its spine
      // bones' heads: 4-7 cm apart on every body (docs/body-fitting.md); not a disagreement.
      const bool back = joint_name(j) == "lower_back" || joint_name(j) == "upper_back";
      if (!back && apart > kJointDisagreement)
        warnings->push_back("the rule-based segmentation puts the " + joint_name(j) + " " + std::to_string(std::lround(1000 * apart)) +
                            " mm from the body model's: one of the two is wrong there");
    }
  } catch (const InvalidInput& e) {
    out["ran"] = false;
    out["why"] = e.what();
  }
  return out;
}

/// segment --body-model: the body model fitted to the body (any pose, frame, mesh or cloud), its
/// labels and joints read off the fit.
int segment_by_body_model(const ArgParser& args) {
  const std::string path = args.positionals()[0];
  BodyUnit unit;
  const BodyInput input = read_body_input(path, args.get("unit"), "segment", &unit);
  const std::unique_ptr<BodyModel> body_model = load_body_model(args);
  const BodyModel& model = *body_model;
  const BodyFit fit = fit_body_model_to_input(model, input, path, args);
  if (args.has("out")) {
    const Eigen::VectorXd part = fit.target_part.cast<double>();
    if (input.is_cloud) {
      PointCloud labelled = input.cloud;
      labelled.point_scalars["part"] = part;
      write_point_cloud(args.get("out"), labelled, {unit.unit, CloudFormat::kAuto, true, io_warnings()});
    } else {
      TriangleMesh labelled = input.mesh;
      labelled.vertex_scalars["part"] = part;
      write_mesh(args.get("out"), labelled, {unit.unit, MeshFormat::kAuto, true, io_warnings()});
    }
  }
  nlohmann::ordered_json joints;
  for (int j = 0; j < kNumJoints; ++j) joints[joint_name(j)] = {fit.joints(j, 0), fit.joints(j, 1), fit.joints(j, 2)};
  nlohmann::ordered_json pose = nlohmann::ordered_json::parse(part_pose_to_json(fit.pose));
  std::vector<std::string> disagreements;
  const nlohmann::ordered_json cross = input.is_cloud ? nlohmann::ordered_json{{"ran", false}, {"why", "a scan: the rules segment meshes"}}
                                                      : rule_based_cross_check(input.mesh, fit, &disagreements);
  for (const auto& w : disagreements) std::cerr << "warning: " << path << ": " << w << "\n";
  nlohmann::ordered_json summary = {{"mesh", path},
                                    {"method", "body model"},
                                    {"body_model", args.get("body-model")},
                                    {"confident", fit.confident},
                                    {"reasons", fit.reasons},
                                    {"warnings", fit.warnings},
                                    {"start", fit.start},
                                    {"up", {fit.up.x(), fit.up.y(), fit.up.z()}},
                                    {"coverage", fit.coverage},
                                    {"target_mean_mm", 1000 * fit.target_mean},
                                    {"target_p95_mm", 1000 * fit.target_p95},
                                    {"shape_mahalanobis", fit.shape_mahalanobis},
                                    {"components", model.components()},
                                    {"working_points", fit.working_points},
                                    {"seconds", fit.seconds},
                                    {"joints", joints},
                                    {"guessed_joints", joint_names_where(fit.joint_guessed)},
                                    {"pose_fit_frame", pose},
                                    {"cross_check", cross},
                                    {"disagreements", disagreements}};
  for (const auto& [stage, seconds] : fit.stage_seconds) summary["stage_seconds"][stage] = seconds;
  if (args.has("fitted")) {
    // The fitted body (the template's topology: vertex k is the template's vertex k, a correspondence)
    // with each vertex's distance to the target, the residual map.
    TriangleMesh fitted;
    fitted.V = fit.V;
    fitted.F = model.faces();
    const PointGrid target_grid(input.is_cloud ? input.cloud.P : input.mesh.V);
    Eigen::VectorXd residual(fit.V.rows());
    for (Eigen::Index v = 0; v < fit.V.rows(); ++v) {
      double sq = 0;
      target_grid.nearest(fit.V.row(v).transpose(), &sq);
      residual[v] = 1000 * std::sqrt(sq);
    }
    fitted.vertex_scalars["residual_mm"] = residual;
    fitted.vertex_scalars["part"] = model.vertex_parts().cast<double>();
    write_mesh(args.get("fitted"), fitted, {unit.unit, MeshFormat::kAuto, true, io_warnings()});
  }
  if (args.has("joints")) {
    nlohmann::ordered_json jj = {{"units", "m"},
                                 {"frame", "input"},
                                 {"confident", fit.confident},
                                 {"joints", joints},
                                 {"guessed", joint_names_where(fit.joint_guessed)}};
    const std::string text = jj.dump(2) + "\n";
    write_file_atomically(
        args.get("joints"), [&](std::ostream& o) { o << text; }, false);
  }
  if (args.flag_set("json")) {
    print_json(summary);
    return 0;
  }
  std::cout << "fitted the body model to " << path << " in " << std::fixed << std::setprecision(2) << fit.seconds << " s (started from "
            << fit.start << ", up " << fit.up.transpose().format(Eigen::IOFormat(2, 0, " ", " ", "", "", "(", ")"))
            << "): " << std::setprecision(1) << 100 * fit.coverage << "% of the body within 2 cm of the target, 95% of the target within "
            << 1000 * fit.target_p95 << " mm" << (fit.confident ? "" : " (POOR FIT)") << "\n";
  for (int j = 0; j < kNumJoints; ++j)
    std::cout << "  " << std::left << std::setw(16) << joint_name(j) << std::right << std::setprecision(3) << fit.joints(j, 0) << " "
              << fit.joints(j, 1) << " " << fit.joints(j, 2) << " m\n";
  return 0;
}

}  // namespace

int run_segment(int argc, char** argv) {
  ArgParser args("segment",
                 "Segments a standing body mesh into the 16 rigid parts (Eq. 2a-2c) and embeds the 15-joint\n"
                 "skeleton. With --model, the representation's labels and the skeleton come from the model's\n"
                 "segmentation prior: the labelled bodies shaped most like this one (recommended); without, from\n"
                 "the representation's own layer labels and the body's features. Either way the hips are the\n"
                 "femoral heads found from the body's own pelvis, and limb joints follow the body's features.\n"
                 "With --body-model, the body model is fitted instead (any pose: kneeling, sitting, arms close; any\n"
                 "axes; a mesh or a scan) and labels and joints are read off the fit. A poor fit exits with status 3\n"
                 "and writes nothing unless --accept-poor.");
  args.positional("mesh", "body mesh (PLY/OBJ/OFF/STL), or with --body-model also a scan's points")
      .pose_model_option("its segmentation prior labels the representation")
      .option("unit", "U", "unit of the mesh: m, dm, cm, mm, or auto (its largest extent tells)", "auto")
      .output("out", "FILE", "mesh with vertex scalar 'part' (0..15); PLY keeps it for other tools")
      .output("joints", "FILE", "write the joint centres as JSON")
      .output("fitted", "FILE",
              "with --body-model: the fitted body (the template's vertices, in order) with vertex scalars "
              "'residual_mm' (distance to the body given) and 'part'")
      .option("frame", "F", "frame of the joints written and printed: input (the file's axes) or posekit", "input")
      .flag("unchecked", "write the result even when it fails the sanity checks (they become warnings)")
      .flag("json", "summary as JSON on stdout")
      .example("posekit segment out/dataset/subjects/m01/rest.ply --model model.pkm --out m01_parts.ply")
      .example("posekit segment registration_z_up.obj --up +Z --joints joints.json")
      .example("posekit segment kneeling_scan.ply --body-model ansur.pks --out parts.ply --joints joints.json");
  add_body_model_options(&args);
  add_orientation_options(&args);
  if (!args.parse(argc, argv)) return 0;
  if (args.has("body-model")) return segment_by_body_model(args);
  const std::string frame = args.get("frame");
  if (frame != "input" && frame != "posekit") throw UsageError("--frame expects input or posekit, got '" + frame + "'");
  BodyUnit unit;
  BodyInput input = read_body_input(args.positionals()[0], args.get("unit"), "segment", &unit);
  if (input.is_cloud) throw InvalidInput(args.positionals()[0] + ": segment needs a mesh (triangles); this file has only points");
  const Eigen::MatrixXd file_vertices = input.mesh.V;
  const BodyOrientation orientation = orient_body_input(&input, args.get("up"), args.get("forward"), args.positionals()[0], "segment");
  require_usable_mesh(input.mesh, args.positionals()[0]);
  std::string left_out;
  std::vector<int> surface_vertex;  // index in the file of each vertex segmented
  const TriangleMesh mesh = body_surface(input.mesh.V, input.mesh.F, &left_out, &surface_vertex);
  if (!left_out.empty()) std::cerr << "warning: " << args.positionals()[0] << ": " << left_out << " (floating pieces are labelled -1)\n";
  const Stopwatch t0;
  const BodyFeatures features = find_body_features(input.mesh.V, input.mesh.F);  // sees the openings (cut hands, head)
  const LayeredRepresentation rep = build_layered_representation(mesh.V, mesh.F, features);
  SegmentationPrior prior;
  if (args.has("model")) prior = segmentation_prior_of(read_pose_model(args.get("model")));
  BodySegmentation result = segment_standing_body(mesh.V, mesh.F, rep, features, args.has("model") ? &prior : nullptr);
  for (const auto& r : result.notes) std::cerr << "note: " << args.positionals()[0] << ": " << r << "\n";
  const Segmentation& seg = result.segmentation;
  Eigen::MatrixXd& joints = result.joints;
  const double seconds = t0.seconds();
  // Left is left, parts whole and in proportion, joints at their borders: never a wrong skeleton silently.
  const SkeletonCheck& check = result.check;
  if (!check.ok()) {
    if (!args.flag_set("unchecked"))
      throw InvalidInput(args.positionals()[0] + ": the segmentation fails its sanity checks: " + check.summary() +
                         "; nothing written (--unchecked writes it anyway)");
    for (const auto& p : check.problems) std::cerr << "warning: " << args.positionals()[0] << ": " << p << "\n";
  }
  if (args.has("out")) {
    TriangleMesh labelled = input.mesh;  // in the file's own frame and unit, every face and vertex
    labelled.V = file_vertices;
    if (labelled.has_normals()) labelled.N = in_file_frame(orientation, input.mesh.N);
    Eigen::VectorXd part = Eigen::VectorXd::Constant(labelled.V.rows(), -1.0);
    for (size_t v = 0; v < surface_vertex.size(); ++v)
      if (surface_vertex[v] >= 0) part[surface_vertex[v]] = seg.vertex_part[static_cast<Eigen::Index>(v)];
    labelled.vertex_scalars["part"] = part;
    write_mesh(args.get("out"), labelled, {unit.unit, MeshFormat::kAuto, true, io_warnings()});
  }
  if (frame == "input") joints = in_file_frame(orientation, joints);
  nlohmann::ordered_json jj;
  jj["units"] = "m";
  jj["frame"] = frame;
  jj["orientation"] = orientation_json(orientation);
  for (int j = 0; j < kNumJoints; ++j) jj["joints"][joint_name(j)] = {joints(j, 0), joints(j, 1), joints(j, 2)};
  if (args.has("joints")) {
    const std::string text = jj.dump(2) + "\n";
    write_file_atomically(
        args.get("joints"), [&](std::ostream& o) { o << text; }, false);
  }
  const Eigen::VectorXd area = face_areas(mesh.V, mesh.F);
  nlohmann::ordered_json parts;
  int present = 0;
  for (int p = 0; p < kNumParts; ++p) {
    double a = 0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
      if (seg.triangle_part[f] == p) a += area[f];
    parts[part_name(p)] = {{"area_m2", a}};
    present += a > 0;
  }
  nlohmann::ordered_json s = {{"mesh", args.positionals()[0]},
                              {"seconds", seconds},
                              {"notes", result.notes},
                              {"normal_failures", seg.normal_failures},
                              {"relabelled_by_cleanup", seg.relabelled},
                              {"parts", parts},
                              {"joints", jj["joints"]},
                              {"checks", {{"ok", check.ok()}, {"problems", check.problems}}}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "segmented " << args.positionals()[0] << " into " << present << " parts (of " << kNumParts << ") in " << std::fixed
            << std::setprecision(3) << seconds << " s (" << seg.normal_failures
            << " triangles without a representation triangle facing the same way, " << seg.relabelled << " moved by the clean-up)\n";
  for (int j = 0; j < kNumJoints; ++j)
    std::cout << "  " << std::left << std::setw(16) << joint_name(j) << std::right << std::setprecision(3) << joints(j, 0) << " "
              << joints(j, 1) << " " << joints(j, 2) << " m\n";
  return 0;
}

}  // namespace posekit::cli
