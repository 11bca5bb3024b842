// libFuzzer target: measuring a body, as `posekit measure` does: a small body as a PLY (a mesh, or a
// cloud when it has no faces), its unit told by its extent, its orientation detected, then its
// stature and girths. Seeds: small MakeHuman bodies (Measurements.WritesFuzzSeeds...).
#include "fuzz_input.h"
#include "posekit/core/units.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/measurements.h"

namespace {

void measure_file(const std::string& path) {
  posekit::TriangleMesh mesh;
  posekit::PointCloud cloud;
  bool is_cloud = false;
  try {
    mesh = posekit::read_mesh(path);
  } catch (const posekit::IoError& e) {
    if (std::string(e.what()).find("no faces") == std::string::npos) throw;
    cloud = posekit::read_point_cloud(path);
    is_cloud = true;
  }
  Eigen::MatrixXd& P = is_cloud ? cloud.P : mesh.V;
  posekit::Unit unit;
  if (!posekit::guess_body_unit(posekit::robust_largest_extent(P), &unit)) return;  // measure refuses it
  P *= posekit::metres_per_unit(unit);
  const posekit::BodyOrientation o = is_cloud ? posekit::detect_body_orientation(P) : posekit::detect_mesh_orientation(mesh.V, mesh.F);
  P = (P * o.rotation.transpose()).eval();
  if (is_cloud) (void)posekit::measure_point_cloud(P);
  else (void)posekit::measure_body(mesh.V, mesh.F);
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = posekit::fuzz::write_input(data, size, ".ply");
  posekit::fuzz::expect_clean([&] { measure_file(path); });
  return 0;
}
