#include "posekit/core/rasterizer.h"
#include "posekit/io/image_io.h"

#include <gtest/gtest.h>

#include <cmath>

#include "posekit/core/error.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;

TEST(Rasterizer, SphereCoversItsProjectedDiscAtTheRightDepth) {
  const TriangleMesh s = test::icosphere(5, 0.5);
  const PinholeCamera cam =
      PinholeCamera::look_at(Eigen::Vector3d(0, 0, 4), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitY(), 400, 400, 500);
  const RenderBuffers b = render_mesh(s, cam);
  // Silhouette radius of a sphere of radius r at distance d: f * r / sqrt(d^2 - r^2).
  const double radius_px = 500 * 0.5 / std::sqrt(16 - 0.25);
  EXPECT_NEAR(b.covered(), M_PI * radius_px * radius_px, 0.02 * M_PI * radius_px * radius_px);
  EXPECT_NEAR(b.depth[200 * 400 + 200], 3.5, 0.002);
  EXPECT_EQ(b.face[5], -1);
  EXPECT_EQ(b.gray[5], 235);
  EXPECT_GT(b.gray[200 * 400 + 200], 200);  // facing the headlight
}

TEST(Rasterizer, LookAtProjectsTheTargetToThePrincipalPoint) {
  const PinholeCamera cam =
      PinholeCamera::look_at(Eigen::Vector3d(3, 1, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d::UnitY(), 800, 1200, 1400);
  const Eigen::Vector3d c = cam.R * Eigen::Vector3d(0, 1, 0) + cam.t;
  EXPECT_NEAR(c.x() / c.z(), 0, 1e-12);
  EXPECT_NEAR(c.y() / c.z(), 0, 1e-12);
  EXPECT_NEAR(c.z(), 3, 1e-12);
  EXPECT_TRUE(cam.centre().isApprox(Eigen::Vector3d(3, 1, 0)));
  const Eigen::Vector3d up = cam.R * Eigen::Vector3d(0, 2, 0) + cam.t;
  EXPECT_LT(up.y(), 0);  // image y points down
}

TEST(Rasterizer, PngRoundTrip) {
  test::TempDir dir;
  std::vector<std::uint8_t> px(30 * 20);
  for (size_t i = 0; i < px.size(); ++i) px[i] = static_cast<std::uint8_t>(i * 7);
  write_gray_png(dir.file("a.png"), 30, 20, px);
  int w = 0, h = 0;
  EXPECT_EQ(read_gray_png(dir.file("a.png"), &w, &h), px);
  EXPECT_EQ(w, 30);
  EXPECT_THROW(read_gray_png(dir.write("bad.png", "not a png"), &w, &h), IoError);
}
