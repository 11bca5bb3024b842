#include "posekit/shape/measurements.h"

#include <gtest/gtest.h>

#include "posekit/core/error.h"
#include "posekit/datasets/remesh.h"
#include "posekit/datasets/scanner.h"
#include "posekit/datasets/subjects.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

TEST(Measurements, GirthsMatchTheGroundTruthOnAllSixteenSubjects) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  for (const auto& s : make_subject_specs(model, 1, 16)) {
    const Body b = build_body(model, s.spec);
    const TriangleMesh mesh = remesh_body(b.mesh, 12400);
    const Measurements gt = measure_makehuman_body(model, b);
    const BodyMeasurements m = measure_body(mesh.V, mesh.F);
    for (const auto& g : m.girths) EXPECT_TRUE(g.measured) << s.id << " " << g.name << ": " << g.note;
    EXPECT_NEAR(m.stature, gt.stature, 0.002) << s.id;
    EXPECT_NEAR(m.find("waist")->value, gt.waist, 0.01) << s.id;
    EXPECT_NEAR(m.find("hip")->value, gt.hip, 0.01) << s.id;
    EXPECT_NEAR(m.find("underbust")->value, gt.underbust, 0.01) << s.id;
    EXPECT_NEAR(m.find("thigh")->value, gt.thigh, 0.01) << s.id;
    EXPECT_NEAR(m.find("upper_arm")->value, gt.upper_arm, 0.01) << s.id;
    EXPECT_NEAR(m.find("neck")->value, gt.neck, 0.01) << s.id;  // measured: worst 0.63 cm (f08)
    EXPECT_NEAR(m.find("bust")->value, gt.bust, 0.01) << s.id;
    // The bust band ends 1 cm below where the arms separate, found to 1 mm in both.
    EXPECT_NEAR(m.features.arms_separate_y, gt.arms_separate_height, 0.003) << s.id;
  }
}

TEST(Measurements, RemeshingLeavesTheGirthsUnchangedOnAllSixteenSubjects) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  // Both are measured on the smooth surface through their vertices, and the remesh samples the
  // original's smooth surface. Measured worst of 16, mm: upper arm 0.91 (f08), wrist 0.73, hip
  // 0.72, bust 0.54, thigh 0.54, waist 0.52, ankle 0.43, underbust 0.41, knee 0.40, calf 0.40,
  // neck 0.23. Before the bust level became a weighted peak centre, the arms' separation a 5 mm
  // clearance and the crotch a fitted arch, bust, thigh and underbust moved by up to 2.6 mm.
  for (const auto& s : make_subject_specs(model, 1, 16)) {
    const Body b = build_body(model, s.spec);
    const BodyMeasurements a = measure_body(b.mesh.V, b.mesh.F);
    const TriangleMesh r = remesh_body(b.mesh, 12400);
    const BodyMeasurements c = measure_body(r.V, r.F);
    for (const char* name : {"bust", "underbust", "waist", "hip", "thigh", "knee", "calf", "ankle", "upper_arm", "wrist", "neck"})
      EXPECT_NEAR(a.find(name)->value, c.find(name)->value, 0.001) << s.id << " " << name;
  }
}

TEST(Measurements, ScanGirthsMatchTheMeshAndHolesAreReported) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  const BodyMeasurements mesh = measure_body(b.mesh.V, b.mesh.F);
  ScannerOptions o;
  o.width = 320;
  o.height = 480;
  o.focal_px = 345;
  SimulatedScan scan = simulate_scan(b.mesh, o);
  const BodyMeasurements cloud = measure_point_cloud(scan.cloud.P);
  for (const char* name : {"waist", "hip", "knee", "calf"}) {
    ASSERT_TRUE(cloud.find(name)->measured) << name << ": " << cloud.find(name)->note;
    EXPECT_NEAR(cloud.find(name)->value, mesh.find(name)->value, 0.015) << name;
  }
  // Cut away the front of the left knee: the knee girth is reported as not measured, not guessed.
  const Eigen::Vector3d knee = cloud.features.knee[kLeft];
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < scan.cloud.size(); ++i) {
    const Eigen::RowVector3d p = scan.cloud.P.row(i);
    if (!(std::abs(p.y() - knee.y()) < 0.03 && p.x() > cloud.features.axis_x && p.z() > knee.z())) keep.push_back(i);
  }
  Eigen::MatrixXd holed(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) holed.row(static_cast<Eigen::Index>(k)) = scan.cloud.P.row(keep[k]);
  const BodyMeasurements h = measure_point_cloud(holed);
  EXPECT_FALSE(h.find("knee")->measured);
  EXPECT_NE(h.find("knee")->note.find("not closed"), std::string::npos);
  EXPECT_TRUE(h.find("waist")->measured);
  EXPECT_THROW(measure_point_cloud(Eigen::MatrixXd::Random(100, 3)), InvalidInput);
}

TEST(Measurements, ScanOfAHeavyWomanFlagsTheBustBandInsteadOfGuessing) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  // f08: the scanner does not see the gap between arm and torso just below the armpit, so the arms
  // separate 2.1 cm too low, the bust band ends below her bust and the belly below it is fuller.
  const Body b = build_body(model, make_subject_specs(model, 1, 16)[7].spec);
  const BodyMeasurements mesh = measure_body(b.mesh.V, b.mesh.F);
  const BodyMeasurements scan = measure_point_cloud(simulate_scan(b.mesh).cloud.P);
  EXPECT_FALSE(mesh.features.torso_levels_doubtful);
  EXPECT_TRUE(scan.features.torso_levels_doubtful);
  for (const char* name : {"bust", "underbust", "waist"}) {
    EXPECT_TRUE(mesh.find(name)->measured) << name;
    EXPECT_FALSE(scan.find(name)->measured) << name;
    EXPECT_NE(scan.find(name)->note.find("fuller below the bust band"), std::string::npos) << scan.find(name)->note;
  }
  EXPECT_TRUE(scan.find("hip")->measured);
  EXPECT_NEAR(scan.find("hip")->value, mesh.find("hip")->value, 0.01);
}

TEST(Measurements, ThighsThatTouchInAScanAreReportedNotMeasuredTwice) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  // f05: the scanner does not see the narrow gap between her thighs 2 cm below the crotch, so the
  // section there goes round both legs (it measured 36 cm too much before this was checked).
  const Body b = build_body(model, make_subject_specs(model, 1, 16)[4].spec);
  const BodyMeasurements mesh = measure_body(b.mesh.V, b.mesh.F);
  const BodyMeasurements scan = measure_point_cloud(simulate_scan(b.mesh).cloud.P);
  ASSERT_TRUE(mesh.find("thigh")->measured) << mesh.find("thigh")->note;
  EXPECT_FALSE(scan.find("thigh")->measured) << scan.find("thigh")->value;
  EXPECT_NE(scan.find("thigh")->note.find("legs touch"), std::string::npos) << scan.find("thigh")->note;
  for (const char* name : {"knee", "calf"}) {
    ASSERT_TRUE(scan.find(name)->measured) << name << ": " << scan.find(name)->note;
    EXPECT_NEAR(scan.find(name)->value, mesh.find(name)->value, 0.01) << name;
  }
}
