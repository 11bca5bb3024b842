// posekit register <source> <target>: ct-FFD or ICP registration and the triangle correspondence;
// posekit shape-space: a shape space file for register --shape-space.
#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/core/units.h"
#include "posekit/datasets/dataset.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/paper/registration_table.h"
#include "posekit/registration/correspondence.h"
#include "posekit/registration/nicp.h"
#include "posekit/registration/registration.h"

namespace posekit::cli {
namespace fs = std::filesystem;

namespace {

/// register --method body-model: the fitted body is the source deformed onto the target (the source
/// in the body model's topology), optionally refined by soft non-rigid ICP; then nearest centroids.
RegistrationResult register_by_body_model(const TriangleMesh& source, const TriangleMesh& target, const RegistrationOptions& o,
                                          const ArgParser& args, Eigen::MatrixXd* fitted) {
  const Stopwatch t0;
  const std::unique_ptr<BodyModel> model = load_body_model(args);
  if (source.V.rows() != model->space().vertices() || source.F != model->faces())
    throw InvalidInput(args.positionals()[0] +
                       ": --method body-model registers a source of the body model's topology (MakeHuman's "
                       "template, " +
                       std::to_string(model->space().vertices()) + " vertices); this one has " + std::to_string(source.V.rows()) +
                       " (use --method ctffd)");
  BodyInput in;
  in.mesh = target;
  const BodyFit fit = fit_body_model_to_input(*model, in, args.positionals()[1], args);
  RegistrationResult r;
  r.deformed_source = *fitted = fit.V;
  if (o.refine) {
    r.nicp = nonrigid_icp(source, target, o.refinement, {}, &fit.V);
    r.deformed_source = r.nicp.V;
  }
  r.correspondence = nearest_centroid_correspondence(r.deformed_source, source.F, target.V, target.F, &r.normal_failures, o.threads);
  r.warnings = fit.warnings;
  r.seconds = t0.seconds();
  return r;
}

}  // namespace

nlohmann::ordered_json registration_quality_json(const RegistrationQuality& q, bool with_warnings) {
  nlohmann::ordered_json j = {{"mean_distance_mm", q.mean_distance_mm},
                              {"p95_distance_mm", q.p95_distance_mm},
                              {"target_covered", q.target_covered},
                              {"normals_agree", q.normals_agree},
                              {"folded_triangles", q.folded_triangles}};
  if (with_warnings) j["warnings"] = q.warnings;
  return j;
}

/// The registration's options from the command line, the shape space (if any) checked against the
/// source's topology.
RegistrationOptions registration_options(const ArgParser& args, bool by_body_model, const TriangleMesh& source) {
  RegistrationOptions o;
  if (!by_body_model) o.method = parse_registration_method(args.get("method"));
  o.icp_iterations = static_cast<int>(args.get_int("iterations"));
  o.refine = args.flag_set("refine");
  if (o.refine && o.method != RegistrationMethod::kCtffd) throw UsageError("--refine applies to --method ctffd or body-model");
  const long threads = args.get_int("threads");
  if (threads < 0 || threads > 256) throw UsageError("--threads must be between 0 (all cores) and 256");
  o.threads = static_cast<int>(threads);
  for (NicpOptions* n : {&o.nicp, &o.refinement}) {
    if (args.has("stiffness")) n->stiffness = args.get_double_list("stiffness");
    if (args.has("steps")) n->max_iterations_per_stiffness = static_cast<int>(args.get_int("steps"));
    n->landmark_weight = args.get_double("landmark-weight");
    n->point_to_point = args.get_double("point-to-point");
    if (n->point_to_point < 0 || n->point_to_point > 1) throw UsageError("--point-to-point must be between 0 and 1");
    if (n->landmark_weight < 0) throw UsageError("--landmark-weight must not be negative");
  }
  const std::string shape_arg = args.get("shape-space");
  const bool shape_file = is_shape_space_file(shape_arg);
  if (shape_arg != "0" && (o.method != RegistrationMethod::kCtffd || by_body_model))
    throw UsageError("--shape-space applies to --method ctffd");
  o.shape_space = shape_space_option(shape_arg, args.get("shape-space-leave-out"), args.get("data"));
  if (o.shape_space &&
      (o.shape_space->vertices() != source.num_vertices() || (o.shape_space->faces.size() > 0 && o.shape_space->faces != source.F)))
    throw InvalidInput(
        args.positionals()[0] + ": the shape space " + (shape_file ? shape_arg + " " : std::string()) + "is of another topology (" +
        std::to_string(o.shape_space->vertices()) + " vertices, " + std::to_string(o.shape_space->faces.rows()) +
        " triangles; the source has " + std::to_string(source.num_vertices()) + " and " + std::to_string(source.num_faces()) + ")" +
        (shape_file ? std::string(": register from the mesh the space's bodies were registered to")
                    : std::string(": MakeHuman's spaces need its base topology, the dataset's template (template/rest.ply)")));
  return o;
}

int run_register(int argc, char** argv) {
  ArgParser args("register",
                 "Registers a source body (e.g. the template) to a target body (a customized model) and matches\n"
                 "every target triangle to the source triangle with the nearest centroid facing the same way\n"
                 "(Eq. 2b/2c). ctffd: ct-FFD through the layered representations (section 3.3.3); icp: rigid\n"
                 "ICP (PCL) for --iterations, the paper's Table 1 baseline; nicp: optimal-step non-rigid ICP\n"
                 "(Amberg et al. 2007: stiffness schedule, automatic landmarks, point-to-plane, rejection). --refine\n"
                 "adds soft non-rigid ICP steps after ct-FFD; --shape-space fits a space of MakeHuman bodies to the\n"
                 "target from ct-FFD's result (sub-millimetre on bodies the space holds). Prints the quality judged\n"
                 "without ground truth (distance to the target, coverage, normal agreement, fold-overs) and warns\n"
                 "when it is poor.\n"
                 "body-model: the body model (--body-model, a shape space with joints) fitted to the target in any\n"
                 "pose and frame, its vertices the source's (the source must be MakeHuman's template topology);\n"
                 "--refine adds the soft non-rigid ICP steps after it. A poor fit exits with status 3.\n"
                 "Both bodies standing (any pose for body-model), in any axis convention and unit (detected, or given).");
  args.positional("source", "source mesh")
      .positional("target", "target mesh")
      .option("method", "M", "ctffd, icp, nicp or body-model", "ctffd")
      .option("iterations", "N", "ICP iterations", "6")
      .flag("refine", "ctffd, body-model: refine by soft non-rigid ICP steps started from its result")
      .option("stiffness", "A,B,..", "non-rigid ICP stiffness schedule, stiff to soft (default: nicp 100,50,25,12,6,3,1.5; refine 4,2)")
      .option("landmark-weight", "W", "non-rigid ICP landmark weight at the first stiffness (falls with it)", "10")
      .option("steps", "N", "non-rigid ICP iterations at most per stiffness (default: nicp 5, refine 2)")
      .option("point-to-point", "S", "share of point-to-point in non-rigid ICP's data term (0: point-to-plane)", "0.1")
      .option("shape-space", "N|FILE",
              "ctffd: refine by a shape space: of N MakeHuman bodies (built from the data root, a "
              "few seconds; the source must be in MakeHuman's base topology, as the dataset's template), or a .pks file "
              "(posekit shape-space) in the source's topology; 0: not",
              "0")
      .option("shape-space-leave-out", "WHAT",
              "none, men, obese or local (the measure modifiers): what the shape space's "
              "population lacks",
              "none")
      .data_option("for --shape-space and --body-model")
      .option("unit", "U", "unit of both meshes: m, dm, cm, mm, or auto (each one's largest extent tells)", "auto")
      .output("out", "FILE", "correspondence JSON: for each target triangle its source triangle")
      .output("deformed", "FILE", "write the source deformed onto the target (mesh)")
      .output("quality", "FILE", "write the summary with the quality judged without ground truth (JSON)")
      .option("threads", "T", "threads of ctffd and of the body model's fit (0: all cores; the result is the same to rounding)", "0")
      .flag("json", "summary as JSON on stdout")
      .example("posekit register dataset/template/rest.ply dataset/subjects/f01/rest.ply --out corr.json --deformed d.ply");
  add_body_model_options(&args, false);
  add_orientation_options(&args, "source-", "the source");
  add_orientation_options(&args, "target-", "the target");
  if (!args.parse(argc, argv)) return 0;
  const bool by_body_model = args.get("method") == "body-model";
  if (by_body_model != args.has("body-model"))
    throw UsageError(by_body_model ? "--method body-model needs --body-model FILE" : "--body-model needs --method body-model");
  auto read_body = [&](const std::string& path, const std::string& prefix, BodyUnit* unit, BodyOrientation* orientation) {
    BodyInput in = read_body_input(path, args.get("unit"), "register", unit);
    if (in.is_cloud) throw InvalidInput(path + ": register needs a mesh (triangles); this file has only points");
    if (by_body_model && prefix == "target-") return std::move(in.mesh);  // the fit finds its frame: any pose
    *orientation = orient_body_input(&in, args.get(prefix + "up"), args.get(prefix + "forward"), path, "register");
    return std::move(in.mesh);
  };
  BodyUnit source_unit, target_unit;
  BodyOrientation source_orientation, target_orientation;
  const TriangleMesh source = read_body(args.positionals()[0], "source-", &source_unit, &source_orientation);
  const TriangleMesh target = read_body(args.positionals()[1], "target-", &target_unit, &target_orientation);
  const RegistrationOptions o = registration_options(args, by_body_model, source);
  // Folds are judged against the source as the method poses it: the body model's fitted body (a
  // kneeling or Z-up target turns most triangles away from the template's own directions).
  TriangleMesh posed_source = source;
  const RegistrationResult r =
      by_body_model ? register_by_body_model(source, target, o, args, &posed_source.V) : register_bodies(source, target, o);
  if (args.has("out")) {
    nlohmann::json j;
    j["source"] = args.positionals()[0];
    j["target"] = args.positionals()[1];
    j["method"] = args.get("method");
    j["meaning"] = "target_to_source[k] is the source triangle matched to target triangle k";
    j["target_to_source"] = std::vector<int>(r.correspondence.data(), r.correspondence.data() + r.correspondence.size());
    const std::string text = j.dump() + "\n";
    write_file_atomically(
        args.get("out"), [&](std::ostream& out) { out << text; }, false);
  }
  if (args.has("deformed")) {
    TriangleMesh d;
    d.V = in_file_frame(target_orientation, r.deformed_source);  // it lies on the target: the target file's frame
    d.F = source.F;
    write_mesh(args.get("deformed"), d, {target_unit.unit, MeshFormat::kAuto, true, io_warnings()});
  }
  const RegistrationQuality q = assess_registration(posed_source, r.deformed_source, target);
  nlohmann::ordered_json s = {{"method", args.get("method")},
                              {"refine", o.refine},
                              {"source_vertices", source.num_vertices()},
                              {"target_triangles", target.num_faces()},
                              {"seconds", r.seconds},
                              {"normal_failures", r.normal_failures},
                              {"quality", registration_quality_json(q, true)}};
  s["warnings"] = r.warnings;
  if (!r.nicp.stiffness.empty())
    s["nicp"] = {{"stiffness", r.nicp.stiffness},
                 {"iterations", r.nicp.iterations},
                 {"solves", r.nicp.solves},
                 {"landmarks", r.nicp.landmarks},
                 {"accepted_fraction", r.nicp.accepted_fraction}};
  if (o.shape_space)
    s["shape_space"] = {{"population", o.shape_space->population}, {"components", o.shape_space->components()},
                        {"iterations", r.shape_fit.iterations},    {"median_distance_mm", 1000 * r.shape_fit.median_distance},
                        {"far_share", r.shape_fit.far_share},      {"uncovered_share", r.shape_fit.uncovered_share},
                        {"kept", r.shape_fit.plausible},           {"seconds", r.shape_fit_seconds}};
  if (args.has("quality")) {
    const std::string text = s.dump(2) + "\n";
    write_file_atomically(
        args.get("quality"), [&](std::ostream& out) { out << text; }, false);
  }
  for (const std::string& w : r.warnings) std::cerr << "posekit register: warning: " << w << "\n";
  for (const std::string& w : q.warnings) std::cerr << "posekit register: warning: " << w << "\n";
  if (args.flag_set("json")) {
    std::cout << s.dump(2) << std::endl;
    return 0;
  }
  std::cout << "registered " << args.positionals()[0] << " -> " << args.positionals()[1] << " by " << args.get("method") << " in "
            << std::fixed << std::setprecision(3) << r.seconds << " s; " << target.num_faces() << " target triangles matched ("
            << r.normal_failures << " without a source triangle facing the same way)\n"
            << "quality: source to target " << std::setprecision(1) << q.mean_distance_mm << " mm mean, " << q.p95_distance_mm
            << " mm p95; target covered " << 100 * q.target_covered << "%; normals agree " << 100 * q.normals_agree << "%; "
            << q.folded_triangles << " triangles folded\n";
  if (o.shape_space)
    std::cout << "shape space: " << o.shape_space->components() << " components of " << o.shape_space->population << "; fitted in "
              << r.shape_fit.iterations << " iterations, " << std::setprecision(3) << r.shape_fit_seconds << " s, median "
              << std::setprecision(1) << 1000 * r.shape_fit.median_distance << " mm from the target, " << 100 * r.shape_fit.far_share
              << "% of it and " << 100 * r.shape_fit.uncovered_share << "% of the target over " << std::setprecision(0)
              << 1000 * o.shape_fit.far_distance << " mm apart: " << (r.shape_fit.plausible ? "kept" : "not kept (see the warning)")
              << "\n";
  if (!r.nicp.stiffness.empty()) {
    std::cout << "non-rigid ICP: " << r.nicp.landmarks << " landmarks; stiffness (iterations)";
    for (size_t k = 0; k < r.nicp.stiffness.size(); ++k)
      std::cout << " " << std::setprecision(2) << r.nicp.stiffness[k] << " (" << r.nicp.iterations[k] << ")";
    std::cout << "\n";
  }
  return 0;
}

}  // namespace posekit::cli
