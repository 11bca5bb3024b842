// Measures a standing body: a mesh (PLY/OBJ/OFF/STL) or a point cloud (PLY/PCD/XYZ), Y up, in
// metres or millimetres (told from its height). Prints the stature and every girth in cm.
//   measure_scan body.ply
#include <iomanip>
#include <iostream>

#include "posekit/core/error.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/shape/measurements.h"
#include "posekit/version.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: measure_scan <mesh or point cloud>   (posekit " << posekit::version() << ")\n";
    return 2;
  }
  try {
    const std::string path = argv[1];
    posekit::TriangleMesh mesh;
    bool is_mesh = posekit::mesh_format_from_path(path) != posekit::MeshFormat::kAuto;
    if (is_mesh) {
      try {
        mesh = posekit::read_mesh(path);
      } catch (const posekit::IoError&) {
        is_mesh = false;  // no faces (a scan's points), or unreadable: tried as a point cloud
      }
    }
    Eigen::MatrixXd points = is_mesh ? mesh.V : posekit::read_point_cloud(path).P;
    const double height = points.col(1).maxCoeff() - points.col(1).minCoeff();
    if (height > 100) points *= 0.001;  // millimetres
    const posekit::BodyMeasurements m = is_mesh ? posekit::measure_body(points, mesh.F) : posekit::measure_point_cloud(points);
    std::cout << std::fixed << std::setprecision(1) << "stature " << 100 * m.stature << " cm\n";
    for (const posekit::Girth& g : m.girths) {
      std::cout << "  " << std::setw(10) << std::left << g.name << std::right;
      if (g.measured) std::cout << std::setw(7) << 100 * g.value << " cm\n";
      else std::cout << "   not measured: " << g.note << "\n";
    }
    return 0;
  } catch (const posekit::Error& e) {
    std::cerr << "measure_scan: " << e.what() << "\n";
    return 1;
  }
}
