#include "posekit/core/units.h"

#include <gtest/gtest.h>

#include <cmath>

#include "posekit/core/error.h"

using namespace posekit;

TEST(Units, ParseAndNameRoundTrip) {
  for (Unit u : {Unit::kMetre, Unit::kDecimetre, Unit::kCentimetre, Unit::kMillimetre}) EXPECT_EQ(parse_unit(unit_name(u)), u);
  EXPECT_EQ(parse_unit("Millimetres"), Unit::kMillimetre);
  EXPECT_DOUBLE_EQ(metres_per_unit(Unit::kCentimetre), 0.01);
  EXPECT_THROW(parse_unit("inch"), InvalidInput);
}

TEST(Units, GuessesTheUnitOfAStandingBody) {
  Unit u;
  ASSERT_TRUE(guess_body_unit(1.75, &u));
  EXPECT_EQ(u, Unit::kMetre);
  ASSERT_TRUE(guess_body_unit(17.3, &u));
  EXPECT_EQ(u, Unit::kDecimetre);
  ASSERT_TRUE(guess_body_unit(172.0, &u));
  EXPECT_EQ(u, Unit::kCentimetre);
  ASSERT_TRUE(guess_body_unit(1700.0, &u));
  EXPECT_EQ(u, Unit::kMillimetre);
  EXPECT_FALSE(guess_body_unit(1e7, &u));
}

TEST(Units, RobustExtentIgnoresAFewStrayPoints) {
  // 1000 points over a 1.7 m column and 3 strays 40 m away: the extent is the column's.
  Eigen::MatrixXd P(1003, 3);
  for (int i = 0; i < 1000; ++i) P.row(i) << 0.1 * (i % 3), 1.7 * i / 999.0, 0.05 * (i % 5);
  P.bottomRows(3) << 40, 0, 0, 0, 40, 0, 0, 0, -40;
  EXPECT_NEAR(robust_largest_extent(P), 1.7, 0.02);
  EXPECT_GT((P.colwise().maxCoeff() - P.colwise().minCoeff()).maxCoeff(), 40.0);  // the plain box
  Unit unit;
  ASSERT_TRUE(guess_body_unit(robust_largest_extent(P * 1000), &unit));
  EXPECT_EQ(unit, Unit::kMillimetre);
  EXPECT_EQ(robust_largest_extent(Eigen::MatrixXd(0, 3)), 0.0);
}

TEST(Units, RobustExtentOfADenseScanFromItsSample) {
  // 1.5M points: a 1.7 m column (its points in scanner order, bottom to top, ring by ring) and 0.25%
  // stray points up to 40 m away, spread through the file: the sample gives the column's extent.
  const Eigen::Index n = 1500000;
  Eigen::MatrixXd P(n, 3);
  for (Eigen::Index i = 0; i < n; ++i) {
    const double t = static_cast<double>(i) / static_cast<double>(n - 1);
    P.row(i) << 0.2 * std::cos(1000 * t), 1.7 * t, 0.2 * std::sin(1000 * t);
    if (i % 401 == 0) P.row(i) << 40 * t, -40 * t, 0;
  }
  EXPECT_NEAR(robust_largest_extent(P), 1.7, 0.03);
}
