// The OpenCV half of photo customization (the "photo" plugin, see posekit/core/plugin.h): silhouettes
// from photos, the layer MLPs of section 3.2, the photo evaluation's degradations and the features
// figure. posekit loads OpenCV only through these entry points.
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/ml.hpp>

#include "opencv_calls.h"
#include "posekit/core/error.h"
#include "posekit/core/plugin.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/customization/silhouette.h"
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

/// Fills the holes a standing person's torso cannot have: background enclosed by the person that
/// crosses the figure's centre column between a fifth and 45% of its height from the top (the torso,
/// in front and side views: the gaps under the arms and between the legs lie beside it or below).
/// Skin shaded like the wall behind leaves such holes.
void fill_holes_on_the_torso_line(cv::Mat* person) {
  const cv::Rect box = cv::boundingRect(*person);
  if (box.area() == 0) return;
  const cv::Moments m = cv::moments(*person, true);
  const int centre = static_cast<int>(std::lround(m.m10 / std::max(1.0, m.m00)));
  cv::Mat background = *person == 0, labels;
  const int n = cv::connectedComponents(background, labels, 4, CV_32S);
  std::vector<bool> touches_frame(static_cast<size_t>(n), false), on_line(static_cast<size_t>(n), false);
  for (int v = 0; v < labels.rows; ++v)
    for (int u : {0, labels.cols - 1}) touches_frame[static_cast<size_t>(labels.at<int>(v, u))] = true;
  for (int u = 0; u < labels.cols; ++u)
    for (int v : {0, labels.rows - 1}) touches_frame[static_cast<size_t>(labels.at<int>(v, u))] = true;
  for (int v = box.y + box.height / 5; v < box.y + static_cast<int>(0.45 * box.height); ++v)
    if (const int l = labels.at<int>(v, centre); l > 0) on_line[static_cast<size_t>(l)] = true;
  for (int l = 1; l < n; ++l)
    if (on_line[static_cast<size_t>(l)] && !touches_frame[static_cast<size_t>(l)]) person->setTo(255, labels == l);
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

cv::Mat to_mat(const Eigen::MatrixXd& M) {
  cv::Mat m(static_cast<int>(M.rows()), static_cast<int>(M.cols()), CV_32F);
  for (int r = 0; r < m.rows; ++r)
    for (int c = 0; c < m.cols; ++c) m.at<float>(r, c) = static_cast<float>(M(r, c));
  return m;
}

cv::ml::ANN_MLP& as_mlp(const opencv_calls::Mlp& mlp) {
  if (!mlp) throw InvalidInput("customization model: a layer's MLP is missing");
  return *static_cast<cv::ml::ANN_MLP*>(mlp.get());
}

/// Holds the cv::Ptr so that the opaque handle keeps the MLP alive.
opencv_calls::Mlp opaque(cv::Ptr<cv::ml::ANN_MLP> mlp) {
  cv::ml::ANN_MLP* raw = mlp.get();
  return opencv_calls::Mlp(raw, [keep = std::move(mlp)](void*) mutable { keep.reset(); });
}

void check_silhouette_cv(const Silhouette& s, const std::string& what, double min_area_fraction) {
  if (s.width <= 0 || s.height <= 0 || s.mask.size() != static_cast<size_t>(s.width) * s.height) throw InvalidInput(what + ": empty image");
  cv::Mat m(s.height, s.width, CV_8U, const_cast<std::uint8_t*>(s.mask.data()));
  int second = 0;
  cv::Mat filled = largest_component_filled(m > 127, &second);
  check_mask(filled, second, what, min_area_fraction);
}

/// The person's mask in a BGR image (see silhouette_from_pixels): background model, thresholds,
/// GrabCut, the largest component. `empty_bgr`: the empty scene (same size) or empty. `second`:
/// the area of the next figure.
cv::Mat person_mask(const cv::Mat& bgr, const cv::Mat& empty_bgr, const SilhouetteOptions& o, int* second_area) {
  const int width = bgr.cols, height = bgr.rows;
  // Background model on a median-filtered copy (5x5: sensor noise falls about four-fold, outlines
  // and gaps of 3 px and more stay where they are): per row, the median of each channel over the
  // left and over the right margin, linearly interpolated across the row (a floor, a wall darker
  // towards the ceiling or lit from one side); or the empty scene's photo. Its robust spread
  // (1.4826 MAD of the frame's residuals) scales the thresholds.
  cv::Mat smooth_bgr;
  cv::medianBlur(bgr, smooth_bgr, 5);
  cv::Mat model(height, width, CV_32FC3);
  if (!empty_bgr.empty()) {
    cv::Mat smooth_e;
    cv::medianBlur(empty_bgr, smooth_e, 5);
    smooth_e.convertTo(model, CV_32FC3);
  } else {
    // Each row's margin medians, then a running median down the rows (61 rows each way, shrunk
    // symmetrically at the ends so that a floor's edge stays sharp): a hand or a second person
    // crossing a margin for fewer rows than that does not enter the model.
    std::vector<float> left[3], right[3];
    for (int c = 0; c < 3; ++c) left[c].resize(static_cast<size_t>(height)), right[c].resize(static_cast<size_t>(height));
    std::vector<int> a[3], b[3];
    for (int v = 0; v < height; ++v) {
      for (int c = 0; c < 3; ++c) a[c].clear(), b[c].clear();
      for (int k = 0; k < kBorder; ++k) {
        const cv::Vec3b l = smooth_bgr.at<cv::Vec3b>(v, k), r = smooth_bgr.at<cv::Vec3b>(v, width - 1 - k);
        for (int c = 0; c < 3; ++c) a[c].push_back(l[c]), b[c].push_back(r[c]);
      }
      for (int c = 0; c < 3; ++c) {
        std::nth_element(a[c].begin(), a[c].begin() + kBorder / 2, a[c].end());
        std::nth_element(b[c].begin(), b[c].begin() + kBorder / 2, b[c].end());
        left[c][static_cast<size_t>(v)] = static_cast<float>(a[c][kBorder / 2]);
        right[c][static_cast<size_t>(v)] = static_cast<float>(b[c][kBorder / 2]);
      }
    }
    auto running_median = [&](const std::vector<float>& x) {
      std::vector<float> out(x.size()), window;
      for (int v = 0; v < height; ++v) {
        const int w = std::min({60, v, height - 1 - v});
        window.assign(x.begin() + (v - w), x.begin() + (v + w + 1));
        std::nth_element(window.begin(), window.begin() + w, window.end());
        out[static_cast<size_t>(v)] = window[static_cast<size_t>(w)];
      }
      return out;
    };
    for (int c = 0; c < 3; ++c) left[c] = running_median(left[c]), right[c] = running_median(right[c]);
    const double u_left = 0.5 * (kBorder - 1), u_right = width - 0.5 * (kBorder + 1);
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        const float t = static_cast<float>(std::clamp((u - u_left) / (u_right - u_left), 0.0, 1.0));
        cv::Vec3f& m = model.at<cv::Vec3f>(v, u);
        for (int c = 0; c < 3; ++c)
          m[c] = left[c][static_cast<size_t>(v)] + t * (right[c][static_cast<size_t>(v)] - left[c][static_cast<size_t>(v)]);
      }
  }
  auto frame_spread = [&](const cv::Mat& img, double floor_value) {
    std::vector<float> r[3];
    for (int v = 0; v < height; ++v)
      for (int u = 0; u < width; ++u) {
        if (v >= kBorder && v < height - kBorder && u >= kBorder && u < width - kBorder) continue;
        const cv::Vec3b p = img.at<cv::Vec3b>(v, u);
        const cv::Vec3f m = model.at<cv::Vec3f>(v, u);
        for (int c = 0; c < 3; ++c) r[c].push_back(std::abs(p[c] - m[c]));
      }
    std::array<double, 3> out{};
    for (int c = 0; c < 3; ++c) {
      std::nth_element(r[c].begin(), r[c].begin() + r[c].size() / 2, r[c].end());
      out[static_cast<size_t>(c)] = std::max(floor_value, 1.4826 * r[c][r[c].size() / 2]);
    }
    return out;
  };
  const std::array<double, 3> sigma = frame_spread(smooth_bgr, 1.0), sharp_sigma = frame_spread(bgr, 1.5);
  // The person: pixels over 4 spreads (and 4 grey levels) from the background on the filtered copy
  // give the interior (eroded 1 px); the outline comes from the sharp image (3x3 median of the
  // distance, over 4 spreads of its own and 6 grey levels).
  cv::Mat coarse(height, width, CV_8U), sharp_dist(height, width, CV_32F);
  for (int v = 0; v < height; ++v)
    for (int u = 0; u < width; ++u) {
      const cv::Vec3b p = smooth_bgr.at<cv::Vec3b>(v, u), q = bgr.at<cv::Vec3b>(v, u);
      const cv::Vec3f m = model.at<cv::Vec3f>(v, u);
      bool differs = false;
      float d = 0;
      for (int c = 0; c < 3; ++c) {
        differs |= std::abs(p[c] - m[c]) > std::max(4.0 * sigma[static_cast<size_t>(c)], 4.0);
        d = std::max(d, static_cast<float>(std::abs(q[c] - m[c]) / std::max(sharp_sigma[static_cast<size_t>(c)], 1.5)));
      }
      coarse.at<std::uint8_t>(v, u) = differs ? 255 : 0;
      sharp_dist.at<float>(v, u) = d;
    }
  cv::Mat sharp_median;
  cv::medianBlur(sharp_dist, sharp_median, 3);
  const double sharp_level = std::max(4.0, 6.0 / *std::max_element(sharp_sigma.begin(), sharp_sigma.end()));
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
    cv::setRNGSeed(1);  // GrabCut's colour models start from k-means on OpenCV's generator: the same photo, the same silhouette
    cv::grabCut(roi, gc, cv::Rect(), bgd, fgd, 1, cv::GC_INIT_WITH_MASK);
    cv::Mat refined = cv::Mat::zeros(height, width, CV_8U);
    refined(box).setTo(255, (gc == cv::GC_FGD) | (gc == cv::GC_PR_FGD));
    person = largest_component_filled(refined, &second);
    // A second figure is judged on the background model, where GrabCut's box does not reach.
    int second_raw = 0;
    largest_component_filled(fg, &second_raw);
    second = std::max(second, second_raw);
  }
  *second_area = second;
  return person;
}

