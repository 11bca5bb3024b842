#include "posekit/core/profile.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "posekit/core/error.h"

using namespace posekit;

namespace {
// A flat-topped chest-like profile: rises to a plateau on [0.02, 0.06], slopes asymmetric.
double plateau_profile(double y) {
  if (y < 0.02) return 1.0 - 0.4 * (0.02 - y);
  if (y > 0.06) return 1.0 - 0.1 * (y - 0.06);
  return 1.0 + 0.002 * (y - 0.02) * (0.06 - y) / 0.0004;
}
}  // namespace

TEST(Profile, SymmetricPeakIsCentredOnItsApex) {
  const std::vector<double> y = {0.0, 0.1, 0.2, 0.3, 0.4};
  const std::vector<double> g = {0.0, 1.0, 2.0, 1.0, 0.0};
  EXPECT_NEAR(peak_centre(y, g, 2, 0.5), 0.2, 1e-12);
  EXPECT_NEAR(peak_centre(y, g, 2, 1.5), 0.2, 1e-12);
}

TEST(Profile, LinearRampCentroidIsAtTwoThirds) {
  // Excess rises linearly from 0 at y = 0 to 1 at y = 3 (the last sample): centroid at y = 2.
  const std::vector<double> y = {-1.0, 0.0, 1.0, 2.0, 3.0};
  const std::vector<double> g = {-1.0, 0.0, 1.0, 2.0, 3.0};
  EXPECT_NEAR(peak_centre(y, g, 4, 0.0), 2.0, 1e-12);
}

TEST(Profile, SpanStopsAtNonFiniteSamplesAndAtTheThreshold) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // A second bump above the threshold beyond a dip below it is not part of the peak.
  EXPECT_NEAR(peak_centre({0, 1, 2, 3, 4}, {1, 2, 1, 0, 5}, 1, 1.0), 1.0, 1e-12);
  EXPECT_NEAR(peak_centre({0, 1, 2, 3}, {nan, 2, 2, 1}, 1, 1.0), peak_centre({1, 2, 3}, {2, 2, 1}, 0, 1.0), 1e-12);
}

TEST(Profile, CentreHardlyDependsOnTheSampling) {
  // The same flat-topped profile sampled every 5 mm at two offsets and every 1 mm: the centres
  // agree to well under a millimetre, where the plateau's (3 mm) edges move with the sampling.
  auto centre = [](double step, double offset) {
    std::vector<double> y, g;
    for (double v = -0.05 + offset; v < 0.15; v += step) y.push_back(v), g.push_back(plateau_profile(v));
    size_t best = 0;
    for (size_t k = 1; k < g.size(); ++k)
      if (g[k] > g[best]) best = k;
    return peak_centre(y, g, best, g[best] - 0.003);
  };
  const double fine = centre(0.001, 0.0);
  EXPECT_NEAR(fine, 0.04091, 0.0001);  // the span is [0.0175, 0.07]; its middle would be 0.04375
  for (double offset : {0.0, 0.0013, 0.0025, 0.0041}) EXPECT_NEAR(centre(0.005, offset), fine, 0.0005) << offset;
}

TEST(Profile, BadInputIsRejected) {
  EXPECT_THROW(peak_centre({0, 1}, {1}, 0, 0.0), InvalidInput);
  EXPECT_THROW(peak_centre({0, 1}, {1, 2}, 2, 0.0), InvalidInput);
  EXPECT_THROW(peak_centre({1, 0}, {1, 2}, 0, 0.0), InvalidInput);
  EXPECT_THROW(peak_centre({0, 1}, {1, 2}, 0, 1.5), InvalidInput);
}
