#include "posekit/viewers/viewer.h"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "posekit/core/error.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

bool is_red(const cv::Vec3b& bgr) { return bgr[2] > 150 && bgr[1] < 110 && bgr[0] < 110; }
bool is_blue(const cv::Vec3b& bgr) { return bgr[0] > 140 && bgr[2] < 110; }
bool is_background(const cv::Vec3b& bgr) { return bgr[0] > 245 && bgr[1] > 245 && bgr[2] > 245; }

}  // namespace

TEST(Viewer, OffScreenHeatmapShowsTheBodyTheColourBarAndRedWhereTheErrorIsHigh) {
  test::TempDir dir;
  ViewPanel panel;
  panel.mesh = test::icosphere(4, 0.3);
  panel.mesh.V.col(1) *= 3;                                          // a standing ellipsoid, 1.8 tall
  Eigen::VectorXd error = 10 * (panel.mesh.V.col(1).array() / 0.9);  // -10 mm at the bottom, +10 at the top
  panel.mesh.vertex_scalars["error_mm"] = error;
  panel.scalar = "error_mm";
  panel.caption = "test";
  ViewOptions o;
  o.colour_map.kind = ColourMapKind::kDiverging;
  o.panel_width = 300;
  o.panel_height = 450;
  render_panels_png({panel, panel}, o, dir.file("h.png"));
  const cv::Mat img = cv::imread(dir.file("h.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 2 * 300 + 200);
  EXPECT_EQ(img.rows, 450);
  // The body covers a sensible part of each panel.
  for (int panel_index = 0; panel_index < 2; ++panel_index) {
    long body = 0, total = 0;
    for (int y = 0; y < img.rows; ++y)
      for (int x = panel_index * 300; x < (panel_index + 1) * 300; ++x, ++total) body += !is_background(img.at<cv::Vec3b>(y, x));
    const double fraction = static_cast<double>(body) / static_cast<double>(total);
    EXPECT_GT(fraction, 0.05) << panel_index;
    EXPECT_LT(fraction, 0.7) << panel_index;
  }
  // The top of the body is red, the bottom blue.
  long red_top = 0, blue_bottom = 0, red_bottom = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < 300; ++x) {
      const cv::Vec3b p = img.at<cv::Vec3b>(y, x);
      if (y < img.rows / 4) red_top += is_red(p);
      if (y > 3 * img.rows / 4) {
        blue_bottom += is_blue(p);
        red_bottom += is_red(p);
      }
    }
  EXPECT_GT(red_top, 200);
  EXPECT_GT(blue_bottom, 200);
  EXPECT_EQ(red_bottom, 0);
  // The colour bar: red and blue in the rightmost 200 pixels, red above blue.
  int first_red = -1, first_blue = -1;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 600; x < img.cols; ++x) {
      if (first_red < 0 && is_red(img.at<cv::Vec3b>(y, x))) first_red = y;
      if (first_blue < 0 && is_blue(img.at<cv::Vec3b>(y, x))) first_blue = y;
    }
  ASSERT_GE(first_red, 0);
  ASSERT_GE(first_blue, 0);
  EXPECT_LT(first_red, first_blue);
}

