// posekit train / pose / segment / eval: the pose deformation pipeline of section 3.3.
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

/// The subject of pose or fit (--subject, --unit, --up, --forward): read, turned into posekit's
/// frame, and checked to be one body.
TriangleMesh read_posing_subject(const ArgParser& args, const std::string& command, BodyOrientation* orientation, BodyUnit* unit) {
  BodyInput input = read_body_input(args.get("subject"), args.get("unit"), command, unit);
  if (input.is_cloud) throw InvalidInput(args.get("subject") + ": the subject must be a mesh (triangles); this file has only points");
  *orientation = orient_body_input(&input, args.get("up"), args.get("forward"), args.get("subject"), command);
  check_subject(input.mesh, args.get("subject"));
  return std::move(input.mesh);
}

nlohmann::ordered_json fit_report_json(const DatasetTrainingReport& r) {
  nlohmann::ordered_json examples = nlohmann::ordered_json::array();
  for (const auto& e : r.examples) {
    nlohmann::ordered_json x = {{"name", e.name}, {"split", e.test ? "test" : e.left_out ? "left out" : "train"}, {"rms_mm", e.rms_mm},
                                {"worst_part", e.worst_part}, {"worst_part_rms_mm", e.worst_core_rms_mm}};
    if (e.joint_error_mean_deg >= 0)
      x["against_json"] = {{"joint_error_mean_deg", e.joint_error_mean_deg}, {"joint_error_max_deg", e.joint_error_max_deg},
                           {"worst_joint", e.worst_joint}};
    x["problems"] = e.problems;
    examples.push_back(x);
  }
  return {{"rest", r.rest_name}, {"rest_reason", r.rest_reason}, {"unit", r.unit}, {"orientation", r.orientation},
          {"labels", r.labels_from_dataset ? "template/parts.json, template/joints.json"
                                           : r.labels_from_body_model ? "the body model's fit" : "segmented (Eq. 2)"},
          {"poses", r.poses_estimated ? "estimated from the meshes" : "pose JSONs"},
          {"examples", examples}, {"warnings", r.warnings}};
}

/// What a user needs to hear about the template and the estimated poses, on stderr.
void report_pose_estimation(const DatasetTrainingReport& r, std::ostream& err) {
  err << "posekit train: template '" << r.rest_name << "' (" << r.rest_reason << "), unit " << r.unit << ", "
      << r.orientation << "; labels " << (r.labels_from_dataset ? "from the dataset" : r.labels_from_body_model ? "from the body model's fit" : "from its own segmentation (Eq. 2)")
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
  err << std::fixed << std::setprecision(1) << "posekit train: poses of " << r.examples.size()
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

/// The joints whose learned offsets training kept.
std::vector<std::string> offsets_kept(const PoseModel& model) {
  std::vector<std::string> kept;
  for (Eigen::Index j = 0; j < model.joint_offsets.rows(); ++j)
    if (!model.joint_offsets.row(j).isZero(0)) kept.push_back(joint_name(static_cast<int>(j)));
  return kept;
}

nlohmann::ordered_json stats_json(const ErrorStats& s) {
  return {{"mean_mm", s.mean_mm}, {"p95_mm", s.p95_mm}, {"max_mm", s.max_mm}, {"vertices", s.count}};
}

}  // namespace

