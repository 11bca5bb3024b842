// posekit pose: a subject posed by the learned model (Eq. 3-6) from a pose JSON or a BVH motion.
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/io/mesh_io.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/shape/body_orientation.h"
#include "posing_inputs.h"

namespace fs = std::filesystem;

namespace posekit::cli {

int run_pose(int argc, char** argv) {
  ArgParser args("pose",
                 "Poses a customized body (any topology) with a trained model (section 3.3.3): its own\n"
                 "segmentation and skeleton give the rigid part rotations T^R, the template's learned T^Q is\n"
                 "carried over by the ct-FFD correspondence, and one prefactorised solve per pose gives the mesh.\n"
                 "A pose is a 16-part pose JSON or a BVH (one mesh per frame): MakeHuman's skeleton, or any humanoid\n"
                 "skeleton (CMU, Mixamo, ...) retargeted to the subject's joints.");
  args.pose_model_option()
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
      .example(
          "posekit pose --model model.pkm --subject out/dataset/subjects/f01/rest.ply --pose "
          "out/dataset/subjects/f01/posed/squat_half.json --out posed.ply")
      .example("posekit pose --model model.pkm --subject body.ply --pose cmu/01_01.bvh --frames 0:100 --out walk/frame.ply");
  add_body_model_options(&args, false);
  add_orientation_options(&args, "", "the subject");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"model", "subject", "pose", "out"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  const PoseMethod method = parse_pose_method(args.get("method"));
  const auto model = read_posing_model(args.get("model"), "pose");
  BodyOrientation orientation;
  BodyUnit unit;
  const TriangleMesh subject = read_posing_subject(args, "pose", &orientation, &unit);
  const Stopwatch t0;
  const PoseSynthesizer synth = set_up_subject(model, subject, args.get("subject"), subject_setup(args, subject));
  const double setup = t0.seconds();
  for (const auto& problem : synth.info().skeleton_problems)
    std::cerr << "warning: " << args.get("subject") << ": the subject's skeleton looks wrong: " << problem << "\n";
  const LoadedPoses loaded =
      load_poses(args.get("pose"), args.has("frames") ? args.get("frames") : "", args.has("data") ? args.get("data") : "",
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
  nlohmann::ordered_json s = {{"subject", args.get("subject")},
                              {"method", pose_method_name(method)},
                              {"poses", poses.size()},
                              {"setup_seconds", setup},
                              {"pose_ms_mean", 1000 * pose_seconds / static_cast<double>(poses.size())},
                              {"normal_failures", synth.info().normal_failures},
                              {"written", written},
                              {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "posed " << args.get("subject") << " (" << subject.num_vertices() << " vertices) in " << poses.size()
            << (poses.size() == 1 ? " pose" : " poses") << " by the " << pose_method_name(method) << " method: set-up " << std::fixed
            << std::setprecision(3) << setup << " s, " << std::setprecision(2) << 1000 * pose_seconds / static_cast<double>(poses.size())
            << " ms per pose, peak RSS " << std::setprecision(0) << peak_rss_mib() << " MiB; wrote " << written.front()
            << (written.size() > 1 ? " ..." : "") << "\n";
  return 0;
}

}  // namespace posekit::cli