TEST(Viewer, PlainMeshesAndBadScalars) {
  test::TempDir dir;
  ViewPanel panel;
  panel.mesh = test::icosphere(3, 0.5);
  render_panels_png({panel}, ViewOptions{}, dir.file("plain.png"));
  const cv::Mat img = cv::imread(dir.file("plain.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  EXPECT_EQ(img.cols, 480);  // no scalar: no colour bar
  panel.scalar = "missing";
  try {
    render_panels_png({panel}, ViewOptions{}, dir.file("bad.png"));
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("missing"), std::string::npos);
  }
  EXPECT_THROW(render_panels_png({}, ViewOptions{}, dir.file("none.png")), InvalidInput);
  EXPECT_EQ(dir.count(), 1);
  ColourMap fixed;
  fixed.automatic = false;
  fixed.min = -2;
  fixed.max = 5;
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(10, -100, 100);
  EXPECT_EQ(colour_range(fixed, {&v}), std::make_pair(-2.0, 5.0));
  ColourMap diverging;
  diverging.kind = ColourMapKind::kDiverging;
  const auto r = colour_range(diverging, {&v});
  EXPECT_DOUBLE_EQ(r.first, -r.second);
}

TEST(Viewer, LabelsGetOneColourEachWithoutBlendsAndALegend) {
  // Two labels, the lower half 0 and the upper half 1: each half one flat colour (a label is not
  // interpolated: no third colour where they meet) and the legend shows both swatches.
  test::TempDir dir;
  ViewPanel panel;
  panel.mesh = test::icosphere(4, 0.3);
  panel.mesh.V.col(1) *= 3;
  panel.mesh.vertex_scalars["part"] = (panel.mesh.V.col(1).array() > 0).cast<double>().matrix();
  panel.scalar = "part";
  ViewOptions o;
  o.colour_map.kind = ColourMapKind::kCategorical;
  o.colour_map.categories = {"lower", "upper"};
  o.colour_map.title = "part";
  o.panel_width = 300;
  o.panel_height = 450;
  render_panels_png({panel}, o, dir.file("labels.png"));
  const cv::Mat img = cv::imread(dir.file("labels.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(img.empty());
  // Hue of each body pixel: the upper and lower quarters differ, and the body has two hues only
  // (shading changes brightness, not hue).
  cv::Mat hsv;
  cv::cvtColor(img, hsv, cv::COLOR_BGR2HSV);
  auto hue_at_rows = [&](int from, int to) {
    std::vector<int> hues;
    for (int y = from; y < to; ++y)
      for (int x = 0; x < 300; ++x)
        if (!is_background(img.at<cv::Vec3b>(y, x)) && hsv.at<cv::Vec3b>(y, x)[1] > 80) hues.push_back(hsv.at<cv::Vec3b>(y, x)[0]);
    std::sort(hues.begin(), hues.end());
    return hues.empty() ? -1 : hues[hues.size() / 2];
  };
  const int top = hue_at_rows(0, img.rows / 3), bottom = hue_at_rows(2 * img.rows / 3, img.rows);
  ASSERT_GE(top, 0);
  ASSERT_GE(bottom, 0);
  EXPECT_GT(std::abs(top - bottom), 10);
  // Other hues only where one row of triangles joins the two labels, and at the silhouette's edge.
  long other = 0, body = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 0; x < 300; ++x) {
      const cv::Vec3b h = hsv.at<cv::Vec3b>(y, x);
      if (is_background(img.at<cv::Vec3b>(y, x))) continue;
      ++body;
      if (h[1] > 80 && std::abs(h[0] - top) > 6 && std::abs(h[0] - bottom) > 6) ++other;
    }
  EXPECT_LT(other, 0.03 * static_cast<double>(body)) << other << " of " << body;
  // The legend holds both colours.
  long legend_top = 0, legend_bottom = 0;
  for (int y = 0; y < img.rows; ++y)
    for (int x = 300; x < img.cols; ++x) {
      const cv::Vec3b h = hsv.at<cv::Vec3b>(y, x);
      if (h[1] <= 80) continue;
      legend_top += std::abs(h[0] - top) <= 6;
      legend_bottom += std::abs(h[0] - bottom) <= 6;
    }
  EXPECT_GT(legend_top, 100);
  EXPECT_GT(legend_bottom, 100);
  ColourMap unnamed;
  unnamed.kind = ColourMapKind::kCategorical;
  Eigen::VectorXd v = Eigen::VectorXd::LinSpaced(4, 0, 3);
  EXPECT_THROW(colour_range(unnamed, {&v}), InvalidInput);
}

TEST(Viewer, SurfacesFacingUpAreLitNotDark) {
  // Under VTK's single headlight a surface turned 60 degrees up from the view came out at half the
  // brightness of one facing the camera: the dark thighs of a squat and the dark feet of the report's
  // figures. With a key light from above it is at least as bright as three quarters of the front.
  test::TempDir dir;
  ViewPanel panel;
  panel.mesh = test::icosphere(5, 0.5);
  ViewOptions o;
  o.panel_width = 400;
  o.panel_height = 400;
  render_panels_png({panel}, o, dir.file("sphere.png"));
  const cv::Mat img = cv::imread(dir.file("sphere.png"), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty());
  int top = img.rows, bottom = -1, left = img.cols, right = -1;
  for (int y = 40; y < img.rows; ++y)  // below the caption
    for (int x = 0; x < img.cols; ++x)
      if (img.at<uchar>(y, x) < 245)
        top = std::min(top, y), bottom = std::max(bottom, y), left = std::min(left, x), right = std::max(right, x);
  ASSERT_GT(bottom - top, 100);
  const double cx = 0.5 * (left + right), cy = 0.5 * (top + bottom), r = 0.5 * (bottom - top);
  auto mean_around = [&](double x, double y) {
    double sum = 0;
    int n = 0;
    for (int dy = -3; dy <= 3; ++dy)
      for (int dx = -3; dx <= 3; ++dx, ++n) sum += img.at<uchar>(static_cast<int>(y) + dy, static_cast<int>(x) + dx);
    return sum / n;
  };
  const double front = mean_around(cx, cy);
  const double up60 = mean_around(cx, cy - r * std::sin(M_PI / 3));
  EXPECT_GT(up60, 0.75 * front) << "front " << front << ", 60 degrees up " << up60;
}

TEST(Viewer, InteractiveWindowPicksAVertexAndTogglesOverlayAndCamera) {
  // The interactive viewer in a real (X or private Xvfb) window, driven by synthetic events through
  // VTK's interactor: a click at the panel's centre picks the sphere's vertex nearest the camera
  // (front: +Z), 's' hides the scan overlay, 'c' turns to the side view (+X), where the same
  // click picks a vertex on the +X side.
  ViewPanel panel;
  panel.mesh = test::icosphere(4, 0.3);
  panel.mesh.vertex_scalars["z_mm"] = 1000 * panel.mesh.V.col(2);
  panel.scalar = "z_mm";
  panel.overlay.P = panel.mesh.V * 1.02;
  ViewOptions o;
  o.panel_width = 300;
  o.panel_height = 300;
  const double centre_x = 150.0 / (300 + 200);  // the colour bar takes 200 pixels on the right
  using Kind = ViewerEvent::Kind;
  const std::vector<ViewerEvent> script = {{Kind::kClick, centre_x, 0.5, 0},
                                           {Kind::kKey, centre_x, 0.5, 's'},
                                           {Kind::kKey, centre_x, 0.5, 'c'},
                                           {Kind::kClick, centre_x, 0.5, 0}};
  const ViewerState state = show_panels({panel}, o, &script);
  EXPECT_FALSE(state.overlays_visible);
  EXPECT_EQ(state.camera, CameraPreset::kSide);
  ASSERT_EQ(state.picks.size(), 2u);
  auto picked = [&](const std::string& line) {
    const auto at = line.find(" vertex ");
    return std::stol(line.substr(at + 8));
  };
  const long front = picked(state.picks[0]), side = picked(state.picks[1]);
  EXPECT_GT(panel.mesh.V(front, 2), 0.28) << state.picks[0];
  EXPECT_GT(panel.mesh.V(side, 0), 0.28) << state.picks[1];
  EXPECT_NE(state.picks[0].find("z_mm = "), std::string::npos) << state.picks[0];
  // Picking a point off the body picks nothing.
  const std::vector<ViewerEvent> miss = {{Kind::kClick, 0.02, 0.98, 0}};
  EXPECT_TRUE(show_panels({panel}, o, &miss).picks.empty());
}

// A scan's stray points do not widen the box a panel of points is framed by.
TEST(Viewer, APanelOfPointsIsFramedWithoutItsStrays) {
  Eigen::MatrixXd P(1001, 3);
  for (int i = 0; i < 1000; ++i) P.row(i) << 0.001 * i, 2 * 0.001 * i, -0.001 * i;
  P.row(1000) << 50, -50, 50;  // one stray, far away
  const auto [lo, hi] = robust_box(P);
  EXPECT_NEAR(lo.x(), 0.010, 1e-9);
  EXPECT_NEAR(hi.x(), 0.990, 1e-9);
  EXPECT_NEAR(hi.y(), 1.978, 1e-9);  // the stray is the lowest y: the 99th percentile is one step lower
  EXPECT_NEAR(lo.z(), -0.989, 1e-9);
  EXPECT_THROW(robust_box(Eigen::MatrixXd(0, 3)), InvalidInput);
}
