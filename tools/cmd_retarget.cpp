// posekit retarget: the frames of any humanoid BVH as 16-part pose JSONs (body/bvh_retarget.h).
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/skinning.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace fs = std::filesystem;

namespace posekit::cli {

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
  const LoadedPoses loaded =
      load_poses(args.positionals()[0], args.has("frames") ? args.get("frames") : "", args.has("data") ? args.get("data") : "", rest,
                 args.has("joint-map") ? args.get("joint-map") : "", args.get("root-motion"));
  for (const auto& note : loaded.notes) std::cerr << "posekit retarget: " << note << "\n";
  create_folders(args.get("out"));
  std::vector<std::string> written;
  for (size_t i = 0; i < loaded.poses.size(); i += static_cast<size_t>(every)) {
    const std::string path = (fs::path(args.get("out")) / (loaded.names[i] + ".json")).string();
    validate_part_pose(loaded.poses[i], path);
    write_file_atomically(path, [&](std::ostream& out) { out << part_pose_to_json(loaded.poses[i]); });
    written.push_back(path);
  }
  nlohmann::ordered_json s = {
      {"bvh", args.positionals()[0]}, {"frames", loaded.poses.size()}, {"written", written.size()}, {"mapping", loaded.notes}};
  if (args.flag_set("json")) {
    print_json(s);
    return 0;
  }
  std::cout << "retargeted " << loaded.poses.size() << " frames of " << args.positionals()[0] << "; wrote " << written.size()
            << " pose files to " << args.get("out") << "\n";
  return 0;
}

}  // namespace posekit::cli
