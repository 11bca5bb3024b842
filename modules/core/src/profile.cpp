#include "posekit/core/profile.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "posekit/core/error.h"

namespace posekit {

double peak_centre(const std::vector<double>& y, const std::vector<double>& g, size_t peak, double threshold) {
  if (y.size() != g.size() || peak >= y.size())
    throw InvalidInput("peak_centre: " + std::to_string(y.size()) + " heights, " + std::to_string(g.size()) + " values and peak index " +
                       std::to_string(peak) + " do not match");
  if (!(g[peak] > threshold)) throw InvalidInput("peak_centre: the peak sample does not exceed the threshold");
  for (size_t k = 1; k < y.size(); ++k)
    if (!(y[k] > y[k - 1])) throw InvalidInput("peak_centre: heights must ascend (sample " + std::to_string(k) + ")");
  double area = 0, moment = 0;
  // Adds the interval from sample `inside` (above the threshold) towards sample `outside`; returns
  // false where the span ends.
  auto add = [&](size_t inside, size_t outside) {
    const double wa = g[inside] - threshold, ya = y[inside];
    if (!std::isfinite(g[outside])) return false;
    const double wb_raw = g[outside] - threshold;
    const double yb = wb_raw >= 0 ? y[outside] : ya + (y[outside] - ya) * wa / (wa - wb_raw);
    const double wb = std::max(wb_raw, 0.0), h = std::abs(yb - ya);
    area += 0.5 * (wa + wb) * h;
    moment += h / 6.0 * (ya * (2 * wa + wb) + yb * (wa + 2 * wb));
    return wb_raw > 0;
  };
  for (size_t k = peak; k + 1 < y.size() && add(k, k + 1); ++k) {
  }
  for (size_t k = peak; k > 0 && add(k, k - 1); --k) {
  }
  return area > 0 ? moment / area : y[peak];
}

}  // namespace posekit