/// The working reduction of a photo `height` rows tall: over 1600 rows it is worked on at about 1200
/// (area-averaged: a phone's 4000 rows in a ninth of the time, its sensor noise a third).
int working_reduction(int height) { return height > 1600 ? (height + 1199) / 1200 : 1; }

/// The person in `bgr`, a photo of `full` size decoded `decoded` times smaller already (1: at full
/// size; a JPEG decoded at 1/2, 1/4 or 1/8 by its IDCT), reduced the rest of the working reduction,
/// and the mask brought back to full size by bilinear interpolation of the 0/255 mask (the outline
/// to about a third of the reduction).
Silhouette silhouette_at_full_size(const cv::Mat& bgr, const cv::Mat& empty_bgr, int decoded, cv::Size full, const std::string& what,
                                   const SilhouetteOptions& o) {
  const int k = std::max(1, working_reduction(full.height) / decoded);
  int second = 0;
  cv::Mat person;
  cv::Rect box(0, 0, full.width, full.height);  // holds every person pixel
  if (k > 1 || decoded > 1) {
    cv::Mat small_bgr = bgr, small_empty = empty_bgr, up;
    if (k > 1) {
      const cv::Size small(full.width / (k * decoded), full.height / (k * decoded));
      cv::resize(bgr, small_bgr, small, 0, 0, cv::INTER_AREA);
      if (!empty_bgr.empty()) cv::resize(empty_bgr, small_empty, small, 0, 0, cv::INTER_AREA);
    }
    const cv::Mat small_person = person_mask(small_bgr, small_empty, o, &second);
    cv::resize(small_person, up, full, 0, 0, cv::INTER_LINEAR);
    // The labelling at full size only where the person can be: the small mask's box widened by the
    // interpolation's reach (a small pixel) and two pixels of background, which keep the components
    // and holes those of the whole frame (a 12-MP frame's labelling is most of the extraction's time).
    const cv::Rect small_box = cv::boundingRect(small_person);
    const double sx = static_cast<double>(full.width) / small_person.cols, sy = static_cast<double>(full.height) / small_person.rows;
    const int x0 = static_cast<int>(std::floor((small_box.x - 1) * sx)) - 2, y0 = static_cast<int>(std::floor((small_box.y - 1) * sy)) - 2;
    const int x1 = static_cast<int>(std::ceil((small_box.x + small_box.width + 1) * sx)) + 2;
    const int y1 = static_cast<int>(std::ceil((small_box.y + small_box.height + 1) * sy)) + 2;
    box = small_box.area() > 0 ? cv::Rect(x0, y0, x1 - x0, y1 - y0) & box : box;
    int second_full = 0;
    person = cv::Mat::zeros(full, CV_8U);
    largest_component_filled(up(box) > 127, &second_full).copyTo(person(box));
    second *= k * decoded * k * decoded;
  } else {
    person = person_mask(bgr, empty_bgr, o, &second);
  }
  cv::Mat person_in_box = person(box);
  fill_holes_on_the_torso_line(&person_in_box);
  check_mask(person, second, what, o.min_area_fraction);
  return from_mat(person);
}

