#include "posekit/datasets/scanner.h"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"

namespace posekit {

SimulatedScan simulate_scan(const TriangleMesh& mesh, const ScannerOptions& o) {
  if (o.views_around < 1 || o.heights.empty()) throw InvalidInput("simulate_scan: need at least one camera");
  const BoundingBox box = bounding_box(mesh.V);
  const double floor = box.min.y();
  const Eigen::Vector3d axis(box.center().x(), 0, box.center().z());
  const Eigen::MatrixXd N = face_normals(mesh.V, mesh.F);
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> noise(0.0, o.noise_sigma);
  SimulatedScan scan;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> view_of;
  for (size_t h = 0; h < o.heights.size(); ++h)
    for (int a = 0; a < o.views_around; ++a) {
      const double angle = (45.0 + 360.0 * a / o.views_around) * M_PI / 180.0;
      const double y = floor + o.heights[h];
      const Eigen::Vector3d eye = axis + Eigen::Vector3d(o.distance * std::sin(angle), y, o.distance * std::cos(angle));
      const Eigen::Vector3d target = axis + Eigen::Vector3d(0, y, 0);
      const PinholeCamera cam = PinholeCamera::look_at(eye, target, Eigen::Vector3d::UnitY(), o.width, o.height, o.focal_px);
      const RenderBuffers buf = render_mesh(mesh, cam);
      const int view = static_cast<int>(scan.cameras.size());
      scan.cameras.push_back(cam);
      for (int py = 0; py < buf.height; ++py)
        for (int px = 0; px < buf.width; ++px) {
          const int f = buf.face[static_cast<size_t>(py) * buf.width + px];
          if (f < 0) continue;
          const Eigen::Vector3d d = cam.ray(px + 0.5, py + 0.5);
          const Eigen::Vector3d n = N.row(f).transpose();
          const double cosine = n.dot(d);
          if (std::abs(cosine) < o.min_incidence_cos) continue;
          const double s = n.dot(mesh.V.row(mesh.F(f, 0)).transpose() - eye) / cosine;  // exact ray hit
          points.push_back(eye + (s + noise(rng)) * d);
          view_of.push_back(view);
        }
    }
  const size_t hits = points.size();
  scan.outliers = static_cast<int>(std::lround(o.outlier_fraction * static_cast<double>(hits)));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Eigen::Vector3d lo = box.min.array() - 0.2, span = box.extent().array() + 0.4;
  for (int i = 0; i < scan.outliers; ++i) {
    points.push_back(lo + Eigen::Vector3d(unit(rng), unit(rng), unit(rng)).cwiseProduct(span));
    view_of.push_back(-1);
  }
  scan.cloud.P.resize(static_cast<Eigen::Index>(points.size()), 3);
  Eigen::VectorXd view(points.size()), outlier(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    scan.cloud.P.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
    view[static_cast<Eigen::Index>(i)] = view_of[i];
    outlier[static_cast<Eigen::Index>(i)] = i >= hits ? 1.0 : 0.0;
  }
  scan.cloud.point_scalars["view"] = view;
  scan.cloud.point_scalars["outlier"] = outlier;
  return scan;
}

}  // namespace posekit
