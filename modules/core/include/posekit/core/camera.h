#pragma once
// The pinhole camera of photos and renders (OpenCV's conventions).
#include <Eigen/Core>
#include <string>

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

/// Camera as JSON (intrinsics K, extrinsics R and t, image size, conventions).
std::string camera_to_json(const PinholeCamera& camera);

}  // namespace posekit
