// libFuzzer target: the BVH motion reader, and forward kinematics of what it read.
#include "fuzz_input.h"
#include "posekit/io/bvh.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = posekit::fuzz::write_input(data, size, ".bvh");
  posekit::fuzz::expect_clean([&] {
    const posekit::BvhMotion motion = posekit::read_bvh(path);
    if (motion.num_frames() > 0) (void)motion.joint_positions(motion.num_frames() - 1);
  });
  return 0;
}
