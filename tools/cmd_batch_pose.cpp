// posekit batch pose: many subjects posed by one trained model into a pose or a BVH's frames.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "batch.h"
#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/checksum.h"
#include "posekit/io/mesh_io.h"
#include "posekit/segmentation/segmentation.h"
#include "posing_inputs.h"

namespace posekit::cli::batch {
namespace fs = std::filesystem;

std::vector<BatchColumn> pose_columns() {
  return {{"unit", [](const auto& r) { return r["unit"].template get<std::string>(); }},
          {"up", [](const auto& r) { return r["up"].template get<std::string>(); }},
          {"forward", [](const auto& r) { return r["forward"].template get<std::string>(); }},
          {"vertices", [](const auto& r) { return std::to_string(r["vertices"].template get<long>()); }},
          {"poses", [](const auto& r) { return std::to_string(r["poses"].template get<long>()); }},
          {"first_file", [](const auto& r) { return r["files"].empty() ? std::string() : r["files"][0].template get<std::string>(); }}};
}

int run_batch_pose(int argc, char** argv) {
  ArgParser args(
      "batch pose",
      std::string(
          "Poses many bodies with one trained model (posekit pose): each subject mesh is segmented and\n"
          "set up once, then put into every pose of --pose (a pose JSON, or the frames of a BVH: MakeHuman's\n"
          "skeleton, or any humanoid one retargeted to each subject's joints). The posed meshes go to OUT/posed/<input>/<pose>.<format> "
          "(listed relative to OUT), in\n"
          "the subject file's frame and unit, with the vertex scalar 'part'. One result per subject in OUT/results, OUT/summary.json\n"
          "and summary.csv; set-up and posing times in OUT/run*.json.") +
          kBatchCommon);
  args.option("inputs", "DIR|LIST", "a folder of subject meshes (recursively, in sorted order) or a text file of paths")
      .pose_model_option()
      .option("pose", "FILE", "pose.json (16-part pose) or a motion capture .bvh (any humanoid skeleton, retargeted; see --joint-map)")
      .option("method", "M", "learned (the paper's), rigid (parts only) or lbs (16-part skinning)", "learned")
      .option("frames", "A:B", "BVH frames A to B-1 (default: all)")
      .option("format", "EXT", "posed mesh format: ply, obj or off", "ply")
      .data_option("for the BVH skeleton")
      .option("joint-map", "FILE", "JSON {\"left_shoulder\": \"<BVH joint>\", ...} for BVH joints the names do not tell")
      .option("root-motion", "M", "a retargeted BVH's root translation: none, vertical (feet stay down) or all", "vertical");
  add_batch_options(&args);
  args.example("posekit batch pose --inputs subjects.txt --model model.pkm --pose squat.json --out posed --jobs 2");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"inputs", "model", "pose", "out"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  const std::string format = args.get("format");
  if (format != "ply" && format != "obj" && format != "off") throw UsageError("--format expects ply, obj or off, got '" + format + "'");
  const PoseMethod method = parse_pose_method(args.get("method"));
  const auto model = read_posing_model(args.get("model"), "batch pose");
  const std::uint32_t model_crc = file_crc32(args.get("model"));  // a retrained model redoes every subject
  const std::string pose_path = args.get("pose");
  const std::string frames = args.has("frames") ? args.get("frames") : "", data = args.has("data") ? args.get("data") : "";
  const std::string joint_map = args.has("joint-map") ? args.get("joint-map") : "", root_motion = args.get("root-motion");
  // Pose JSONs and MakeHuman's BVHs are the same for every subject: loaded once. Other BVHs are
  // retargeted to each subject's own joints.
  std::string ext = fs::path(pose_path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  BvhMotion motion;
  if (ext == ".bvh") motion = read_bvh(pose_path, Unit::kMetre, io_warnings());
  const bool per_subject = ext == ".bvh" && motion.find_joint("upperarm01.L") < 0;
  LoadedPoses shared;
  if (!per_subject) shared = load_poses(pose_path, frames, data, Eigen::MatrixXd(), "", root_motion, ext == ".bvh" ? &motion : nullptr);
  else
    (void)load_poses(pose_path, frames, data, Eigen::MatrixXd::Zero(kNumJoints, 3), joint_map, root_motion,
                     &motion);  // bad input fails once, not per subject
  const fs::path posed_dir = fs::path(args.get("out")) / "posed";
  std::mutex timing_mutex;
  std::vector<double> setup_seconds, pose_ms;
  BatchJob job;
  job.command = "pose";
  job.settings = {
      {"model", args.get("model")}, {"model_checksum", model_crc},        {"pose", pose_path}, {"frames", frames}, {"joint_map", joint_map},
      {"root_motion", root_motion}, {"method", pose_method_name(method)}, {"format", format}};
  job.process = [&](const std::string& input, const std::string& stem) {
    PreparedBody subject = prepare_body(input, "auto");
    if (subject.in.is_cloud) throw InvalidInput(input + ": the subject must be a mesh (triangles); this file has only points");
    const TriangleMesh& mesh = subject.in.mesh;
    const MeshReport report = validate_mesh(mesh);
    if (report.components != 1)
      throw InvalidInput(input + ": the subject mesh has " + std::to_string(report.components) +
                         " connected components; posing needs one connected body");
    std::vector<std::string> warnings = subject.warnings;
    if (report.boundary_loops > 0) warnings.push_back(std::to_string(report.boundary_loops) + " holes: features near them may be off");
    const Stopwatch t0;
    const PoseSynthesizer synth = set_up_subject(model, mesh, input);
    const double setup = t0.seconds();
    for (const auto& problem : synth.info().skeleton_problems) warnings.push_back("the skeleton looks wrong: " + problem);
    const fs::path dir = posed_dir / stem;
    create_folders(dir.string());
    TriangleMesh posed;
    posed.F = mesh.F;
    posed.vertex_scalars["part"] = vertex_labels_from_triangles(mesh.V, mesh.F, synth.info().triangle_part).cast<double>();
    nlohmann::ordered_json files = nlohmann::ordered_json::array();
    const Stopwatch t1;
    const LoadedPoses own =
        per_subject ? load_poses(pose_path, frames, data, synth.info().joint_centres, joint_map, root_motion, &motion) : LoadedPoses{};
    const LoadedPoses& poses = per_subject ? own : shared;
    for (size_t k = 0; k < poses.poses.size(); ++k) {
      const std::string& name = poses.names[k];
      const PartPose& pose = poses.poses[k];
      synth.pose(pose, method, &posed.V);
      if (!subject.orientation.is_identity()) posed.V = in_file_frame(subject.orientation, posed.V);
      const std::string path = (dir / (name + "." + format)).string();
      std::vector<std::string> io;
      write_mesh(path, posed, {subject.unit, MeshFormat::kAuto, true, &io});
      warnings.insert(warnings.end(), io.begin(), io.end());
      files.push_back((fs::path("posed") / stem / (name + "." + format)).string());  // relative to OUT: the summary moves with it
    }
    const double posing = t1.seconds();
    {
      std::lock_guard<std::mutex> lock(timing_mutex);
      setup_seconds.push_back(setup);
      pose_ms.push_back(1000 * posing / static_cast<double>(poses.poses.size()));
    }
    nlohmann::ordered_json r = {{"unit", unit_name(subject.unit)},
                                {"up", axis_name(subject.orientation.up())},
                                {"forward", axis_name(subject.orientation.forward())},
                                {"vertices", mesh.V.rows()},
                                {"poses", poses.poses.size()},
                                {"normal_failures", synth.info().normal_failures},
                                {"files", files},
                                {"warnings", warnings}};
    return r;
  };
  job.columns = pose_columns();
  const int status = run_batch_job(args, job, list_inputs(args.get("inputs")));
  if (!setup_seconds.empty() && !args.flag_set("json")) {
    const Stats s = stats_of(setup_seconds), p = stats_of(pose_ms);
    std::cout << "  per subject: set-up median " << std::setprecision(3) << s.median << " s (" << s.min << " to " << s.max
              << "), posing median " << std::setprecision(2) << p.median << " ms per pose\n";
  }
  return status;
}

}  // namespace posekit::cli::batch