void check_photo_size(int width, int height, const std::string& what) {
  if (width < 4 * kBorder || height < 4 * kBorder)
    throw InvalidInput(what + ": image too small (" + std::to_string(width) + "x" + std::to_string(height) + ")");
}

/// The photo of the empty scene (options.background_photo) as `photo` was decoded; empty without one.
cv::Mat empty_scene(const std::string& path, const ReducedImage& photo, ReductionChooser choose, const std::string& what,
                    ReducedImage* storage) {
  if (path.empty()) return cv::Mat();
  *storage = read_image_reduced(path, ImageColor::kBgr, choose);
  if (storage->full_width != photo.full_width || storage->full_height != photo.full_height)
    throw InvalidInput(what + ": the empty scene's photo '" + path + "' is " + std::to_string(storage->full_width) + "x" +
                       std::to_string(storage->full_height) + ", the photo " + std::to_string(photo.full_width) + "x" +
                       std::to_string(photo.full_height));
  cv::Mat m(storage->image.height, storage->image.width, CV_8UC3, storage->image.pixels.data());
  if (storage->reduction == photo.reduction) return m;
  cv::Mat as_photo;  // one a JPEG, the other not: the empty scene brought to the photo's decoded size
  cv::resize(m, as_photo, cv::Size(photo.image.width, photo.image.height), 0, 0, cv::INTER_AREA);
  return as_photo;
}

