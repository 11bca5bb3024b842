#include "posekit/viewers/viewer.h"

#include <algorithm>
#include <cmath>

#include "posekit/core/error.h"
#include "posekit/core/plugin.h"

namespace posekit {

CameraPreset parse_camera_preset(const std::string& name) {
  if (name == "front") return CameraPreset::kFront;
  if (name == "side") return CameraPreset::kSide;
  if (name == "back") return CameraPreset::kBack;
  throw InvalidInput("unknown camera '" + name + "': expected front, side or back");
}

std::pair<double, double> colour_range(const ColourMap& map, const std::vector<const Eigen::VectorXd*>& values) {
  if (map.kind == ColourMapKind::kCategorical) {
    if (map.categories.empty()) throw InvalidInput("colour map: categorical colours need the categories' names");
    return {0.0, static_cast<double>(map.categories.size() - 1)};
  }
  if (!map.automatic) {
    if (!(map.max > map.min)) throw InvalidInput("colour range: the maximum must exceed the minimum");
    return {map.min, map.max};
  }
  std::vector<double> finite;
  for (const auto* v : values)
    for (Eigen::Index i = 0; i < v->size(); ++i)
      if (std::isfinite((*v)[i])) finite.push_back((*v)[i]);
  if (finite.empty()) return {0.0, 1.0};
  // Robust: the 1st and 99th percentiles, so that a few outliers do not wash the map out.
  std::sort(finite.begin(), finite.end());
  const double lo = finite[static_cast<size_t>(0.01 * static_cast<double>(finite.size() - 1))];
  const double hi = finite[static_cast<size_t>(0.99 * static_cast<double>(finite.size() - 1))];
  if (map.kind == ColourMapKind::kDiverging) {
    const double m = std::max({std::abs(lo), std::abs(hi), 1e-9});
    return {-m, m};
  }
  const double low = std::min(lo, 0.0);
  return {low, std::max(hi, low + 1e-9)};
}

void render_panels_png(const std::vector<ViewPanel>& panels, const ViewOptions& options, const std::string& png_path) {
  using Render = void(const std::vector<ViewPanel>&, const ViewOptions&, const std::string&);
  plugin_function<Render>("render", "posekit_render_panels_png")(panels, options, png_path);
}

ViewerState show_panels(const std::vector<ViewPanel>& panels, const ViewOptions& options, const std::vector<ViewerEvent>* script) {
  using Show = void(const std::vector<ViewPanel>&, const ViewOptions&, const std::vector<ViewerEvent>*, ViewerState*);
  ViewerState state;
  plugin_function<Show>("render", "posekit_show_panels")(panels, options, script, &state);
  return state;
}

}  // namespace posekit
