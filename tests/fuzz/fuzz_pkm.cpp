// libFuzzer target: the .pkm pose model reader. Most mutants of a version 3 seed fail its checksum;
// the version 2 seed (no checksum) lets mutations reach the counts and values behind it.
#include "fuzz_input.h"
#include "posekit/deformation/pose_model.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = posekit::fuzz::write_input(data, size, ".pkm");
  posekit::fuzz::expect_clean([&] { (void)posekit::read_pose_model(path); });
  return 0;
}