LoadedPoses load_poses(const std::string& path, const std::string& frames, const std::string& data_root,
                       const Eigen::MatrixXd& rest_joints, const std::string& joint_map, const std::string& root_motion,
                       const BvhMotion* parsed) {
  LoadedPoses out;
  std::string ext = fs::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  const std::string stem = fs::path(path).stem().string();
  if (ext != ".bvh") {
    out.names.push_back(stem);
    out.poses.push_back(read_part_pose(path));
    return out;
  }
  BvhMotion read;
  if (!parsed) read = read_bvh(path, Unit::kMetre, io_warnings());
  const BvhMotion& motion = parsed ? *parsed : read;
  if (motion.num_frames() == 0) throw InvalidInput(path + ": the motion has no frames");
  long first = 0, last = motion.num_frames();
  if (!frames.empty()) {
    const auto [a, b] = parse_number_pair(frames, ':', "--frames");
    first = static_cast<long>(a), last = static_cast<long>(b);
    if (first < 0 || last > motion.num_frames() || first >= last)
      throw UsageError("--frames " + frames + " is outside the " + std::to_string(motion.num_frames()) + " frames of " + path);
  }
  for (long i = first; i < last; ++i) {
    std::ostringstream name;
    name << stem << "_" << std::setw(4) << std::setfill('0') << i;
    out.names.push_back(last - first > 1 ? name.str() : stem);
  }
  if (motion.find_joint("upperarm01.L") >= 0) {  // MakeHuman's own skeleton: through its rig, bone by bone
    const auto mh = load_makehuman_model(find_data_root(data_root));
    for (long i = first; i < last; ++i)
      out.poses.push_back(part_pose_from_bone_pose(mh->rig, bone_pose_from_bvh(mh->rig, motion, static_cast<int>(i))));
    return out;
  }
  std::map<std::string, std::string> overrides;
  if (!joint_map.empty()) {
    nlohmann::json j;
    try {
      j = nlohmann::json::parse(read_file_bytes(joint_map));
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(joint_map + ": not JSON (" + e.what() + ")");
    }
    if (!j.is_object()) throw InvalidInput(joint_map + ": expected an object {\"left_shoulder\": \"<BVH joint>\", ...}");
    for (const auto& [key, value] : j.items()) {
      if (!value.is_string()) throw InvalidInput(joint_map + ": the value of '" + key + "' must be a BVH joint name");
      overrides[key] = value.get<std::string>();
    }
  }
  const BvhPartMap map = map_bvh_skeleton(motion, overrides);
  RetargetOptions o;
  o.first = static_cast<int>(first);
  o.last = static_cast<int>(last);
  if (root_motion == "none") o.root_motion = RetargetOptions::RootMotion::kNone;
  else if (root_motion == "all") o.root_motion = RetargetOptions::RootMotion::kAll;
  else if (root_motion != "vertical") throw UsageError("--root-motion expects none, vertical or all, got '" + root_motion + "'");
  out.poses = retarget_bvh(motion, map, rest_joints, o);
  std::string mapped;
  for (int p = 0; p < kNumParts; ++p)
    if (map.joint[p] >= 0) mapped += (mapped.empty() ? "" : ", ") + part_name(p) + "=" + motion.joints[static_cast<size_t>(map.joint[p])].name;
  out.notes.push_back(path + ": retargeted from its own skeleton (" + mapped + ")");
  out.notes.insert(out.notes.end(), map.notes.begin(), map.notes.end());
  return out;
}

