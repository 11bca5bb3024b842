#include "posekit/core/rasterizer.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"

namespace posekit {

int RenderBuffers::covered() const {
  return static_cast<int>(std::count_if(face.begin(), face.end(), [](int f) { return f >= 0; }));
}

RenderBuffers render_mesh(const TriangleMesh& mesh, const PinholeCamera& cam, std::uint8_t background) {
  if (cam.width <= 0 || cam.height <= 0 || cam.fx <= 0 || cam.fy <= 0) throw InvalidInput("render_mesh: bad camera");
  RenderBuffers out;
  out.width = cam.width;
  out.height = cam.height;
  const size_t n = static_cast<size_t>(cam.width) * cam.height;
  out.depth.assign(n, std::numeric_limits<float>::infinity());
  out.face.assign(n, -1);
  out.gray.assign(n, background);
  const Eigen::MatrixXd Vc = (mesh.V * cam.R.transpose()).rowwise() + cam.t.transpose();
  Eigen::MatrixXd uv(Vc.rows(), 2);
  for (Eigen::Index i = 0; i < Vc.rows(); ++i) {
    uv(i, 0) = cam.fx * Vc(i, 0) / Vc(i, 2) + cam.cx;
    uv(i, 1) = cam.fy * Vc(i, 1) / Vc(i, 2) + cam.cy;
  }
  constexpr double kNear = 0.01;
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int a = mesh.F(f, 0), b = mesh.F(f, 1), c = mesh.F(f, 2);
    if (Vc(a, 2) < kNear || Vc(b, 2) < kNear || Vc(c, 2) < kNear) continue;
    const double ax = uv(a, 0), ay = uv(a, 1), bx = uv(b, 0), by = uv(b, 1), cx = uv(c, 0), cy = uv(c, 1);
    const double area = (bx - ax) * (cy - ay) - (by - ay) * (cx - ax);
    if (std::abs(area) < 1e-12) continue;
    const int x0 = std::max(0, static_cast<int>(std::floor(std::min({ax, bx, cx}) - 0.5)));
    const int x1 = std::min(cam.width - 1, static_cast<int>(std::ceil(std::max({ax, bx, cx}) - 0.5)));
    const int y0 = std::max(0, static_cast<int>(std::floor(std::min({ay, by, cy}) - 0.5)));
    const int y1 = std::min(cam.height - 1, static_cast<int>(std::ceil(std::max({ay, by, cy}) - 0.5)));
    const double iza = 1.0 / Vc(a, 2), izb = 1.0 / Vc(b, 2), izc = 1.0 / Vc(c, 2);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const double px = x + 0.5, py = y + 0.5;
        const double w0 = ((bx - px) * (cy - py) - (by - py) * (cx - px)) / area;
        const double w1 = ((cx - px) * (ay - py) - (cy - py) * (ax - px)) / area;
        const double w2 = 1.0 - w0 - w1;
        if (w0 < 0 || w1 < 0 || w2 < 0) continue;
        const float z = static_cast<float>(1.0 / (w0 * iza + w1 * izb + w2 * izc));
        const size_t k = static_cast<size_t>(y) * cam.width + x;
        if (z < out.depth[k]) {
          out.depth[k] = z;
          out.face[k] = static_cast<int>(f);
        }
      }
  }
  const Eigen::MatrixXd N = face_normals(mesh.V, mesh.F);
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const size_t k = static_cast<size_t>(y) * cam.width + x;
      if (out.face[k] < 0) continue;
      const double lambert = std::abs(N.row(out.face[k]).dot(cam.ray(x + 0.5, y + 0.5)));
      out.gray[k] = static_cast<std::uint8_t>(40 + std::lround(185 * lambert));  // at most 225 < background
    }
  return out;
}

}  // namespace posekit
