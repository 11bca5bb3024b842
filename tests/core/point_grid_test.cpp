#include "posekit/core/point_grid.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "posekit/core/error.h"

using namespace posekit;

namespace {

int brute_nearest(const Eigen::MatrixXd& P, const Eigen::Vector3d& p, int skip, double* sq) {
  int best = -1;
  *sq = 1e300;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const double d = (P.row(i).transpose() - p).squaredNorm();
    if (i != skip && d < *sq) *sq = d, best = static_cast<int>(i);
  }
  return best;
}

}  // namespace

TEST(PointGrid, NearestMatchesABruteForceSearchInsideOutsideAndWithinARadius) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  // A thin shell (a scan is a surface) plus a far cluster: cells of very different occupancy.
  Eigen::MatrixXd P(3000, 3);
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    Eigen::Vector3d v(g(rng), g(rng), g(rng));
    const Eigen::Vector3d q = i < 2900 ? Eigen::Vector3d(v.normalized() * 0.3) : Eigen::Vector3d(v * 0.01 + Eigen::Vector3d(2, 0, 0));
    P.row(i) = q.transpose();
  }
  for (const double cell : {0.0, 0.01, 0.5}) {
    const PointGrid grid(P, cell);
    std::uniform_real_distribution<double> u(-1.5, 3.0);
    for (int q = 0; q < 300; ++q) {
      const Eigen::Vector3d p(u(rng), u(rng) * 0.5, u(rng) * 0.5);  // many outside the grid's box
      double sq, expected;
      const int i = grid.nearest(p, &sq);
      const int j = brute_nearest(P, p, -1, &expected);
      ASSERT_EQ(sq, expected) << "cell " << cell << " query " << q;
      EXPECT_EQ((P.row(i).transpose() - p).squaredNorm(), sq);
      (void)j;
      // Within a radius: the same answer when the nearest is inside it, none otherwise.
      const double radius = 0.2;
      double sq_r;
      const int k = grid.nearest(p, &sq_r, radius);
      if (expected < radius * radius) EXPECT_EQ(sq_r, expected);
      else EXPECT_EQ(k, -1);
    }
    // Near the surface, as most of a fit's queries are: the answer's cell is beside the query's, and
    // cells no nearer than the best so far are passed over.
    std::normal_distribution<double> noise(0, 0.003);
    for (int q = 0; q < 600; ++q) {
      const Eigen::Vector3d p = P.row(q * 5).transpose() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
      double sq, expected;
      const int i = grid.nearest(p, &sq, 0.1);
      const int j = brute_nearest(P, p, -1, &expected);
      ASSERT_EQ(i, j) << "cell " << cell << " near-surface query " << q;
      ASSERT_EQ(sq, expected);
    }
    // A point's nearest other point.
    for (int i = 0; i < 3000; i += 97) {
      double sq, expected;
      grid.nearest(P.row(i).transpose(), &sq, std::numeric_limits<double>::infinity(), i);
      brute_nearest(P, P.row(i).transpose(), i, &expected);
      ASSERT_EQ(sq, expected) << i;
    }
  }
  EXPECT_THROW(PointGrid(Eigen::MatrixXd(0, 3)), InvalidInput);
}

TEST(PointGrid, CoordinatesFarApartAreRefusedOrIndexedNeverUndefined) {
  // Found by the fit fuzz target: points 1e308 apart overflowed the grid's extent into a NaN cell
  // count (undefined behaviour casting it to int). Now refused; a volume beyond double's range
  // (points 1e200 apart) is one cell.
  Eigen::MatrixXd far(3, 3);
  far << -1e308, 0, 0, 1e308, 0, 0, 0, 1, 0;
  EXPECT_THROW(PointGrid(far, 0.0), InvalidInput);
  Eigen::MatrixXd wide(4, 3);
  wide << -1e200, -1e200, -1e200, 1e200, 1e200, 1e200, 0, 0, 0, 1, 1, 1;
  double sq = 0;
  const PointGrid grid(wide, 0.0);
  EXPECT_EQ(grid.nearest(Eigen::Vector3d(0.9, 0.9, 0.9), &sq), 3);
  const PointGrid nan_cell(wide, std::nan(""));
  EXPECT_EQ(nan_cell.nearest(Eigen::Vector3d(0.1, 0, 0), &sq), 2);
  EXPECT_NEAR(sq, 0.01, 1e-12);
}
