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
#include "posekit/evaluation/registration_table.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/registration/correspondence.h"
#include "posekit/registration/nicp.h"
#include "posekit/registration/registration.h"

namespace posekit::cli {
namespace fs = std::filesystem;

void set_population_leave_out(PopulationOptions& o, const std::string& what) {
  if (what == "men") {
    o.keep = [](const BodySpec& s, const TriangleMesh&) { return s.gender <= 0.5; };
    o.keep_note = "men (gender over 0.5) left out";
  } else if (what == "obese") {
    o.keep = [](const BodySpec&, const TriangleMesh& m) { return body_stats(m).bmi < 30.0; };
    o.keep_note = "BMI 30 and over left out";
  } else if (what == "local") {
    o.local_variation = false;
  } else if (what != "none") {
    throw UsageError("the shape space's leave-out is none, men, obese or local, not '" + what + "'");
  }
}

ShapeSpace make_makehuman_shape_space(const MakeHumanModel& model, PopulationOptions o, double variance_kept, int max_components) {
  std::unique_ptr<Progress> progress;
  o.progress = [&](int done, int total) {
    if (!progress) progress = std::make_unique<Progress>("shape space bodies", total);
    progress->update(done);
  };
  ShapeSpace space = makehuman_shape_space(model, o, variance_kept, max_components);
  if (progress) progress->finish();
  return space;
}

bool is_shape_space_file(const std::string& value) {
  return !value.empty() && value.find_first_not_of("0123456789", value[0] == '-' ? 1 : 0) != std::string::npos;
}

std::shared_ptr<const ShapeSpace> shape_space_option(const std::string& value, const std::string& leave_out, const std::string& data_root) {
  if (is_shape_space_file(value)) return std::make_shared<const ShapeSpace>(read_shape_space(value));
  const long bodies = value.empty() ? 0 : std::stol(value);
  if (bodies < 0 || bodies == 1) throw UsageError("--shape-space must be 0, at least 2 bodies, or a .pks file");
  if (bodies == 0) return nullptr;
  PopulationOptions po;
  po.count = static_cast<int>(bodies);
  set_population_leave_out(po, leave_out);
  return std::make_shared<const ShapeSpace>(make_makehuman_shape_space(*load_makehuman_model(find_data_root(data_root)), po));
}

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
      .option("threads", "T", "ctffd: threads (0: all cores; the result is the same to rounding)", "0")
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
                              {"quality",
                               {{"mean_distance_mm", q.mean_distance_mm},
                                {"p95_distance_mm", q.p95_distance_mm},
                                {"target_covered", q.target_covered},
                                {"normals_agree", q.normals_agree},
                                {"folded_triangles", q.folded_triangles},
                                {"warnings", q.warnings}}}};
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

