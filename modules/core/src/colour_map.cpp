#include "posekit/core/colour_map.h"

#include <algorithm>
#include <cmath>

#include "posekit/core/error.h"

namespace posekit {

const std::vector<ColourStop>& colour_map_stops(ColourMapKind kind) {
  static const std::vector<ColourStop> sequential = {{0.00, {0.19, 0.21, 0.58}},
                                                     {0.25, {0.16, 0.60, 0.85}},
                                                     {0.50, {0.55, 0.85, 0.55}},
                                                     {0.75, {0.99, 0.80, 0.20}},
                                                     {1.00, {0.85, 0.08, 0.08}}};
  static const std::vector<ColourStop> diverging = {{0.00, {0.17, 0.27, 0.78}},
                                                    {0.25, {0.50, 0.68, 0.95}},
                                                    {0.50, {0.36, 0.74, 0.36}},
                                                    {0.75, {0.98, 0.68, 0.30}},
                                                    {1.00, {0.78, 0.09, 0.11}}};
  if (kind == ColourMapKind::kCategorical) throw InvalidInput("colour map: a categorical map has colours per category, not stops");
  return kind == ColourMapKind::kDiverging ? diverging : sequential;
}

Eigen::Vector3d category_colour(size_t i) {
  static const double kPalette[16][3] = {{0.90, 0.60, 0.00}, {0.34, 0.71, 0.91}, {0.00, 0.62, 0.45}, {0.94, 0.89, 0.26},
                                         {0.00, 0.45, 0.70}, {0.84, 0.37, 0.00}, {0.80, 0.47, 0.65}, {0.55, 0.34, 0.16},
                                         {0.60, 0.60, 0.60}, {0.20, 0.20, 0.55}, {0.65, 0.85, 0.35}, {0.75, 0.10, 0.20},
                                         {0.45, 0.25, 0.60}, {0.10, 0.40, 0.25}, {1.00, 0.70, 0.75}, {0.30, 0.30, 0.30}};
  const double* c = kPalette[i % 16];
  return Eigen::Vector3d(c[0], c[1], c[2]);
}

Eigen::Vector3d colour_at(ColourMapKind kind, double t) {
  const std::vector<ColourStop>& stops = colour_map_stops(kind);
  t = std::clamp(std::isfinite(t) ? t : 0.5, 0.0, 1.0);
  for (size_t i = 1; i < stops.size(); ++i)
    if (t <= stops[i].at) {
      const double w = (t - stops[i - 1].at) / (stops[i].at - stops[i - 1].at);
      return (1 - w) * stops[i - 1].rgb + w * stops[i].rgb;
    }
  return stops.back().rgb;
}

std::pair<double, double> heatmap_range(ColourMapKind kind, const std::vector<const Eigen::VectorXd*>& values) {
  std::vector<double> finite;
  for (const auto* v : values)
    for (Eigen::Index i = 0; i < v->size(); ++i)
      if (std::isfinite((*v)[i])) finite.push_back(kind == ColourMapKind::kDiverging ? std::abs((*v)[i]) : (*v)[i]);
  if (finite.empty()) return {kind == ColourMapKind::kDiverging ? -1.0 : 0.0, 1.0};
  auto quantile = [&](double q) {
    const auto k = static_cast<std::ptrdiff_t>(std::lround(q * static_cast<double>(finite.size() - 1)));
    std::nth_element(finite.begin(), finite.begin() + k, finite.end());
    return finite[static_cast<size_t>(k)];
  };
  if (kind == ColourMapKind::kDiverging) {
    const double m = std::max(quantile(0.95), 1e-9);
    return {-m, m};
  }
  const double hi = quantile(0.95);
  const double low = std::min(quantile(0.05), 0.0);
  return {low, std::max(hi, low + 1e-9)};
}

RowMatrixX3u8 heatmap_colours(const Eigen::VectorXd& values, ColourMapKind kind, double lo, double hi) {
  if (!(hi > lo)) throw InvalidInput("heatmap: the range's maximum must exceed its minimum");
  RowMatrixX3u8 out(values.size(), 3);
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const Eigen::Vector3d c = std::isfinite(values[i]) ? colour_at(kind, (values[i] - lo) / (hi - lo)) : Eigen::Vector3d(0.5, 0.5, 0.5);
    for (int k = 0; k < 3; ++k) out(i, k) = static_cast<std::uint8_t>(std::lround(255 * c[k]));
  }
  return out;
}

}  // namespace posekit