/// A JPEG decodes at half size for free when the working reduction is even (the rest is area
/// averaging). Not further: the IDCT's 1/4 scaling is no area average, and on three 12-MP phone
/// photos it moved a hip girth by up to 6 mm against full decoding (1/2: within 2 mm), for no
/// measurable gain in time.
int decoding_reduction(int /*width*/, int height) { return working_reduction(height) % 2 == 0 ? 2 : 1; }

Silhouette silhouette_from_pixels_cv(int width, int height, int channels, const std::uint8_t* pixels, const std::string& what,
                                     const SilhouetteOptions& o) {
  check_photo_size(width, height, what);
  if (channels != 1 && channels != 3) throw InvalidInput(what + ": need a gray or colour image");
  cv::Mat img(height, width, channels == 1 ? CV_8UC1 : CV_8UC3, const_cast<std::uint8_t*>(pixels));
  cv::Mat bgr;
  if (channels == 1) cv::cvtColor(img, bgr, cv::COLOR_GRAY2BGR);
  else bgr = img;
  ReducedImage photo, empty;
  photo.full_width = width, photo.full_height = height, photo.image.width = width, photo.image.height = height;
  const cv::Mat empty_bgr = empty_scene(o.background_photo, photo, nullptr, what, &empty);
  return silhouette_at_full_size(bgr, empty_bgr, 1, {width, height}, what, o);
}

