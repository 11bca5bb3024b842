#include "posekit/customization/silhouette.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/core/plugin.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/io/image_io.h"

namespace posekit {

int Silhouette::area() const {
  return static_cast<int>(std::count_if(mask.begin(), mask.end(), [](std::uint8_t v) { return v != 0; }));
}

namespace {

/// The first row (from the top or the bottom) with a person pixel.
int first_row(const Silhouette& s, bool from_top) {
  for (int k = 0; k < s.height; ++k) {
    const int v = from_top ? k : s.height - 1 - k;
    const auto row = s.mask.begin() + static_cast<std::ptrdiff_t>(v) * s.width;
    if (std::any_of(row, row + s.width, [](std::uint8_t x) { return x != 0; })) return v;
  }
  return -1;
}

/// The first column (from the left or the right) with a person pixel, read row by row (each row
/// only as far as the best found so far).
int first_column(const Silhouette& s, bool from_left) {
  int best = s.width;  // columns from the side searched
  for (int v = 0; v < s.height; ++v) {
    const std::uint8_t* row = s.mask.data() + static_cast<size_t>(v) * s.width;
    for (int k = 0; k < best; ++k)
      if (row[from_left ? k : s.width - 1 - k]) {
        best = k;
        break;
      }
  }
  return best == s.width ? -1 : from_left ? best : s.width - 1 - best;
}

}  // namespace

int Silhouette::top() const { return first_row(*this, true); }
int Silhouette::bottom() const { return first_row(*this, false); }
int Silhouette::left() const { return first_column(*this, true); }
int Silhouette::right() const { return first_column(*this, false); }

void check_silhouette(const Silhouette& s, const std::string& what, double min_area_fraction) {
  static auto* const check = plugin_function<void(const Silhouette&, const std::string&, double)>("photo", "posekit_check_silhouette");
  check(s, what, min_area_fraction);
}

Silhouette silhouette_from_pixels(int width, int height, int channels, const std::uint8_t* pixels, const std::string& what,
                                  const SilhouetteOptions& o) {
  using FromPixels = void(int, int, int, const std::uint8_t*, const std::string&, const SilhouetteOptions&, Silhouette*);
  static auto* const from_pixels = plugin_function<FromPixels>("photo", "posekit_silhouette_from_pixels");
  Silhouette s;
  from_pixels(width, height, channels, pixels, what, o, &s);
  return s;
}

Silhouette silhouette_from_render(const RenderBuffers& b) {
  Silhouette s;
  s.width = b.width, s.height = b.height;
  s.mask.resize(b.face.size());
  for (size_t k = 0; k < b.face.size(); ++k) s.mask[k] = b.face[k] >= 0 ? 255 : 0;
  return s;
}

Silhouette silhouette_from_photo(const std::string& path, const std::string& what, const SilhouetteOptions& o) {
  using FromPhoto = void(const std::string&, const std::string&, const SilhouetteOptions&, Silhouette*);
  static auto* const from_photo = plugin_function<FromPhoto>("photo", "posekit_silhouette_from_photo");
  Silhouette s;
  from_photo(path, what + " '" + path + "'", o, &s);
  return s;
}

Silhouette read_silhouette_mask(const std::string& path, const std::string& what) {
  using ReadMask = void(const std::string&, const std::string&, Silhouette*);
  static auto* const read_mask = plugin_function<ReadMask>("photo", "posekit_read_silhouette_mask");
  Silhouette s;
  read_mask(path, what, &s);
  return s;
}

void write_silhouette_png(const std::string& path, const Silhouette& s) { write_png(path, Image8{s.width, s.height, 1, s.mask}); }

PhotoCameras read_photo_cameras(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError("cannot open camera file '" + path + "'");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw InvalidInput("camera file '" + path + "': not JSON (" + e.what() + ")");
  }
  PhotoCameras out;
  for (const char* view : {"front", "side"}) {
    const std::string where = "camera file '" + path + "', \"" + view + "\"";
    if (!j.contains(view) || !j[view].is_object()) throw InvalidInput(where + ": missing");
    const auto& c = j[view];
    PinholeCamera cam;
    try {
      cam.width = c.at("width").get<int>();
      cam.height = c.at("height").get<int>();
      const auto& K = c.at("K");
      cam.fx = K.at(0).at(0).get<double>(), cam.cx = K.at(0).at(2).get<double>();
      cam.fy = K.at(1).at(1).get<double>(), cam.cy = K.at(1).at(2).get<double>();
      for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) cam.R(r, k) = c.at("R").at(r).at(k).get<double>();
        cam.t[r] = c.at("t").at(r).get<double>();
      }
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput(where + ": expected width, height, K (3x3), R (3x3), t (3): " + e.what());
    }
    if (cam.width <= 0 || cam.height <= 0 || !(cam.fx > 0) || !(cam.fy > 0))
      throw InvalidInput(where + ": image size and focal lengths must be positive");
    if ((cam.R * cam.R.transpose() - Eigen::Matrix3d::Identity()).norm() > 1e-3 || cam.R.determinant() < 0)
      throw InvalidInput(where + ": R is not a rotation");
    (std::string(view) == "front" ? out.front : out.side) = cam;
  }
  return out;
}