PoseSynthesizer set_up_subject(std::shared_ptr<const PoseModel> model, const TriangleMesh& subject, const std::string& path,
                               const SubjectSetupOptions& options) {
  try {
    return PoseSynthesizer(std::move(model), subject, options);
  } catch (const InvalidInput& e) {
    throw InvalidInput(path + ": cannot be set up for posing: " + e.what() +
                       (options.joint_centres.size() ? std::string() : "; a subject must stand upright in the standard pose, arms away from the body (or give --body-model)"));
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

/// --calibration-population: empty for random MakeHuman bodies, else `count` bodies fitted to subjects
/// of the survey drawn with `seed` (both: and `count` random MakeHuman bodies besides).
std::vector<BodySpec> calibration_population_specs(const ArgParser& args, int count, unsigned seed) {
  const std::string population = args.get("calibration-population");
  if (population == "makehuman") return {};
  if (population != "ansur" && population != "both")
    throw UsageError("--calibration-population is makehuman, ansur or both, not '" + population + "'");
  const std::string data_root = find_data_root(args.has("data") ? args.get("data") : "");
  const std::string survey = find_ansur_root(args.has("survey") ? args.get("survey") : "", data_root);
  const SurveyBodyFitter fitter(load_makehuman_model(data_root));
  std::vector<BodySpec> specs;
  for (const SurveySubject& subject : sample_survey(read_survey(survey), count, seed)) specs.push_back(fitter.fit(subject).spec);
  if (population == "both")
    for (BodySpec& random : make_calibration_specs(seed, count)) specs.push_back(std::move(random));
  return specs;
}

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
      .option("poses", "auto|json|estimate",
              "training poses: the JSONs, estimated from the meshes, or auto (JSONs when every example has one)", "auto")
      .option("rest", "NAME", "the rest-pose example (default: the manifest's, a zero pose, a name with rest/template, else the first)")
      .option("unit", "UNIT", "unit of the meshes: m, dm, cm, mm or auto (from the rest mesh's extent)", "auto")
      .output("fit-report", "FILE", "per-example fit of the estimated poses (JSON: residuals, joint errors against given JSONs)")
      .flag("joint-offsets",
            "extension beyond the paper: learn where each joint sits as a function of its twist (a shoulder girdle\n"
            "                          that rises with the arm), kept per joint where it lowers the training error")
      .option("smooth", "N", "extension beyond the paper, for noisy meshes: smooth each example's non-rigid deformation over N rounds of neighbouring triangles before Eq. 5", "0")
      .option("calibration-bodies", "N", "random MakeHuman bodies in the segmentation prior; 0: the template alone (default: 128)")
      .option("calibration-population", "P", "the segmentation prior's bodies: makehuman (random sliders) or ansur (MakeHuman\n"
              "                          fitted to ANSUR II subjects drawn at random, women and men alternately: real proportions)\n"
              "                          or both (N of each)",
              "makehuman")
      .option("survey", "DIR|FILE", "--calibration-population ansur: ANSUR II's folder or a survey CSV (default: $POSEKIT_ANSUR, "
              "else ansur2 beside the data root)")
      .data_option("for the prior")
      .flag("json", "summary as JSON on stdout")
      .example("posekit train --dataset out/dataset --out model.pkm")
      .example("posekit train --dataset scape_meshes/ --rest mesh000 --fit-report fits.json");
  add_body_model_options(&args, false);
  add_orientation_options(&args, "", "the meshes' body");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
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
  std::unique_ptr<BodyModel> body_model;
  if (args.has("body-model")) body_model = load_body_model(args), dto.body_model = body_model.get();
  dto.accept_poor_fit = args.flag_set("accept-poor");
  Progress progress("train", 100);
  TrainingOptions o;
  o.progress = [&](int done, int total) { progress.update(100L * done / std::max(total, 1)); };
  o.learn_joint_offsets = args.flag_set("joint-offsets");
  const long smoothing = args.get_int("smooth");
  if (smoothing < 0 || smoothing > 1000) throw UsageError("--smooth expects 0 to 1000 iterations, got " + args.get("smooth"));
  o.smoothing_iterations = static_cast<int>(smoothing);
  const Stopwatch t0;
  DatasetTrainingReport fits;
  PoseModel model = train_on_dataset(args.get("dataset"), o, dto, &fits);
  const double seconds = t0.seconds();
  progress.finish();
  const nlohmann::ordered_json fit_json = fit_report_json(fits);
  report_pose_estimation(fits, std::cerr);
  if (args.has("fit-report")) write_file_atomically(args.get("fit-report"), [&](std::ostream& f) { f << fit_json.dump(2) << "\n"; }, false);
  const long calibration_bodies = args.has("calibration-bodies") ? args.get_int("calibration-bodies") : 128;
  if (calibration_bodies < 0) throw UsageError("--calibration-bodies must not be negative");
  PriorReport prior;
  if (calibration_bodies > 0) {
    Progress calibration("segmentation prior", calibration_bodies + 1);
    CalibrationOptions co;
    co.bodies = static_cast<int>(calibration_bodies);
    co.progress = [&](int done, int) { calibration.update(done); };
    co.specs = calibration_population_specs(args, static_cast<int>(calibration_bodies), co.seed);
    prior = add_segmentation_prior(&model, args.has("data") ? args.get("data") : "", co);
    calibration.finish();
    if (!prior.not_made.empty()) std::cerr << "posekit train: segmentation prior is the template alone: " << prior.not_made << "\n";
  }
  write_pose_model(args.get("out"), model);
  nlohmann::ordered_json s = {{"model", args.get("out")}, {"training_poses", model.training_poses},
                              {"template_vertices", model.template_V.rows()}, {"template_triangles", model.template_F.rows()},
                              {"fit_rms", model.fit_rms}, {"seconds", seconds},
                              {"calibration_bodies", prior.bodies}, {"calibration_skipped", prior.skipped},
                              {"calibration_seconds", prior.seconds},
                              {"rest", fits.rest_name}, {"poses", fit_json["poses"]}, {"labels", fit_json["labels"]},
                              {"joint_offsets_kept", offsets_kept(model)},
                              {"warnings", fits.warnings},
                              {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "trained on " << model.training_poses << " poses of a " << model.template_V.rows() << "-vertex template in "
            << std::fixed << std::setprecision(2) << seconds << " s (RMS residual of Eq. 5: " << std::setprecision(4)
            << model.fit_rms << ")";
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

int run_pose(int argc, char** argv) {
  ArgParser args("pose",
                 "Poses a customized body (any topology) with a trained model (section 3.3.3): its own\n"
                 "segmentation and skeleton give the rigid part rotations T^R, the template's learned T^Q is\n"
                 "carried over by the ct-FFD correspondence, and one prefactorised solve per pose gives the mesh.\n"
                 "A pose is a 16-part pose JSON or a BVH (one mesh per frame): MakeHuman's skeleton, or any humanoid\n"
                 "skeleton (CMU, Mixamo, ...) retargeted to the subject's joints.");
  args.option("model", "FILE", "trained model (.pkm, posekit train)")
      .option("subject", "FILE", "the body to pose (PLY/OBJ/OFF/STL), standing; posed meshes come out in its frame")
      .option("pose", "FILE", "pose.json (16-part pose) or motion.bvh")
      .output("out", "FILE", "posed mesh; several BVH frames go to <stem>_0000<ext>, <stem>_0001<ext>, ...")
      .option("method", "M", "learned (the paper's), rigid (parts only) or lbs (16-part skinning)", "learned")
      .option("unit", "U", "unit of the subject mesh: m, dm, cm, mm, or auto (its largest extent tells)", "auto")
      .option("frames", "A:B", "BVH frames A to B-1 (default: all)")
      .data_option("for the BVH skeleton")
      .option("joint-map", "FILE", "JSON {\"left_shoulder\": \"<BVH joint>\", ...} for BVH joints the names do not tell")
      .option("root-motion", "M", "a retargeted BVH's root translation: none, vertical (feet stay down) or all", "vertical")
      .flag("json", "summary as JSON on stdout")
      .example("posekit pose --model model.pkm --subject out/dataset/subjects/f01/rest.ply --pose out/dataset/subjects/f01/posed/squat_half.json --out posed.ply")
      .example("posekit pose --model model.pkm --subject body.ply --pose cmu/01_01.bvh --frames 0:100 --out walk/frame.ply");
  add_body_model_options(&args, false);
  add_orientation_options(&args, "", "the subject");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"model", "subject", "pose", "out"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  const PoseMethod method = parse_pose_method(args.get("method"));
  const auto model = std::make_shared<const PoseModel>(read_pose_model(args.get("model")));
  BodyOrientation orientation;
  BodyUnit unit;
  const TriangleMesh subject = read_posing_subject(args, "pose", &orientation, &unit);
  const Stopwatch t0;
  const PoseSynthesizer synth = set_up_subject(model, subject, args.get("subject"), subject_setup(args, subject));
  const double setup = t0.seconds();
  for (const auto& problem : synth.info().skeleton_problems)
    std::cerr << "warning: " << args.get("subject") << ": the subject's skeleton looks wrong: " << problem << "\n";
  const LoadedPoses loaded = load_poses(args.get("pose"), args.has("frames") ? args.get("frames") : "", args.has("data") ? args.get("data") : "",
                                        synth.info().joint_centres, args.has("joint-map") ? args.get("joint-map") : "", args.get("root-motion"));
  for (const auto& note : loaded.notes) std::cerr << "posekit pose: " << note << "\n";
  const std::vector<PartPose>& poses = loaded.poses;
  Progress progress("pose", static_cast<long>(poses.size()));
  double pose_seconds = 0;
  std::vector<std::string> written;
  const fs::path out = args.get("out");  // its folder checked (or made, --mkdir) by the parser
  for (size_t i = 0; i < poses.size(); ++i) {
    const Stopwatch t1;
    TriangleMesh posed;
    synth.pose(poses[i], method, &posed.V);
    pose_seconds += t1.seconds();
    posed.F = subject.F;
    posed.vertex_scalars["part"] = vertex_labels_from_triangles(subject.V, subject.F, synth.info().triangle_part).cast<double>();
    std::string path = out.string();
    if (poses.size() > 1) {
      std::ostringstream name;
      name << out.stem().string() << "_" << std::setw(4) << std::setfill('0') << i << out.extension().string();
      path = (out.parent_path() / name.str()).string();
    }
    if (!orientation.is_identity()) posed.V = in_file_frame(orientation, posed.V);  // the subject file's frame
    write_mesh(path, posed, {unit.unit, MeshFormat::kAuto, true, io_warnings()});
    written.push_back(path);
    progress.update(static_cast<long>(i + 1));
  }
  progress.finish();
  nlohmann::ordered_json s = {{"subject", args.get("subject")}, {"method", pose_method_name(method)},
                              {"poses", poses.size()}, {"setup_seconds", setup},
                              {"pose_ms_mean", 1000 * pose_seconds / static_cast<double>(poses.size())},
                              {"normal_failures", synth.info().normal_failures}, {"written", written},
                              {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "posed " << args.get("subject") << " (" << subject.num_vertices() << " vertices) in " << poses.size()
            << (poses.size() == 1 ? " pose" : " poses") << " by the " << pose_method_name(method) << " method: set-up "
            << std::fixed << std::setprecision(3) << setup << " s, " << std::setprecision(2)
            << 1000 * pose_seconds / static_cast<double>(poses.size()) << " ms per pose, peak RSS " << std::setprecision(0)
            << peak_rss_mib() << " MiB; wrote " << written.front() << (written.size() > 1 ? " ..." : "") << "\n";
  return 0;
}

int run_retarget(int argc, char** argv) {
  ArgParser args("retarget",
                 "Turns the frames of a humanoid BVH (CMU's namings, Mixamo, generic Hips/Spine/..., any channel\n"
                 "order and unit, T-pose or A-pose rest) into 16-part pose JSONs, one per frame: the skeleton is\n"
                 "mapped by names and structure (printed), each part's rest direction turned onto the file's, and\n"
                 "the file's rotations applied. Poses are made for the default MakeHuman body's joints; `posekit\n"
                 "pose --pose file.bvh` retargets to the subject's own joints instead.");
  args.positional("bvh", "motion file (.bvh)")
      .output_folder("out", "DIR", "folder for <stem>_NNNN.json (created)")
      .option("frames", "A:B", "frames A to B-1 (default: all)")
      .option("every", "N", "every N-th frame", "1")
      .option("joint-map", "FILE", "JSON {\"left_shoulder\": \"<BVH joint>\", ...} for joints the names do not tell")
      .option("root-motion", "M", "root translation: none, vertical (feet stay down) or all", "vertical")
      .data_option("for the default body's joints")
      .flag("json", "summary as JSON on stdout")
      .example("posekit retarget ../shared/datasets/motions/cmu/01_01.bvh --out poses --every 10");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("out")) throw UsageError("--out DIR is required");
  const long every = args.get_int("every");
  if (every < 1) throw UsageError("--every must be at least 1");
  const auto mh = load_makehuman_model(find_data_root(args.has("data") ? args.get("data") : ""));
  const Eigen::MatrixXd rest = joint_centres(mh->rig, build_body(*mh, BodySpec{}));
  const LoadedPoses loaded = load_poses(args.positionals()[0], args.has("frames") ? args.get("frames") : "", args.has("data") ? args.get("data") : "",
                                        rest, args.has("joint-map") ? args.get("joint-map") : "", args.get("root-motion"));
  for (const auto& note : loaded.notes) std::cerr << "posekit retarget: " << note << "\n";
  create_folders(args.get("out"));
  std::vector<std::string> written;
  for (size_t i = 0; i < loaded.poses.size(); i += static_cast<size_t>(every)) {
    const std::string path = (fs::path(args.get("out")) / (loaded.names[i] + ".json")).string();
    validate_part_pose(loaded.poses[i], path);
    write_file_atomically(path, [&](std::ostream& out) { out << part_pose_to_json(loaded.poses[i]); });
    written.push_back(path);
  }
  nlohmann::ordered_json s = {{"bvh", args.positionals()[0]}, {"frames", loaded.poses.size()}, {"written", written.size()},
                              {"mapping", loaded.notes}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "retargeted " << loaded.poses.size() << " frames of " << args.positionals()[0] << "; wrote " << written.size()
            << " pose files to " << args.get("out") << "\n";
  return 0;
}

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
  nlohmann::ordered_json summary = {
      {"mesh", path}, {"method", "body model"}, {"body_model", args.get("body-model")}, {"confident", fit.confident},
      {"reasons", fit.reasons}, {"warnings", fit.warnings}, {"start", fit.start},
      {"up", {fit.up.x(), fit.up.y(), fit.up.z()}}, {"coverage", fit.coverage},
      {"target_mean_mm", 1000 * fit.target_mean}, {"target_p95_mm", 1000 * fit.target_p95},
      {"shape_mahalanobis", fit.shape_mahalanobis}, {"components", model.components()},
      {"working_points", fit.working_points}, {"seconds", fit.seconds}, {"joints", joints}, {"pose_fit_frame", pose},
      {"cross_check", cross}, {"disagreements", disagreements}};
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
    nlohmann::ordered_json jj = {{"units", "m"}, {"frame", "input"}, {"confident", fit.confident}, {"joints", joints}};
    const std::string text = jj.dump(2) + "\n";
    write_file_atomically(args.get("joints"), [&](std::ostream& o) { o << text; }, false);
  }
  if (args.flag_set("json")) {
    print_json(summary);
    return 0;
  }
  std::cout << "fitted the body model to " << path << " in " << std::fixed << std::setprecision(2) << fit.seconds
            << " s (started from " << fit.start << ", up " << fit.up.transpose().format(Eigen::IOFormat(2, 0, " ", " ", "", "", "(", ")"))
            << "): " << std::setprecision(1) << 100 * fit.coverage << "% of the body within 2 cm of the target, 95% of the target within "
            << 1000 * fit.target_p95 << " mm" << (fit.confident ? "" : " (POOR FIT)") << "\n";
  for (int j = 0; j < kNumJoints; ++j)
    std::cout << "  " << std::left << std::setw(16) << joint_name(j) << std::right << std::setprecision(3) << fit.joints(j, 0)
              << " " << fit.joints(j, 1) << " " << fit.joints(j, 2) << " m\n";
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
      .option("model", "FILE", "trained model (.pkm) whose segmentation prior labels the representation")
      .option("unit", "U", "unit of the mesh: m, dm, cm, mm, or auto (its largest extent tells)", "auto")
      .output("out", "FILE", "mesh with vertex scalar 'part' (0..15); PLY keeps it for other tools")
      .output("joints", "FILE", "write the joint centres as JSON")
      .output("fitted", "FILE", "with --body-model: the fitted body (the template's vertices, in order) with vertex scalars "
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
  const BodyOrientation orientation =
      orient_body_input(&input, args.get("up"), args.get("forward"), args.positionals()[0], "segment");
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
    write_file_atomically(args.get("joints"), [&](std::ostream& o) { o << text; }, false);
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
  nlohmann::ordered_json s = {{"mesh", args.positionals()[0]}, {"seconds", seconds}, {"notes", result.notes},
                              {"normal_failures", seg.normal_failures}, {"relabelled_by_cleanup", seg.relabelled},
                              {"parts", parts}, {"joints", jj["joints"]},
                              {"checks", {{"ok", check.ok()}, {"problems", check.problems}}}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "segmented " << args.positionals()[0] << " into " << present << " parts (of " << kNumParts << ") in " << std::fixed << std::setprecision(3) << seconds
            << " s (" << seg.normal_failures << " triangles without a representation triangle facing the same way, "
            << seg.relabelled << " moved by the clean-up)\n";
  for (int j = 0; j < kNumJoints; ++j)
    std::cout << "  " << std::left << std::setw(16) << joint_name(j) << std::right << std::setprecision(3) << joints(j, 0)
              << " " << joints(j, 1) << " " << joints(j, 2) << " m\n";
  return 0;
}

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

namespace posekit::cli {
namespace {

nlohmann::ordered_json fit_summary_json(const PoseFitResult& r) {
  return {{"iterations", r.iterations}, {"seconds", r.seconds},
          {"target_to_body_mm", {{"mean", 1000 * r.target_mean}, {"p95", 1000 * r.target_p95}}},
          {"coverage_1cm", r.coverage}, {"warnings", r.warnings}};
}

/// Angle (degrees) between two poses' rotations: the root's, then each joint's.
std::vector<double> joint_angle_errors(const PartPose& a, const PartPose& b) {
  std::vector<double> out{rotation_difference(a.root_rotation, b.root_rotation) * 180 / M_PI};
  for (int j = 0; j < kNumJoints; ++j)
    out.push_back(rotation_difference(a.joint_rotation[static_cast<size_t>(j)], b.joint_rotation[static_cast<size_t>(j)]) * 180 / M_PI);
  return out;
}

}  // namespace

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
  args.option("model", "FILE", "trained model (.pkm, posekit train)")
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
      .example("posekit fit --model model.pkm --subject ds/subjects/f01/rest.ply --target ds/scans/f01/squat_half.pcd "
               "--out fitted.ply --pose-out pose.json");
  args.option("target-up", "AXIS", "the axis the target stands along (+X, -Y, ...) or auto (detected); its heading is fitted", "auto");
  add_body_model_options(&args);
  add_orientation_options(&args, "", "the subject");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"model", "subject", "target"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  const auto model = std::make_shared<const PoseModel>(read_pose_model(args.get("model")));
  BodyOrientation orientation;
  BodyUnit unit;
  const TriangleMesh subject = read_posing_subject(args, "fit", &orientation, &unit);
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
    fitted.V = r.V * target_to_fit;  // back in the target's axes, to overlay the scan
    fitted.N.resize(0, 3);
    fitted.vertex_scalars["residual_mm"] = 1000 * r.residual;
    fitted.vertex_scalars["part"] = synth.vertex_parts().cast<double>();
    write_mesh(args.get("out"), fitted);
  }
  nlohmann::ordered_json s = fit_summary_json(r);
  s["pose"] = nlohmann::json::parse(part_pose_to_json(r.pose));
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(1) << "fitted in " << r.iterations << " iterations, " << std::setprecision(2)
            << r.seconds << " s: target to body mean " << std::setprecision(1) << 1000 * r.target_mean << " mm, 95th percentile "
            << 1000 * r.target_p95 << " mm; " << 100 * r.coverage << "% of the body within 1 cm of the target\n";
  for (int j = 0; j < kNumJoints; ++j) {
    const Eigen::Vector3d& v = r.pose.joint_rotation[static_cast<size_t>(j)];
    if (v.norm() > 5 * M_PI / 180)
      std::cout << "  " << joint_name(j) << ": " << std::setprecision(0) << v.norm() * 180 / M_PI << " degrees\n";
  }
  return 0;
}

int run_eval_fit(int argc, char** argv) {
  ArgParser args("eval fit",
                 "posekit fit on a dataset's simulated scans of posed subjects (holes, noise, outliers), against the\n"
                 "poses and posed meshes that made them: joint angle error, per-vertex error against the true posed\n"
                 "mesh, target-to-body distance and time, for the learned and the LBS posing in the loop.");
  args.option("dataset", "DIR", "a posekit dataset")
      .option("model", "FILE", "trained model (.pkm)")
      .option("subjects", "N", "the first N subjects (0: all)", "0")
      .flag("from-truth", "start every fit at the true pose instead of searching: what the objective itself gives")
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset") || !args.has("model")) throw UsageError("--dataset DIR and --model FILE are required");
  const bool from_truth = args.flag_set("from-truth");
  const std::string dir = args.get("dataset");
  const auto model = std::make_shared<const PoseModel>(read_pose_model(args.get("model")));
  const auto manifest = nlohmann::json::parse(read_file_bytes(dir + "/manifest.json"));
  const long limit = args.get_int("subjects");
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  struct Sums { std::vector<double> angle, vertex, target, seconds; };
  std::map<std::string, Sums> sums;
  int done = 0;
  Progress progress("eval fit", limit > 0 ? limit : static_cast<long>(manifest["subjects"].size()));
  for (const auto& s : manifest["subjects"]) {
    if (limit > 0 && done >= limit) break;
    const std::string id = s["id"];
    const TriangleMesh subject = load_subject_mesh(dir + "/" + s["rest"].get<std::string>());
    const PoseSynthesizer synth(model, subject);
    for (const auto& p : s.value("posed", nlohmann::json::array())) {
      const std::string pose_name = p["pose"];
      const std::string scan = dir + "/scans/" + id + "/" + pose_name + ".pcd";
      if (!fs::is_regular_file(scan)) continue;
      const PointCloud cloud = load_scan(scan);
      const PartPose truth = read_part_pose(dir + "/" + p["pose_json"].get<std::string>());
      const TriangleMesh truth_mesh = read_mesh(dir + "/" + p["mesh"].get<std::string>());
      for (PoseMethod method : {PoseMethod::kLearned, PoseMethod::kLbs}) {
        PoseFitOptions o;
        o.method = method;
        if (from_truth) o.start = truth;
        const PoseFitResult r = fit_pose(synth, cloud.P, o);
        const std::vector<double> angles = joint_angle_errors(r.pose, truth);
        const double angle_mean = std::accumulate(angles.begin(), angles.end(), 0.0) / static_cast<double>(angles.size());
        const double angle_max = *std::max_element(angles.begin(), angles.end());
        nlohmann::ordered_json per_joint = {{"root", angles[0]}};
        for (int j = 0; j < kNumJoints; ++j) per_joint[joint_name(j)] = angles[static_cast<size_t>(j + 1)];
        const double vertex = (r.V - truth_mesh.V).rowwise().norm().mean();
        Sums& a = sums[pose_method_name(method)];
        a.angle.push_back(angle_mean);
        a.vertex.push_back(1000 * vertex);
        a.target.push_back(1000 * r.target_mean);
        a.seconds.push_back(r.seconds);
        rows.push_back({{"subject", id}, {"pose", pose_name}, {"method", pose_method_name(method)},
                        {"joint_angle_error_deg", {{"mean", angle_mean}, {"max", angle_max}, {"per_joint", per_joint}}},
                        {"vertex_error_mm", 1000 * vertex}, {"fit", fit_summary_json(r)}});
      }
    }
    progress.update(++done);
  }
  progress.finish();
  auto mean = [](const std::vector<double>& v) {
    double t = 0;
    for (double x : v) t += x;
    return v.empty() ? 0.0 : t / static_cast<double>(v.size());
  };
  nlohmann::ordered_json summary = nlohmann::ordered_json::object();
  for (const auto& [method, a] : sums)
    summary[method] = {{"scans", a.angle.size()}, {"joint_angle_error_deg_mean", mean(a.angle)},
                       {"vertex_error_mm_mean", mean(a.vertex)}, {"target_to_body_mm_mean", mean(a.target)},
                       {"seconds_median", stats_of(a.seconds).median}, {"seconds_max", stats_of(a.seconds).max}};
  if (args.flag_set("json")) {
    print_json({{"dataset", dir}, {"summary", summary}, {"fits", rows}});
    return 0;
  }
  std::cout << std::fixed << std::setprecision(2)
            << "| posing in the loop | scans | joint angle error, mean deg | vertex error vs truth, mean mm | scan to body, mean mm | s per scan (median / max) |\n"
               "|---|---|---|---|---|---|\n";
  for (const auto& [method, a] : sums)
    std::cout << "| " << method << " | " << a.angle.size() << " | " << mean(a.angle) << " | " << mean(a.vertex) << " | "
              << mean(a.target) << " | " << stats_of(a.seconds).median << " / " << stats_of(a.seconds).max << " |\n";
  return 0;
}

}  // namespace posekit::cli
