#include "posekit/customization/silhouette.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/io/image_io.h"

namespace posekit {
namespace {

constexpr int kBorder = 12;  // pixels of the frame that model the background

Silhouette from_mat(const cv::Mat& m) {
  Silhouette s;
  s.width = m.cols;
  s.height = m.rows;
  s.mask.assign(m.data, m.data + static_cast<size_t>(m.total()));
  return s;
}

/// The largest 8-connected component with its small holes filled (under 0.5% of its area: noise,
/// or a patch of skin as bright as the background); a larger enclosed patch of background (the gap
/// between a forearm and the waist) stays. `second` receives the area of the next largest component.
cv::Mat largest_component_filled(const cv::Mat& binary, int* second) {
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(binary, labels, stats, centroids, 8, CV_32S);
  int best = -1, best_area = 0, next_area = 0;
  for (int i = 1; i < n; ++i) {
    const int a = stats.at<int>(i, cv::CC_STAT_AREA);
    if (a > best_area) next_area = best_area, best_area = a, best = i;
    else next_area = std::max(next_area, a);
  }
  if (second) *second = next_area;
  cv::Mat out = cv::Mat::zeros(binary.size(), CV_8U);
  if (best < 0) return out;
  out.setTo(255, labels == best);
  // Holes: 4-connected background components that do not touch the frame.
  cv::Mat background = out == 0, hole_labels, hole_stats, hole_centroids;
  const int holes = cv::connectedComponentsWithStats(background, hole_labels, hole_stats, hole_centroids, 4, CV_32S);
  for (int i = 1; i < holes; ++i) {
    const int x = hole_stats.at<int>(i, cv::CC_STAT_LEFT), y = hole_stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = hole_stats.at<int>(i, cv::CC_STAT_WIDTH), h = hole_stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const bool touches_frame = x == 0 || y == 0 || x + w == out.cols || y + h == out.rows;
    if (!touches_frame && hole_stats.at<int>(i, cv::CC_STAT_AREA) < 0.005 * best_area) out.setTo(255, hole_labels == i);
  }
  return out;
}

void check_mask(const cv::Mat& m, int second_area, const std::string& what, double min_area_fraction) {
  const double total = static_cast<double>(m.total());
  const int area = cv::countNonZero(m);
  if (area < min_area_fraction * total)
    throw InvalidInput(what + ": no person found (the figure covers " + std::to_string(area) + " of " +
                       std::to_string(static_cast<long>(total)) + " pixels)");
  if (area > 0.6 * total)
    throw InvalidInput(what + ": the silhouette covers " + std::to_string(static_cast<int>(100.0 * area / total)) +
                       "% of the frame: no plain background around a standing person");
  if (second_area > 0.3 * area)
    throw InvalidInput(what + ": two figures (" + std::to_string(area) + " and " + std::to_string(second_area) +
                       " pixels): one person per photo, against a plain background");
  const cv::Rect box = cv::boundingRect(m);
  if (box.y == 0 || box.y + box.height >= m.rows)
    throw InvalidInput(what + ": the person touches the " + std::string(box.y == 0 ? "top" : "bottom") +
                       " of the frame: the whole body, head to feet, must be in the photo");
}

}  // namespace

int Silhouette::area() const { return static_cast<int>(std::count_if(mask.begin(), mask.end(), [](std::uint8_t v) { return v != 0; })); }

int Silhouette::top() const {
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u)
      if (inside(u, v)) return v;
  return -1;
}
int Silhouette::bottom() const {
  for (int v = height - 1; v >= 0; --v)
    for (int u = 0; u < width; ++u)
      if (inside(u, v)) return v;
  return -1;
}
int Silhouette::left() const {
  for (int u = 0; u < width; ++u)
    for (int v = 0; v < height; ++v)
      if (inside(u, v)) return u;
  return -1;
}
int Silhouette::right() const {
  for (int u = width - 1; u >= 0; --u)
    for (int v = 0; v < height; ++v)
      if (inside(u, v)) return u;
  return -1;
}

