#pragma once
// A small software rasterizer: depth, triangle-id and shaded buffers of a mesh seen by a pinhole
// camera. Needs no display; used for simulated scans and photos.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "posekit/core/camera.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct RenderBuffers {
  int width = 0, height = 0;
  std::vector<float> depth;        ///< z_cam of the nearest surface (m), +inf where empty
  std::vector<int> face;           ///< nearest triangle, -1 where empty
  std::vector<std::uint8_t> gray;  ///< Lambert shading with a headlight on `background`
  int covered() const;             ///< pixels showing the mesh
};

/// Rasterizes every triangle in front of the camera (z > 1 cm), nearest wins.
RenderBuffers render_mesh(const TriangleMesh& mesh, const PinholeCamera& camera, std::uint8_t background = 235);

}  // namespace posekit