/// A photo file: a JPEG of even working reduction decoded at half size (a 12-MP photo: no full-size
/// colour image at all).
Silhouette silhouette_from_photo_cv(const std::string& path, const std::string& what, const SilhouetteOptions& o) {
  ReducedImage photo = read_image_reduced(path, ImageColor::kBgr, decoding_reduction);
  check_photo_size(photo.full_width, photo.full_height, what);
  const cv::Mat bgr(photo.image.height, photo.image.width, CV_8UC3, photo.image.pixels.data());
  ReducedImage empty;
  const cv::Mat empty_bgr = empty_scene(o.background_photo, photo, decoding_reduction, what, &empty);
  return silhouette_at_full_size(bgr, empty_bgr, photo.reduction, {photo.full_width, photo.full_height}, what, o);
}

Silhouette read_silhouette_mask_cv(const std::string& path, const std::string& what) {
  Image8 gray = read_image(path, ImageColor::kGray);
  const cv::Mat img(gray.height, gray.width, CV_8UC1, gray.pixels.data());
  int second = 0;
  cv::Mat m = largest_component_filled(img > 127, &second);
  check_mask(m, second, what + " '" + path + "'", 0.005);
  return from_mat(m);
}

void write_photo_features_png_cv(const std::string& path, const Silhouette& sil, const PinholeCamera& cam, const CustomizedBody& body) {
  cv::Mat gray(sil.height, sil.width, CV_8U, const_cast<std::uint8_t*>(sil.mask.data()));
  cv::Mat img;
  cv::cvtColor(gray / 2 + 64, img, cv::COLOR_GRAY2BGR);
  const PhotoLandmarks& L = body.landmarks;
  const double s = body.scale;
  auto unscaled = [&](const Eigen::Vector3d& p) {  // the result back in the photos' world
    return Eigen::Vector3d(body.scale_origin + (p - body.scale_origin) / s);
  };
  const std::pair<double, cv::Scalar> levels[] = {
      {L.floor_y, {0, 0, 255}},       {L.crotch_y, {0, 128, 255}}, {L.hip_y, {0, 200, 0}},
      {L.waist_y, {255, 128, 0}},     {L.bust_y, {255, 0, 255}},   {L.armpit_y[0], {0, 255, 255}},
      {L.armpit_y[1], {0, 255, 255}}, {L.neck_y, {255, 255, 0}},   {L.crown_y, {0, 0, 255}}};
  for (const auto& [y, colour] : levels) {
    const Eigen::Vector2d a = project(cam, Eigen::Vector3d(L.axis_x, y, L.axis_z));
    cv::line(img, cv::Point(0, static_cast<int>(a.y())), cv::Point(img.cols - 1, static_cast<int>(a.y())), colour, 1);
  }
  const cv::Scalar chain_colours[] = {{60, 60, 255}, {255, 200, 0}, {0, 200, 0}, {0, 140, 0}, {255, 0, 200}, {180, 0, 140}};
  const int n = body.representation.points_per_layer;
  for (size_t i = 0; i < body.representation.layers.size(); ++i)
    for (int k = 0; k < n; ++k) {
      const Eigen::Vector2d p = project(cam, unscaled(body.representation.mesh.V.row(static_cast<Eigen::Index>(i) * n + k).transpose()));
      cv::circle(img, cv::Point(static_cast<int>(p.x()), static_cast<int>(p.y())), 1,
                 chain_colours[std::clamp(body.representation.layers[i].chain, 0, 5)], cv::FILLED);
    }
  CV_Assert(img.type() == CV_8UC3 && img.isContinuous());
  write_png(path, Image8{img.cols, img.rows, 3, std::vector<std::uint8_t>(img.data, img.data + img.total() * 3)});
}

}  // namespace
}  // namespace posekit

using posekit::opencv_calls::Mlp;

POSEKIT_PLUGIN_EXPORT void posekit_check_silhouette(const posekit::Silhouette& s, const std::string& what, double min_area_fraction) {
  posekit::check_silhouette_cv(s, what, min_area_fraction);
}

POSEKIT_PLUGIN_EXPORT void posekit_silhouette_from_pixels(int width, int height, int channels, const std::uint8_t* pixels,
                                                          const std::string& what, const posekit::SilhouetteOptions& o,
                                                          posekit::Silhouette* out) {
  *out = posekit::silhouette_from_pixels_cv(width, height, channels, pixels, what, o);
}