void check_silhouette(const Silhouette& s, const std::string& what, double min_area_fraction) {
  if (s.width <= 0 || s.height <= 0 || s.mask.size() != static_cast<size_t>(s.width) * s.height)
    throw InvalidInput(what + ": empty image");
  cv::Mat m(s.height, s.width, CV_8U, const_cast<std::uint8_t*>(s.mask.data()));
  int second = 0;
  cv::Mat filled = largest_component_filled(m > 127, &second);
  check_mask(filled, second, what, min_area_fraction);
}

Silhouette silhouette_from_pixels(int width, int height, int channels, const std::uint8_t* pixels, const std::string& what,
                                  const SilhouetteOptions& o) {
  if (width < 4 * kBorder || height < 4 * kBorder) throw InvalidInput(what + ": image too small (" + std::to_string(width) + "x" + std::to_string(height) + ")");
  if (channels != 1 && channels != 3) throw InvalidInput(what + ": need a gray or colour image");
  cv::Mat img(height, width, channels == 1 ? CV_8UC1 : CV_8UC3, const_cast<std::uint8_t*>(pixels));
  cv::Mat bgr;
  if (channels == 1) cv::cvtColor(img, bgr, cv::COLOR_GRAY2BGR);
  else bgr = img.clone();
  // Background model on a median-filtered copy (5x5: sensor noise falls about four-fold, outlines
  // and gaps of 3 px and more stay where they are): median and robust spread (1.4826 MAD) of each
  // channel over the frame.
  cv::Mat smooth_bgr;
  cv::medianBlur(bgr, smooth_bgr, 5);
  std::vector<std::vector<int>> border(3);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      if (v >= kBorder && v < height - kBorder && u >= kBorder && u < width - kBorder) continue;
      const cv::Vec3b p = smooth_bgr.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) border[c].push_back(p[c]);
    }
  double median[3], sigma[3];
  for (int c = 0; c < 3; ++c) {
    auto& b = border[c];
    std::nth_element(b.begin(), b.begin() + b.size() / 2, b.end());
    median[c] = b[b.size() / 2];
    for (int& x : b) x = std::abs(x - static_cast<int>(median[c]));
    std::nth_element(b.begin(), b.begin() + b.size() / 2, b.end());
    sigma[c] = std::max(1.0, 1.4826 * b[b.size() / 2]);
  }
  // The person: pixels over 4 spreads (and 4 grey levels) from the background on the filtered copy
  // give the interior (eroded 1 px); the outline comes from the sharp image (3x3 median of the
  // distance, over 4 spreads of its own and 6 grey levels).
  std::vector<std::vector<int>> sharp_border(3);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      if (v >= kBorder && v < height - kBorder && u >= kBorder && u < width - kBorder) continue;
      const cv::Vec3b p = bgr.at<cv::Vec3b>(v, u);
      for (int c = 0; c < 3; ++c) sharp_border[c].push_back(std::abs(p[c] - static_cast<int>(median[c])));
    }
  double sharp_sigma[3];
  for (int c = 0; c < 3; ++c) {
    auto& b = sharp_border[c];
    std::nth_element(b.begin(), b.begin() + b.size() / 2, b.end());
    sharp_sigma[c] = std::max(1.5, 1.4826 * b[b.size() / 2]);
  }
  cv::Mat coarse(height, width, CV_8U), sharp_dist(height, width, CV_32F);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const cv::Vec3b p = smooth_bgr.at<cv::Vec3b>(v, u), q = bgr.at<cv::Vec3b>(v, u);
      bool differs = false;
      float d = 0;
      for (int c = 0; c < 3; ++c) {
        differs |= std::abs(p[c] - median[c]) > std::max(4.0 * sigma[c], 4.0);
        d = std::max(d, static_cast<float>(std::abs(q[c] - median[c]) / std::max(sharp_sigma[c], 1.5)));
      }
      coarse.at<std::uint8_t>(v, u) = differs ? 255 : 0;
      sharp_dist.at<float>(v, u) = d;
    }
  cv::Mat sharp_median;
  cv::medianBlur(sharp_dist, sharp_median, 3);
  const double sharp_level = std::max(4.0, 6.0 / *std::max_element(sharp_sigma, sharp_sigma + 3));
  cv::Mat sharp = sharp_median > sharp_level, interior;
  cv::erode(coarse, interior, cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}));
  cv::Mat fg = sharp | interior;
  cv::morphologyEx(fg, fg, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_ELLIPSE, {3, 3}));
  int second = 0;
  cv::Mat person = largest_component_filled(fg, &second);
  if (cv::countNonZero(person) >= o.min_area_fraction * width * height && o.graph_cut) {
    // GrabCut on the person's box: certain 4 px inside what the sharp image shows (the filtered one
    // may bridge a narrow gap: between the thighs, under the arms), certain background 12 px out.
    cv::Rect box = cv::boundingRect(person);
    box.x = std::max(0, box.x - 16), box.y = std::max(0, box.y - 16);
    box.width = std::min(width - box.x, box.width + 32), box.height = std::min(height - box.y, box.height + 32);
    cv::Mat inner, outer;
    cv::erode(largest_component_filled(sharp, nullptr)(box), inner, cv::getStructuringElement(cv::MORPH_ELLIPSE, {9, 9}));
    cv::dilate(person(box), outer, cv::getStructuringElement(cv::MORPH_ELLIPSE, {25, 25}));
    cv::Mat gc(box.size(), CV_8U, cv::Scalar(cv::GC_BGD));
    gc.setTo(cv::GC_PR_BGD, outer);
    gc.setTo(cv::GC_PR_FGD, person(box));
    gc.setTo(cv::GC_FGD, inner);
    cv::Mat bgd, fgd;
    cv::Mat roi = bgr(box).clone();
    cv::grabCut(roi, gc, cv::Rect(), bgd, fgd, 1, cv::GC_INIT_WITH_MASK);
    cv::Mat refined = cv::Mat::zeros(height, width, CV_8U);
    refined(box).setTo(255, (gc == cv::GC_FGD) | (gc == cv::GC_PR_FGD));
    person = largest_component_filled(refined, &second);
    // A second figure is judged on the background model, where GrabCut's box does not reach.
    int second_raw = 0;
    largest_component_filled(fg, &second_raw);
    second = std::max(second, second_raw);
  }
  check_mask(person, second, what, o.min_area_fraction);
  return from_mat(person);
}

