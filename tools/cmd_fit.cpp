// posekit fit and eval fit: the 16-part pose of a target mesh fitted from a subject.
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

/// fit --registered: the pose of the subject's own mesh in another pose, from its vertices.
int fit_registered(const ArgParser& args, const PoseSynthesizer& synth, const TriangleMesh& subject, const BodyOrientation& orientation,
                   const BodyUnit& unit) {
  const Stopwatch clock;
  const std::string path = args.get("target");
  TriangleMesh target = read_mesh(path);
  if (target.V.rows() != subject.V.rows() || target.F.rows() != subject.F.rows() || target.F != subject.F)
    throw InvalidInput(path + ": --registered needs the subject's topology (" + std::to_string(subject.V.rows()) + " vertices, " +
                       std::to_string(subject.F.rows()) + " triangles, in the same order); it has " + std::to_string(target.V.rows()) +
                       " vertices and " + std::to_string(target.F.rows()) + " triangles" +
                       (target.V.rows() == subject.V.rows() ? " in another order" : ""));
  // The subject's file axes and unit apply to its registered copy too.
  target.V *= metres_per_unit(unit.unit);
  if (!orientation.is_identity()) target.V = (target.V * orientation.rotation.transpose()).eval();
  const PartPoseEstimator estimator(synth.rest_vertices(), synth.faces(), synth.info().triangle_part, synth.info().joint_centres);
  const PartPoseEstimate e = estimator.estimate(target.V);
  const PoseMethod method = parse_pose_method(args.get("method"));
  const Eigen::MatrixXd X = synth.pose(e.pose, method);
  const Eigen::VectorXd error = (X - target.V).rowwise().norm();
  const double seconds = clock.seconds();
  const std::vector<std::string> problems = pose_estimate_problems(e);
  for (const auto& p : problems) std::cerr << "warning: " << path << ": " << p << "\n";
  if (args.has("pose-out")) write_part_pose(args.get("pose-out"), e.pose);
  if (args.has("out")) {
    TriangleMesh fitted = subject;
    fitted.V = X * orientation.rotation / metres_per_unit(unit.unit);  // the subject's file axes and unit
    fitted.N.resize(0, 3);
    fitted.vertex_scalars["residual_mm"] = 1000 * error;
    fitted.vertex_scalars["part"] = synth.vertex_parts().cast<double>();
    write_mesh(args.get("out"), fitted);
  }
  std::vector<double> errors(error.data(), error.data() + error.size());
  const ErrorStats stats = error_stats(errors);
  nlohmann::ordered_json parts = nlohmann::ordered_json::object();
  for (int p = 0; p < kNumParts; ++p) parts[part_name(p)] = 1000 * e.core_rms[static_cast<size_t>(p)];
  if (args.flag_set("json")) {
    print_json({{"registered", true},
                {"seconds", seconds},
                {"method", pose_method_name(method)},
                {"rigid_parts_rms_mm", 1000 * e.rms},
                {"part_core_rms_mm", parts},
                {"worst_part", part_name(e.worst_part)},
                {"posed_to_target_mm", {{"mean", stats.mean_mm}, {"p95", stats.p95_mm}, {"max", stats.max_mm}}},
                {"warnings", problems},
                {"pose", nlohmann::json::parse(part_pose_to_json(e.pose))}});
    return 0;
  }
  std::cout << std::fixed << std::setprecision(1) << "pose from the registered vertices in " << std::setprecision(3) << seconds
            << " s: rigid parts explain the target to " << std::setprecision(1) << 1000 * e.rms << " mm RMS (worst part "
            << part_name(e.worst_part) << ", " << 1000 * e.core_rms[static_cast<size_t>(e.worst_part)]
            << " mm away from its joints); posed by " << pose_method_name(method) << ": " << stats.mean_mm << " mm mean, " << stats.p95_mm
            << " mm 95th percentile from the target\n";
  for (int j = 0; j < kNumJoints; ++j) {
    const Eigen::Vector3d& v = e.pose.joint(j);
    if (v.norm() > 5 * M_PI / 180)
      std::cout << "  " << joint_name(j) << ": " << std::setprecision(0) << v.norm() * 180 / M_PI << " degrees\n";
  }
  return 0;
}

}  // namespace

nlohmann::ordered_json fit_summary_json(const PoseFitResult& r) {
  return {{"iterations", r.iterations},
          {"seconds", r.seconds},
          {"target_to_body_mm", {{"mean", 1000 * r.target_mean}, {"p95", 1000 * r.target_p95}}},
          {"coverage_1cm", r.coverage},
          {"guessed_joints", joint_names_where(r.joint_guessed)},
          {"warnings", r.warnings}};
}

