#pragma once
// A small software rasterizer: depth, triangle-id and shaded buffers of a mesh seen by a pinhole
// camera. Needs no display; used for simulated scans and photos.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// OpenCV-style pinhole camera: x_cam = R x_world + t, looking along +z_cam, x right, y down.
struct PinholeCamera {
  int width = 0, height = 0;              ///< pixels
  double fx = 0, fy = 0, cx = 0, cy = 0;  ///< pixels
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();  ///< m

  Eigen::Vector3d centre() const { return -R.transpose() * t; }
  /// Unit ray direction (world) through pixel coordinates (u, v).
  Eigen::Vector3d ray(double u, double v) const;
  /// A camera at `eye` looking at `target`, `up` roughly up in the image, focal length in pixels.
  static PinholeCamera look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up, int width, int height,
                               double focal_px);
};

struct RenderBuffers {
  int width = 0, height = 0;
  std::vector<float> depth;        ///< z_cam of the nearest surface (m), +inf where empty
  std::vector<int> face;           ///< nearest triangle, -1 where empty
  std::vector<std::uint8_t> gray;  ///< Lambert shading with a headlight on `background`
  int covered() const;             ///< pixels showing the mesh
};

/// Rasterizes every triangle in front of the camera (z > 1 cm), nearest wins.
RenderBuffers render_mesh(const TriangleMesh& mesh, const PinholeCamera& camera, std::uint8_t background = 235);

/// Camera as JSON (intrinsics K, extrinsics R and t, image size, conventions).
std::string camera_to_json(const PinholeCamera& camera);

/// Writes an 8-bit single-channel image as PNG (atomically). Throws IoError.
void write_gray_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& pixels);
/// Reads an 8-bit PNG as gray. Throws IoError naming the file.
std::vector<std::uint8_t> read_gray_png(const std::string& path, int* width, int* height);

}  // namespace posekit