Silhouette silhouette_from_render(const RenderBuffers& b) {
  Silhouette s;
  s.width = b.width, s.height = b.height;
  s.mask.resize(b.face.size());
  for (size_t k = 0; k < b.face.size(); ++k) s.mask[k] = b.face[k] >= 0 ? 255 : 0;
  return s;
}

Silhouette silhouette_from_photo(const std::string& path, const std::string& what, const SilhouetteOptions& o) {
  const Image8 img = read_image(path, ImageColor::kBgr);
  return silhouette_from_pixels(img.width, img.height, 3, img.pixels.data(), what + " '" + path + "'", o);
}

Silhouette read_silhouette_mask(const std::string& path, const std::string& what) {
  Image8 gray = read_image(path, ImageColor::kGray);
  const cv::Mat img(gray.height, gray.width, CV_8UC1, gray.pixels.data());
  int second = 0;
  cv::Mat m = largest_component_filled(img > 127, &second);
  check_mask(m, second, what + " '" + path + "'", 0.005);
  return from_mat(m);
}

void write_silhouette_png(const std::string& path, const Silhouette& s) {
  write_png(path, Image8{s.width, s.height, 1, s.mask});
}

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
  out.assumed.push_back("both cameras level, " + std::to_string(distance).substr(0, 4) + " m from the person, principal point at the image centre");
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
