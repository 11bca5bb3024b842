// Poses a customized body along a BVH motion with a trained pose model (posekit train): rigid part
// rotations plus the learned non-rigid deformation (Eq. 1, 5-6). Writes one PLY per frame.
//   pose_bvh model.pkm subject.ply motion.bvh out_prefix [frames]
// The BVH's skeleton is read onto MakeHuman's rig, found under POSEKIT_DATA (or the default data
// root).
#include <iostream>
#include <memory>
#include <string>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/skinning.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"

int main(int argc, char** argv) {
  if (argc < 5 || argc > 6) {
    std::cerr << "usage: pose_bvh model.pkm subject.ply motion.bvh out_prefix [frames]\n";
    return 2;
  }
  try {
    const auto model = std::make_shared<const posekit::PoseModel>(posekit::read_pose_model(argv[1]));
    const posekit::TriangleMesh subject = posekit::read_mesh(argv[2]);
    const posekit::BvhMotion motion = posekit::read_bvh(argv[3]);
    const long frames = std::min<long>(argc == 6 ? std::stol(argv[5]) : 3, motion.frames.rows());
    const auto makehuman = posekit::load_makehuman_model(posekit::find_data_root());
    const posekit::PoseSynthesizer synth(model, subject);  // segmentation, skeleton, correspondence
    posekit::TriangleMesh posed;
    posed.F = subject.F;
    for (long i = 0; i < frames; ++i) {
      const posekit::PartPose pose =
          posekit::part_pose_from_bone_pose(makehuman->rig, posekit::bone_pose_from_bvh(makehuman->rig, motion, static_cast<int>(i)));
      synth.pose(pose, posekit::PoseMethod::kLearned, &posed.V);
      const std::string out = std::string(argv[4]) + "_" + std::to_string(i) + ".ply";
      posekit::write_mesh(out, posed);
      std::cout << out << "\n";
    }
    return 0;
  } catch (const posekit::Error& e) {
    std::cerr << "pose_bvh: " << e.what() << "\n";
    return 1;
  }
}
