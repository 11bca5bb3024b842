#include "posekit/viewers/viewer.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/plugin.h"

namespace posekit {

std::pair<Eigen::Vector3d, Eigen::Vector3d> robust_box(const Eigen::MatrixXd& P) {
  if (P.rows() == 0 || P.cols() != 3) throw InvalidInput("robust_box: expected a non-empty #P x 3 set of points");
  Eigen::Vector3d lo, hi;
  for (int k = 0; k < 3; ++k) {
    std::vector<double> v(P.col(k).data(), P.col(k).data() + P.rows());
    std::sort(v.begin(), v.end());
    lo[k] = v[static_cast<size_t>(0.01 * static_cast<double>(v.size() - 1))];
    hi[k] = v[static_cast<size_t>(0.99 * static_cast<double>(v.size() - 1))];
  }
  return {lo, hi};
}

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
  return heatmap_range(map.kind, values);
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