int run_fit(int argc, char** argv) {
  ArgParser args("fit",
                 "Finds the 16-part pose (and the global rotation and translation) that makes a body match a\n"
                 "target: a scan with holes, noise and outliers, or a mesh of another topology. No markers: the\n"
                 "target's vertical is detected; the rest pose on its feet at four headings, then six whole-body\n"
                 "starts (arms forward or up, half squat, sitting, a stride either way) are refined briefly and the\n"
                 "best fully by articulated ICP with the posing method in the loop (learned by default),\n"
                 "correspondences both ways, Cauchy weights, a weak rest prior (in the final refinement at 0.3 of its\n"
                 "weight, on each joint's swing, its twist about the bone weighted 0.1: the data decides the twist),\n"
                 "elbows and knees kept on their hinge, and the joints' ranges of motion as priors. A part the target\n"
                 "does not show (hands cut off) has its joint held at rest, with a warning. Writes the pose, the\n"
                 "fitted body with its per-vertex distance to the target (PLY scalar 'residual_mm') and a summary.\n"
                 "--start skips the search (e.g. the previous frame's pose). With --body-model, the subject's parts and\n"
                 "joints come from the body model fitted to it (any rest pose, arms close); a poor fit exits with status 3.");
  args.pose_model_option()
      .option("subject", "FILE", "the body to pose, standing at rest (PLY/OBJ/OFF/STL)")
      .option("target", "FILE", "scan (PCD/PLY/XYZ) or mesh to match, upright")
      .option("unit", "U", "unit of the subject: m, dm, cm, mm or auto", "auto")
      .option("target-unit", "U", "unit of the target: m, dm, cm, mm or auto", "auto")
      .option("method", "NAME", "posing inside the loop: learned, lbs or rigid", "learned")
      .output("out", "FILE", "the fitted body in the target's axes, in metres (PLY with 'residual_mm' and 'part')")
      .output("pose-out", "FILE", "the fitted 16-part pose (JSON; root rotation and translation in the subject's frame, Y up)")
      .option("iterations", "N", "Levenberg-Marquardt steps of the final refinement at most", "100")
      .option("start", "FILE", "start from this 16-part pose (e.g. the previous frame's --pose-out) instead of searching")
      .flag("json", "summary as JSON on stdout")
      .example(
          "posekit fit --model model.pkm --subject ds/subjects/f01/rest.ply --target ds/scans/f01/squat_half.pcd "
          "--out fitted.ply --pose-out pose.json");
  args.option("target-up", "AXIS", "the axis the target stands along (+X, -Y, ...) or auto (detected); its heading is fitted", "auto");
  args.flag("registered",
            "the target is the subject's own mesh posed (same vertices and triangles, same axes and unit):\n"
            "its pose comes from the known correspondences (each part's weighted Procrustes fit, then\n"
            "the parts refined together so that parent and child meet at every joint), no search");
  add_body_model_options(&args);
  add_orientation_options(&args, "", "the subject");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"model", "subject", "target"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  const auto model = read_posing_model(args.get("model"), "fit");
  BodyOrientation orientation;
  BodyUnit unit;
  const TriangleMesh subject = read_posing_subject(args, "fit", &orientation, &unit);
  if (args.flag_set("registered"))
    return fit_registered(args, set_up_subject(model, subject, args.get("subject"), subject_setup(args, subject)), subject, orientation,
                          unit);
  BodyUnit target_unit;
  BodyInput target_input = read_body_input(args.get("target"), args.get("target-unit"), "fit", &target_unit);
  Eigen::MatrixXd T = target_input.is_cloud ? target_input.cloud.P : target_input.mesh.V;
  Eigen::Matrix3d target_to_fit = Eigen::Matrix3d::Identity();  // p_fit = target_to_fit * p_target
  {
    // Only the vertical matters: the fit finds the heading itself (a twisted or walking body fools
    // the shape-based forward).
    Eigen::Vector3d up;
    if (args.get("target-up") != "auto") {
      up = parse_axis(args.get("target-up"));
    } else {
      up = (target_input.is_cloud ? detect_body_orientation(T) : detect_mesh_orientation(T, target_input.mesh.F)).up();
    }
    target_to_fit = Eigen::Quaterniond::FromTwoVectors(up.normalized(), Eigen::Vector3d::UnitY()).toRotationMatrix();
    const Eigen::Matrix3d& R = target_to_fit;
    if (!R.isIdentity(1e-12)) {
      T = (T * R.transpose()).eval();
      std::cerr << "posekit fit: " << args.get("target") << ": up " << axis_name(up) << ", turned to +Y\n";
    }
  }
  const PoseSynthesizer synth = set_up_subject(model, subject, args.get("subject"), subject_setup(args, subject));
  PoseFitOptions o;
  o.method = parse_pose_method(args.get("method"));
  o.iterations = static_cast<int>(args.get_int("iterations"));
  if (o.iterations < 1) throw UsageError("--iterations must be at least 1");
  if (args.has("start")) o.start = read_part_pose(args.get("start"));
  const PoseFitResult r = fit_pose(synth, T, o);
  for (const auto& w : r.warnings) std::cerr << "warning: " << args.get("target") << ": " << w << "\n";
  if (args.has("pose-out")) write_part_pose(args.get("pose-out"), r.pose);
  if (args.has("out")) {
    TriangleMesh fitted = subject;
    fitted.V = r.V * target_to_fit;  // back in the target's axes and unit, to overlay the scan
    fitted.N.resize(0, 3);
    fitted.vertex_scalars["residual_mm"] = 1000 * r.residual;
    fitted.vertex_scalars["part"] = synth.vertex_parts().cast<double>();
    write_mesh(args.get("out"), fitted, {target_unit.unit, MeshFormat::kAuto, true, io_warnings()});
  }
  nlohmann::ordered_json s = fit_summary_json(r);
  s["pose"] = nlohmann::json::parse(part_pose_to_json(r.pose));
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(1) << "fitted in " << r.iterations << " iterations, " << std::setprecision(2) << r.seconds
            << " s: target to body mean " << std::setprecision(1) << 1000 * r.target_mean << " mm, 95th percentile " << 1000 * r.target_p95
            << " mm; " << 100 * r.coverage << "% of the body within 1 cm of the target\n";
  for (int j = 0; j < kNumJoints; ++j) {
    const Eigen::Vector3d& v = r.pose.joint(j);
    if (v.norm() > 5 * M_PI / 180)
      std::cout << "  " << joint_name(j) << ": " << std::setprecision(0) << v.norm() * 180 / M_PI << " degrees\n";
  }
  return 0;
}

}  // namespace posekit::cli
