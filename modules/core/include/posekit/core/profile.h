#pragma once
// Levels read off a sampled profile, such as the girths of a stack of parallel cross-sections.
#include <cstddef>
#include <vector>

namespace posekit {

/// The centre of a profile's peak: the centroid of the excess g(y) - threshold over the span
/// around sample `peak` where the piecewise-linear profile through (y[k], g[k]) stays above
/// `threshold`. The span ends where the profile crosses the threshold, at a non-finite sample, or
/// at the first or last sample. Unlike the middle of that span, it moves continuously with the
/// samples (a sample near the threshold carries almost no weight), so it hardly depends on how
/// finely or where the profile was sampled. `y` must ascend; g[peak] must exceed `threshold`.
/// Throws InvalidInput otherwise.
double peak_centre(const std::vector<double>& y, const std::vector<double>& g, size_t peak, double threshold);

}  // namespace posekit
