#include "posekit/core/colour_map.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "posekit/core/error.h"

namespace posekit {
namespace {

TEST(ColourMap, TheRangeIsTheDatasNinetyFifthPercentileAndOutliersSaturate) {
  Eigen::VectorXd errors = Eigen::VectorXd::LinSpaced(101, -5, 5);  // |e|: 0, 0.1, ..., 5 twice
  errors[0] = -300;                                                 // a stray point
  errors[1] = std::numeric_limits<double>::quiet_NaN();             // no scan data
  const auto [lo, hi] = heatmap_range(ColourMapKind::kDiverging, {&errors});
  EXPECT_NEAR(hi, 4.8, 0.11);  // not 300: the outlier does not wash the map out
  EXPECT_EQ(lo, -hi);
  const auto [slo, shi] = heatmap_range(ColourMapKind::kSequential, {&errors});
  EXPECT_LT(slo, -4.0);  // signed values: from the 5th percentile
  EXPECT_NEAR(shi, 4.5, 0.11);
  const RowMatrixX3u8 c = heatmap_colours(errors, ColourMapKind::kDiverging, lo, hi);
  EXPECT_EQ(c.row(1), RowMatrixX3u8::Constant(1, 3, 128));                                                     // NaN: grey
  EXPECT_EQ(c.row(0), heatmap_colours(Eigen::VectorXd::Constant(1, -hi), ColourMapKind::kDiverging, lo, hi));  // saturated
  EXPECT_THROW(heatmap_colours(errors, ColourMapKind::kDiverging, 1, 1), InvalidInput);
}

TEST(ColourMap, ZeroOnTheDivergingMapIsAHueNotAShadeOfGrey) {
  // A small error must not look like shading (a darker or lighter grey) or a specular highlight
  // (white): zero is a saturated colour, and every colour of the map is far from every grey.
  const Eigen::Vector3d zero = colour_at(ColourMapKind::kDiverging, 0.5);
  EXPECT_GT(zero.maxCoeff() - zero.minCoeff(), 0.3) << zero.transpose();
  for (int i = 0; i <= 100; ++i) {
    const Eigen::Vector3d c = colour_at(ColourMapKind::kDiverging, i / 100.0);
    EXPECT_GT(c.maxCoeff() - c.minCoeff(), 0.2) << i << ": " << c.transpose();
  }
  EXPECT_GT(colour_at(ColourMapKind::kDiverging, 0).z(), colour_at(ColourMapKind::kDiverging, 0).x());  // negative: blue
  EXPECT_GT(colour_at(ColourMapKind::kDiverging, 1).x(), colour_at(ColourMapKind::kDiverging, 1).z());  // positive: red
  EXPECT_THROW(colour_map_stops(ColourMapKind::kCategorical), InvalidInput);
}

}  // namespace
}  // namespace posekit
