#include "posekit/core/camera.h"

#include <Eigen/Geometry>
#include <iomanip>
#include <sstream>

namespace posekit {

Eigen::Vector3d PinholeCamera::ray(double u, double v) const {
  const Eigen::Vector3d d_cam((u - cx) / fx, (v - cy) / fy, 1.0);
  return (R.transpose() * d_cam).normalized();
}

PinholeCamera PinholeCamera::look_at(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up, int width,
                                     int height, double focal_px) {
  PinholeCamera c;
  c.width = width;
  c.height = height;
  c.fx = c.fy = focal_px;
  c.cx = width / 2.0;
  c.cy = height / 2.0;
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();  // image right
  const Eigen::Vector3d y = z.cross(x);                // image down
  c.R.row(0) = x.transpose();
  c.R.row(1) = y.transpose();
  c.R.row(2) = z.transpose();
  c.t = -c.R * eye;
  return c;
}

std::string camera_to_json(const PinholeCamera& c) {
  std::ostringstream o;
  o << std::setprecision(17) << "{\n  \"model\": \"pinhole\",\n  \"convention\": \"x_cam = R x_world + t; camera looks along +z, "
    << "x right, y down (OpenCV); world in metres, Y up, subject facing +Z\",\n  \"width\": " << c.width << ",\n  \"height\": " << c.height
    << ",\n  \"K\": [[" << c.fx << ", 0, " << c.cx << "], [0, " << c.fy << ", " << c.cy << "], [0, 0, 1]],\n  \"R\": [";
  for (int r = 0; r < 3; ++r) o << (r ? ", " : "") << "[" << c.R(r, 0) << ", " << c.R(r, 1) << ", " << c.R(r, 2) << "]";
  const Eigen::Vector3d e = c.centre();
  o << "],\n  \"t\": [" << c.t.x() << ", " << c.t.y() << ", " << c.t.z() << "],\n  \"centre\": [" << e.x() << ", " << e.y() << ", " << e.z()
    << "]\n}\n";
  return o.str();
}

}  // namespace posekit
