#pragma once
// Colour maps for error fields, without a renderer: the viewers (VTK), the report and the glTF
// heatmaps (io) colour from the same stops and the same default range.
#include <Eigen/Core>
#include <utility>
#include <vector>

#include "posekit/core/point_cloud.h"

namespace posekit {

enum class ColourMapKind {
  kSequential,  ///< blue (low) through cyan and yellow to red (high): unsigned errors
  /// blue (negative) through light blue, green (zero), orange to red (positive): signed errors. Zero
  /// is green, not white, so that a small error is never taken for a specular highlight or for
  /// shading, which change only the brightness.
  kDiverging,
  kCategorical  ///< one colour per integer value 0..n-1, a legend naming each (labels, e.g. parts)
};

/// A colour at a position of the map (0: its low end, 1: its high end), RGB in [0, 1].
struct ColourStop {
  double at;
  Eigen::Vector3d rgb;
};

/// The stops of a sequential or diverging map (linear in RGB between them).
const std::vector<ColourStop>& colour_map_stops(ColourMapKind kind);

/// The colour at t in [0, 1] (clamped) of a sequential or diverging map.
Eigen::Vector3d colour_at(ColourMapKind kind, double t);

/// Distinct colours for categories (labels such as parts), cycled beyond 16, RGB in [0, 1].
Eigen::Vector3d category_colour(size_t i);

/// The default range of a heatmap of these values (NaNs ignored), from the data's 95th percentile:
/// diverging, +-(95th percentile of |value|); sequential, [min(5th percentile, 0), 95th percentile].
/// A few outliers then neither wash the map out nor hide small errors; values beyond it saturate.
std::pair<double, double> heatmap_range(ColourMapKind kind, const std::vector<const Eigen::VectorXd*>& values);

/// 8-bit colours of the values on the map over [lo, hi]; NaN (e.g. no scan data) mid grey.
RowMatrixX3u8 heatmap_colours(const Eigen::VectorXd& values, ColourMapKind kind, double lo, double hi);

}  // namespace posekit
