#include "posekit/population/limb_segments.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <tuple>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/population/survey_fit.h"
#include "testing/makehuman_fixture.h"
#include "testing/temp_dir.h"

using namespace posekit;

namespace {

/// ANSUR II's columns for the 12 measurements and the limb segments, one subject per row.
std::string survey_with_segments(const std::string& trochanterion) {
  std::string header = "Gender", row = "Female";
  for (int m = 0; m < kSurveyMeasureCount; ++m) {
    header += std::string(",") + survey_column(static_cast<SurveyMeasure>(m));
    row += "," + std::to_string(1000 + 10 * m);
  }
  header += ",acromionradialelength,radialestylionlength,trochanterionheight,lateralfemoralepicondyleheight,lateralmalleolusheight";
  return header + "\n" + row + ",330,260," + trochanterion + ",480,70\n";
}

}  // namespace

TEST(LimbSegments, ReadsTheSegmentsFromTheirColumnsAndNamesAnInvertedPair) {
  test::TempDir dir;
  const SurveySubject s = read_survey_csv(dir.write("s.csv", survey_with_segments("900"))).front();
  EXPECT_NEAR(s.segments[static_cast<int>(LimbSegment::kUpperArm)], 0.330, 1e-12);
  EXPECT_NEAR(s.segments[static_cast<int>(LimbSegment::kForearm)], 0.260, 1e-12);
  EXPECT_NEAR(s.segments[static_cast<int>(LimbSegment::kThigh)], 0.420, 1e-12);
  EXPECT_NEAR(s.segments[static_cast<int>(LimbSegment::kShank)], 0.410, 1e-12);
  try {
    read_survey_csv(dir.write("inverted.csv", survey_with_segments("400")));
    FAIL() << "a trochanterion below the knee was read";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("inverted.csv:2: column 'trochanterionheight' is not above 'lateralfemoralepicondyleheight'"),
              std::string::npos)
        << e.what();
  }
}

TEST(LimbSegments, TheSpreadIsWhatTheMeasurementsLeaveOpen) {
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0, 1);
  std::vector<SurveySubject> subjects(400);
  for (size_t i = 0; i < subjects.size(); ++i) {
    SurveySubject& s = subjects[i];
    s.male = i % 2 == 0;
    for (double& v : s.values) v = 1 + 0.05 * normal(rng);
    const double stature = s.values[static_cast<int>(SurveyMeasure::kStature)];
    // Lengths the measurements decide but for 5 and 0 mm; the shank not measured.
    s.segments[0] = 0.19 * stature + (s.male ? 0.01 : 0) + 0.005 * normal(rng);
    s.segments[1] = 0.5 * s.values[static_cast<int>(SurveyMeasure::kSleeveOutseam)] - 0.1 * stature;
    s.segments[2] = 0.25 * stature + 0.012 * normal(rng);
  }
  const auto spread = limb_segment_spread(subjects);
  EXPECT_NEAR(spread[0], 0.005, 0.0006);
  EXPECT_LT(spread[1], 1e-9);
  EXPECT_NEAR(spread[2], 0.012, 0.0015);
  EXPECT_TRUE(std::isnan(spread[3]));
  subjects.resize(100);  // fewer than 10 subjects per regressor
  EXPECT_TRUE(std::isnan(limb_segment_spread(subjects)[0]));
}

TEST(LimbSegments, AComponentLengthensBothSidesSegmentAndCarriesTheLimbBeyond) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  std::vector<BodySpec> specs(3);
  specs[1].height = 0.8, specs[2].weight = 0.9;
  ShapeSpace space = population_shape_space(model, specs, "test");
  const ShapeSpace before = space;
  const double nan = std::nan("");
  add_limb_segment_components(model, {0.01, 0.02, nan, 0.005}, &space);
  ASSERT_EQ(space.components(), before.components() + 3);  // the thigh has no spread
  double shares = 0;
  for (double v : space.variance_share) shares += v;
  EXPECT_NEAR(shares, 1.0, 1e-9);

  const Eigen::VectorXi parts = vertex_part_labels(model);
  const Eigen::MatrixXd& J = space.joint_mean;
  for (const auto& [c, sd, segment] :
       {std::tuple{before.components(), 0.01, kLeftUpperArm}, std::tuple{before.components() + 1, 0.02, kLeftForearm},
        std::tuple{before.components() + 2, 0.005, kLeftShank}}) {
    Eigen::VectorXd coefficients = Eigen::VectorXd::Zero(space.components());
    coefficients[c] = 1;
    const Eigen::MatrixXd V = space.body(coefficients), joints = space.joints(coefficients);
    for (const int side : {static_cast<int>(segment), mirror_part(segment)}) {
      const int start = side - 1, end = side;  // joint j starts part j + 1: the segment's joint, its child's
      EXPECT_NEAR((joints.row(end) - joints.row(start)).norm() - (J.row(end) - J.row(start)).norm(), sd, 1e-9) << side;
    }
    // The joints beyond either side's segment move by its spread, every other stays.
    for (int j = 0; j < kNumJoints; ++j) {
      bool beyond = false;
      for (int p = part_parent(j + 1); p >= 0; p = part_parent(p)) beyond = beyond || p == segment || p == mirror_part(segment);
      EXPECT_NEAR((joints.row(j) - J.row(j)).norm(), beyond ? sd : 0.0, 1e-9) << segment << " " << joint_name(j);
    }
    const Eigen::VectorXd moved = (V - space.mean).rowwise().norm();
    for (Eigen::Index v = 0; v < V.rows(); ++v) {
      if (parts[v] == kPelvis || parts[v] == kHead) EXPECT_LT(moved[v], 1e-12) << v;
      const bool beyond =
          segment == kLeftShank ? parts[v] == kLeftFoot || parts[v] == kRightFoot : parts[v] == kLeftHand || parts[v] == kRightHand;
      if (beyond) EXPECT_NEAR(moved[v], sd, 0.05 * sd) << v;
      EXPECT_LE(moved[v], sd * (1 + 1e-9)) << v;
    }
  }
  ShapeSpace wrong = before;
  wrong.joint_mean.resize(0, 3);
  EXPECT_THROW(add_limb_segment_components(model, {0.01, 0.01, 0.01, 0.01}, &wrong), InvalidInput);
}
