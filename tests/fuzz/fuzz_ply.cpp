// libFuzzer target: the PLY reader, as a mesh and as a point cloud.
#include "fuzz_input.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = posekit::fuzz::write_input(data, size, ".ply");
  posekit::fuzz::expect_clean([&] { posekit::read_mesh(path); });
  posekit::fuzz::expect_clean([&] { posekit::read_point_cloud(path); });
  return 0;
}