PhotoCameras cameras_from_stature(const Silhouette& front, const Silhouette& side, double stature, double distance, double focal_px) {
  if (!(stature > 0.5 && stature < 2.6)) throw InvalidInput("stated height " + std::to_string(stature) + " m: expected 0.5 to 2.6 m");
  if (!(distance > 0.5)) throw InvalidInput("camera distance must be over 0.5 m");
  PhotoCameras out;
  std::ostringstream note;
  const bool derived_focal = focal_px <= 0;
  if (derived_focal) {
    const int pixels = front.bottom() - front.top() + 1;
    focal_px = pixels * distance / stature;
    note << "focal length " << std::lround(focal_px) << " px, from the stated height " << stature << " m at " << distance << " m";
  } else {
    note << "focal length " << focal_px << " px (given)";
  }
  out.assumed.push_back(note.str());
  out.assumed.push_back("both cameras level, " + std::to_string(distance).substr(0, 4) +
                        " m from the person, principal point at the image centre");
  if (front.width != side.width || front.height != side.height)
    out.assumed.push_back("the photos differ in size (" + std::to_string(front.width) + "x" + std::to_string(front.height) + " and " +
                          std::to_string(side.width) + "x" + std::to_string(side.height) + "): the same lens assumed for both");
  const Eigen::Vector3d centre(0, 0, 0);
  auto place = [&](double f) {
    out.front = PinholeCamera::look_at(Eigen::Vector3d(0, 0, distance), centre, Eigen::Vector3d::UnitY(), front.width, front.height, f);
    out.side = PinholeCamera::look_at(Eigen::Vector3d(distance, 0, 0), centre, Eigen::Vector3d::UnitY(), side.width, side.height, f);
  };
  place(focal_px);
  if (derived_focal) {
    // The silhouette's height in pixels includes perspective (the toes nearer the camera than the
    // crown): the focal length is corrected until the photos' own stature is the stated one.
    for (int k = 0; k < 3; ++k) {
      focal_px *= find_photo_landmarks(front, side, out).stature / stature;
      place(focal_px);
    }
    std::ostringstream note;
    note << "focal length " << std::lround(focal_px) << " px, from the stated height " << stature << " m at " << distance << " m";
    out.assumed.front() = note.str();
  }
  return out;
}

Eigen::Vector2d project(const PinholeCamera& c, const Eigen::Vector3d& x) {
  const Eigen::Vector3d p = c.R * x + c.t;
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

Eigen::Vector3d point_at_depth(const PinholeCamera& c, double u, double v, double depth) {
  const Eigen::Vector3d r = c.ray(u, v);
  return c.centre() + r * (depth / r.dot(c.R.row(2).transpose()));
}

double depth_of(const PinholeCamera& c, const Eigen::Vector3d& x) { return (c.R * x + c.t).z(); }

}  // namespace posekit