namespace {

/// The BVH files `list` names (comma-separated files and folders, searched recursively); "auto": the
/// motions folder beside the data root and the data root's own poses and animations, where they are.
std::vector<std::string> motion_files(const std::string& list, const std::string& data_root) {
  std::vector<std::string> roots;
  if (list == "auto") {
    const fs::path data(data_root);
    for (const fs::path& p : {data.parent_path() / "motions", data / "poses", data / "animations"})
      if (fs::is_directory(p)) roots.push_back(p.string());
  } else {
    std::stringstream in(list);
    for (std::string item; std::getline(in, item, ',');)
      if (!item.empty()) roots.push_back(item);
  }
  std::vector<std::string> files;
  for (const std::string& root : roots) {
    if (!fs::exists(root)) throw UsageError("--motions: " + root + " does not exist");
    if (!fs::is_directory(root)) {
      files.push_back(root);
      continue;
    }
    for (const auto& e : fs::recursive_directory_iterator(root)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (e.is_regular_file() && ext == ".bvh") files.push_back(e.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// Every `every`-th frame of the motions retargeted to the space's mean body, the most distinct of
/// them (distinct_motion_poses) stored in the space for the body-model fit's search.
void add_motion_poses(const std::vector<std::string>& files, const std::string& data_root, int every, int max_poses, ShapeSpace* space) {
  std::vector<LibraryPose> frames;
  int used = 0;
  for (const std::string& file : files) {
    try {
      const LoadedPoses loaded = load_poses(file, "", data_root, space->joint_mean, "", "none");
      for (size_t f = 0; f < loaded.poses.size(); f += static_cast<size_t>(every)) {
        const std::string name = fs::path(file).stem().string() + (loaded.poses.size() > 1 ? " frame " + std::to_string(f) : "");
        frames.push_back({name, name, loaded.poses[f]});
      }
      ++used;
    } catch (const Error& e) {
      std::cerr << "warning: --motions: " << file << " left out: " << e.what() << "\n";
    }
  }
  const std::vector<LibraryPose> chosen = distinct_motion_poses(frames, pose_library(space->joint_mean), max_poses);
  space->poses.resize(static_cast<Eigen::Index>(chosen.size()), 3 * (1 + kNumJoints));
  space->pose_names.clear();
  for (size_t k = 0; k < chosen.size(); ++k) {
    space->poses.row(static_cast<Eigen::Index>(k)) = pose_row(chosen[k].pose);
    space->pose_names.push_back(chosen[k].name);
  }
  std::cerr << "posekit shape-space: " << chosen.size() << " poses for the fit's search, the most distinct of " << frames.size()
            << " frames (every " << every << ") of " << used << " motion files\n";
}

}  // namespace

int run_shape_space(int argc, char** argv) {
  ArgParser args("shape-space",
                 "Learns a shape space (principal components of a population of bodies in one topology) and writes\n"
                 "it to a .pks file for posekit register --shape-space FILE, which then skips the few seconds of\n"
                 "building it. The population: N MakeHuman bodies in its base topology (the dataset's template), or\n"
                 "your own registered bodies (--meshes: a folder of meshes sharing one topology, standing in one\n"
                 "pose, in any place, direction and unit; turned rigidly onto their mean before learning). Register\n"
                 "from the mesh those bodies were registered to.\n"
                 "--survey: posekit's body model population. MakeHuman's sliders (macros, measure-* modifiers, buttocks)\n"
                 "are fitted to each subject's stature, chest, waist (at the navel), buttock, thigh, calf, neck and flexed\n"
                 "biceps girths, crotch and acromial heights, biacromial breadth and sleeve outseam (ANSUR II columns),\n"
                 "the fit residuals are reported, and the components kept are the fewest that reconstruct every fitted\n"
                 "body within --max-rms-mm (docs/population.md).");
  args.output("out", "FILE", "the shape space file to write (.pks)")
      .option("bodies", "N", "MakeHuman bodies in the population", "300")
      .option("leave-out", "WHAT", "none, men, obese or local (the measure modifiers): what the MakeHuman population lacks", "none")
      .data_option()
      .option("meshes", "DIR", "learn from this folder of registered meshes (OBJ/PLY/OFF, one topology) instead of MakeHuman bodies")
      .option("unit", "U", "--meshes: their unit, m, dm, cm, mm, or auto (the first mesh's largest extent tells)", "auto")
      .flag("no-align", "--meshes: keep them where they stand (no rigid alignment onto their mean)")
      .flag("ansur", "learn from MakeHuman bodies fitted to ANSUR II's 6,068 adults (found as --survey says)")
      .option("survey", "DIR|FILE",
              "--ansur: ANSUR II's folder or one survey CSV with its columns (default: $POSEKIT_ANSUR, "
              "else ansur2 beside the data root)")
      .option("subjects", "N", "--ansur: that many subjects spread through the survey (0: all)", "0")
      .option("leave-out-ids", "A,B", "--ansur: leave these SubjectIds out (e.g. the bodies customize robustness photographs)")
      .option("max-rms-mm", "MM", "--ansur: keep the fewest components that reconstruct every fitted body within this RMS", "1")
      .output("residuals", "FILE", "--ansur: write the fit residuals and each subject's sliders (JSON)")
      .option("threads", "N", "--ansur: threads for the fits (0: all cores)", "0")
      .option("motions", "LIST",
              "--ansur: motion capture (BVH files or folders, comma-separated) whose most distinct frames join "
              "the body-model fit's pose library; auto: the motions folder beside the data root and the data root's poses "
              "and animations; none: the built-in library only",
              "auto")
      .option("motion-poses", "N",
              "--motions: poses kept at most (each at least 30 degrees at some joint from the others "
              "and the built-in library)",
              "40")
      .option("motion-every", "N", "--motions: every N-th frame is a candidate", "10")
      .option("variance", "F", "share of the population's variance the components keep", "0.99999")
      .option("max-components", "K", "components at most", "60")
      .flag("json", "summary as JSON on stdout")
      .example("posekit shape-space --out makehuman300.pks")
      .example("posekit shape-space --meshes my_registrations/ --unit mm --out mine.pks")
      .example("posekit shape-space --ansur --out ansur.pks --residuals ansur-fits.json");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("out")) throw UsageError("--out FILE is required");
  const double variance = args.get_double("variance");
  const long max_components = args.get_int("max-components");
  if (!(variance > 0 && variance <= 1)) throw UsageError("--variance must be in (0, 1]");
  if (max_components < 1) throw UsageError("--max-components must be at least 1");
  ShapeSpace space;
  if (args.flag_set("ansur") || args.has("survey")) {
    if (args.has("meshes")) throw UsageError("--ansur and --meshes are two populations: give one");
    const long subjects = args.get_int("subjects"), threads = args.get_int("threads");
    const double max_rms = args.get_double("max-rms-mm");
    if (subjects < 0 || subjects == 1) throw UsageError("--subjects must be 0 (all) or at least 2");
    if (!(max_rms > 0)) throw UsageError("--max-rms-mm must be positive");
    if (threads < 0) throw UsageError("--threads must be 0 (all cores) or more");
    const long motion_poses = args.get_int("motion-poses"), every = args.get_int("motion-every");
    if (motion_poses < 0) throw UsageError("--motion-poses must be 0 or more");
    if (every < 1) throw UsageError("--motion-every must be at least 1");
    const std::string data_root = find_data_root(args.get("data"));
    const std::vector<std::string> motions =
        args.get("motions") == "none" || motion_poses == 0 ? std::vector<std::string>{} : motion_files(args.get("motions"), data_root);
    space = survey_shape_space(args.has("survey") ? args.get("survey") : "", args.get("data"), subjects, max_rms,
                               static_cast<int>(max_components), static_cast<int>(threads),
                               args.has("residuals") ? args.get("residuals") : "", args.flag_set("json"),
                               args.has("leave-out-ids") ? split_commas(args.get("leave-out-ids")) : std::vector<std::string>{});
    if (!motions.empty()) add_motion_poses(motions, data_root, static_cast<int>(every), static_cast<int>(motion_poses), &space);
  } else if (args.has("meshes")) {
    const std::string dir = args.get("meshes");
    // Read in the file's numbers first when the unit is to be detected: the first mesh's extent tells.
    const bool automatic = args.get("unit") == "auto";
    PoseDataset data = load_pose_dataset(dir, automatic ? Unit::kMetre : parse_unit(args.get("unit")));
    if (automatic) {
      const double extent = robust_largest_extent(data.V.front());
      Unit unit = Unit::kMetre;
      if (!guess_body_unit(extent, &unit))
        throw InvalidInput(dir + ": cannot tell the meshes' unit from the first one's largest extent (" + std::to_string(extent) +
                           "): give --unit");
      for (Eigen::MatrixXd& V : data.V) V *= metres_per_unit(unit);
      std::cerr << "posekit shape-space: unit " << unit_name(unit) << " (detected from " << data.names.front() << "'s largest extent, "
                << extent << ")\n";
    }
    // One unit for all: a body 10 or 1000 times the first one's size is another unit, not a shape.
    const double first = robust_largest_extent(data.V.front());
    for (size_t b = 1; b < data.V.size(); ++b) {
      const double ratio = robust_largest_extent(data.V[b]) / first;
      if (!(ratio > 0.5 && ratio < 2))
        throw InvalidInput(dir + ": " + data.names[b] + " is " + std::to_string(ratio) + " times the size of " + data.names.front() +
                           ": the meshes must be in one unit (convert it, or learn without it)");
    }
    if (!args.flag_set("no-align")) align_bodies_rigidly(data.V);
    space = learn_shape_space(data.V, variance, static_cast<int>(max_components),
                              std::to_string(data.V.size()) + " registered meshes of " + dir);
    space.faces = data.F;
  } else {
    const long count = args.get_int("bodies");
    if (count < 2) throw UsageError("--bodies must be at least 2");
    PopulationOptions po;
    po.count = static_cast<int>(count);
    set_population_leave_out(po, args.get("leave-out"));
    space =
        make_makehuman_shape_space(*load_makehuman_model(find_data_root(args.get("data"))), po, variance, static_cast<int>(max_components));
  }
  write_shape_space(args.get("out"), space);
  double kept = 0;
  for (double v : space.variance_share) kept += v;
  if (args.flag_set("json")) {
    print_json({{"out", args.get("out")},
                {"population", space.population},
                {"bodies", space.bodies},
                {"vertices", space.vertices()},
                {"triangles", space.faces.rows()},
                {"components", space.components()},
                {"variance_kept", kept}});
    return 0;
  }
  std::cout << "wrote " << args.get("out") << ": " << space.components() << " components of " << space.population << " ("
            << space.vertices() << " vertices), " << std::setprecision(6) << 100 * kept << "% of its variance\n";
  return 0;
}

}  // namespace posekit::cli
