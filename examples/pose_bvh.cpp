// Poses a customized body along a BVH motion with a trained pose model (posekit train): rigid part
// rotations plus the learned non-rigid deformation (Eq. 1, 5-6). Writes one PLY per frame.
//   pose_bvh model.pkm subject.ply motion.bvh out_prefix [frames]
// A BVH of MakeHuman's skeleton is read onto its rig (found under POSEKIT_DATA or the default data
// root); any other humanoid skeleton (CMU's, Mixamo's) is retargeted to the subject's joints.
#include <algorithm>
#include <iostream>
#include <memory>
#include <string>

#include "posekit/core/error.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_sequence.h"
#include "posekit/deformation/pose_synthesis.h"
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
    const posekit::PoseSynthesizer synth(model, subject);  // segmentation, skeleton, correspondence
    posekit::PoseSequenceOptions frames;
    frames.last = static_cast<int>(std::min<long>(argc == 6 ? std::stol(argv[5]) : 3, motion.num_frames()));
    const posekit::PoseSequence poses = posekit::load_pose_sequence(argv[3], synth.info().joint_centres, frames, &motion);
    posekit::TriangleMesh posed;
    posed.F = subject.F;
    for (size_t i = 0; i < poses.poses.size(); ++i) {
      synth.pose(poses.poses[i], posekit::PoseMethod::kLearned, &posed.V);
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