POSEKIT_PLUGIN_EXPORT void posekit_silhouette_from_photo(const std::string& path, const std::string& what,
                                                         const posekit::SilhouetteOptions& o, posekit::Silhouette* out) {
  *out = posekit::silhouette_from_photo_cv(path, what, o);
}

POSEKIT_PLUGIN_EXPORT void posekit_read_silhouette_mask(const std::string& path, const std::string& what, posekit::Silhouette* out) {
  *out = posekit::read_silhouette_mask_cv(path, what);
}

POSEKIT_PLUGIN_EXPORT void posekit_write_photo_features_png(const std::string& path, const posekit::Silhouette& sil,
                                                            const posekit::PinholeCamera& cam, const posekit::CustomizedBody& body) {
  posekit::write_photo_features_png_cv(path, sil, cam, body);
}

POSEKIT_PLUGIN_EXPORT void posekit_load_mlp(const std::string& text, Mlp* out) {
  cv::Ptr<cv::ml::ANN_MLP> mlp = cv::Algorithm::loadFromString<cv::ml::ANN_MLP>(text);
  *out = mlp && mlp->isTrained() ? posekit::opaque(std::move(mlp)) : Mlp();
}

POSEKIT_PLUGIN_EXPORT void posekit_predict_mlp(const Mlp& mlp, const Eigen::VectorXd& input, Eigen::VectorXd* out) {
  cv::Mat y;
  posekit::as_mlp(mlp).predict(posekit::to_mat(input.transpose()), y);
  out->resize(y.cols);
  for (int c = 0; c < y.cols; ++c) (*out)[c] = y.at<float>(0, c);
}

POSEKIT_PLUGIN_EXPORT void posekit_train_mlp(const Eigen::MatrixXd& inputs, const Eigen::MatrixXd& targets, int hidden, int iterations,
                                             int seed, Mlp* out) {
  auto mlp = cv::ml::ANN_MLP::create();
  cv::Mat sizes = (cv::Mat_<int>(3, 1) << static_cast<int>(inputs.cols()), hidden, static_cast<int>(targets.cols()));
  mlp->setLayerSizes(sizes);
  mlp->setActivationFunction(cv::ml::ANN_MLP::SIGMOID_SYM, 1, 1);
  mlp->setTrainMethod(cv::ml::ANN_MLP::RPROP);
  mlp->setTermCriteria(cv::TermCriteria(cv::TermCriteria::MAX_ITER + cv::TermCriteria::EPS, iterations, 1e-7));
  cv::setRNGSeed(seed);
  mlp->train(cv::ml::TrainData::create(posekit::to_mat(inputs), cv::ml::ROW_SAMPLE, posekit::to_mat(targets)));
  *out = posekit::opaque(std::move(mlp));
}

POSEKIT_PLUGIN_EXPORT void posekit_mlp_text(const Mlp& mlp, std::string* out) {
  cv::FileStorage fs(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "opencv_ml_ann_mlp"
     << "{";
  posekit::as_mlp(mlp).write(fs);
  fs << "}";
  *out = fs.releaseAndGetString();
}

POSEKIT_PLUGIN_EXPORT void posekit_morph_silhouette(const posekit::Silhouette& s, bool erode, int px, posekit::Silhouette* out) {
  *out = s;
  cv::Mat m(s.height, s.width, CV_8U, out->mask.data());
  const cv::Mat k = cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * px + 1, 2 * px + 1});
  cv::Mat result;
  if (erode) cv::erode(m, result, k);
  else cv::dilate(m, result, k);
  out->mask.assign(result.data, result.data + result.total());
}

POSEKIT_PLUGIN_EXPORT void posekit_add_gaussian_noise(posekit::Image8* photo, unsigned seed, double sigma) {
  cv::Mat img(photo->height, photo->width, CV_8UC(photo->channels), photo->pixels.data());
  cv::Mat noise(img.size(), CV_32FC(photo->channels));
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0, sigma);
  cv::Mat f;
  img.convertTo(f, CV_32FC(photo->channels));
  f += noise;
  f.convertTo(img, CV_8UC(photo->channels));
}
