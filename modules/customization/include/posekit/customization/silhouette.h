#pragma once
// Silhouettes of a person from photos (background modelled from the image border, refined by a
// graph cut) and the two cameras of a front/side photo pair.
#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "posekit/core/rasterizer.h"

namespace posekit {

/// A binary person mask: 255 person, 0 background, row-major.
struct Silhouette {
  int width = 0, height = 0;
  std::vector<std::uint8_t> mask;
  bool inside(int u, int v) const { return u >= 0 && v >= 0 && u < width && v < height && mask[static_cast<size_t>(v) * width + u]; }
  int area() const;
  /// First and last rows and columns with person pixels (-1 when empty).
  int top() const, bottom() const, left() const, right() const;
};

struct SilhouetteOptions {
  bool graph_cut = true;             ///< refine the background model's mask with GrabCut
  double min_area_fraction = 0.005;  ///< below: "no person"
  /// A photo of the empty scene from the same place (same size): the background model is that
  /// photo, for a textured wall or a cluttered room. Empty: modelled from the photo's own frame.
  std::string background_photo;
};

/// The person in a photo (PNG or JPEG): pixels unlike the background, refined by GrabCut near the
/// outline, the largest component with its holes filled. The background is modelled row by row
/// from the photo's left and right 12-pixel margins, linearly across the row: a floor in view, a
/// wall lit from one side or darker towards the ceiling are background (or, with
/// options.background_photo, the empty scene itself). Throws InvalidInput naming `what` (e.g.
/// "front photo") when there is no person, the person fills the frame or touches its top or bottom,
/// or a second figure nearly as large stands beside the first.
Silhouette silhouette_from_photo(const std::string& path, const std::string& what, const SilhouetteOptions& options = {});
/// The same from an 8-bit image in memory (1 or 3 channels, row-major, BGR).
Silhouette silhouette_from_pixels(int width, int height, int channels, const std::uint8_t* pixels, const std::string& what,
                                  const SilhouetteOptions& options = {});
/// The true silhouette of a rendered mesh (pixels its triangles cover).
Silhouette silhouette_from_render(const RenderBuffers& buffers);
/// A mask image (person > 127): the largest component, holes filled, with the same checks.
Silhouette read_silhouette_mask(const std::string& path, const std::string& what);
/// Checks a silhouette as the readers do (throws InvalidInput naming `what`).
void check_silhouette(const Silhouette& s, const std::string& what, double min_area_fraction = 0.005);
/// Writes a mask as PNG (atomically).
void write_silhouette_png(const std::string& path, const Silhouette& s);

/// The cameras of a photo pair and what was assumed about them.
struct PhotoCameras {
  PinholeCamera front, side;
  std::vector<std::string> assumed;  ///< human-readable assumptions (empty: from a camera file)
};

/// Reads a camera file in the dataset's format ({"front": {K, R, t, width, height}, "side": ...}).
/// Throws IoError / InvalidInput naming the file and the element.
PhotoCameras read_photo_cameras(const std::string& path);
/// Cameras of two photos taken level at `distance` metres, the person `stature` metres tall: with
/// focal_px <= 0 the focal length is the one that makes the front silhouette that tall there.
/// Front camera on +Z looking at -Z, side camera on +X (the subject's left) looking at -X.
PhotoCameras cameras_from_stature(const Silhouette& front, const Silhouette& side, double stature, double distance = 3.0,
                                  double focal_px = 0);

/// Projects a world point to pixel coordinates (u right, v down).
Eigen::Vector2d project(const PinholeCamera& camera, const Eigen::Vector3d& x);
/// The point of the ray through pixel (u, v) at `depth` along the camera's optical axis.
Eigen::Vector3d point_at_depth(const PinholeCamera& camera, double u, double v, double depth);
/// Depth of a world point along the camera's optical axis.
double depth_of(const PinholeCamera& camera, const Eigen::Vector3d& x);

}  // namespace posekit
