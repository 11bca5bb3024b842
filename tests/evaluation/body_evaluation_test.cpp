#include "posekit/evaluation/body_evaluation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "posekit/body/parts.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/datasets/robustness.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/segmentation/body_segmentation.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/layered_representation.h"
#include "posekit/shape/measurements.h"
#include "testing/temp_dir.h"

namespace posekit {
namespace {

/// The failures real data showed, reproduced on generated bodies: an X-up registration in mm with
/// bent arms and fists, a booth scan with its head anonymised, hands cut, soles open, holes and
/// floating bits, cut hands alone, a head cut off below the chin, floating bits alone, and nearly
/// straight arms (elbows_bent: 28 degrees for this list's first shape).
std::string make_set(const test::TempDir& dir) {
  RobustnessOptions o;
  o.data_root = test::test_data_root();
  o.shapes = 1;
  o.only = {"xup_mm_bent", "scanner", "hands_cut", "no_head", "components", "elbows_bent"};
  const std::string out = dir.file("set");
  make_robustness_set(out, o);
  return out;
}

TEST(RobustnessSet, RealDataFailuresAreMeasuredSegmentedOrNamedNeverSilent) {
  ASSERT_FALSE(test::test_data_root().empty()) << "POSEKIT_DATA does not point at the MakeHuman assets";
  test::TempDir dir;
  const std::string set = make_set(dir);
  const BodyEvaluation ev = evaluate_bodies(set);
  ASSERT_EQ(ev.bodies.size(), 6u);
  for (const BodyResult& b : ev.bodies) {
    EXPECT_TRUE(b.unit_right) << b.name;
    EXPECT_TRUE(b.orientation_right) << b.name << ": " << b.orientation;
    // Each used to be refused as "not a standing body" or "an arm was not found".
    EXPECT_TRUE(b.measured) << b.name << ": " << b.measure_error;
    for (const char* g : {"bust", "waist", "hip"}) {
      auto it = b.girth_error.find(g);
      if (it != b.girth_error.end()) EXPECT_LE(std::abs(it->second), iso_allowable_girth_error(g)) << b.name << " " << g;
      else EXPECT_FALSE(b.girth_not_measured.at(g).empty()) << b.name << " " << g << " has no reason";
    }
    // Without a trained model's prior the torso joints sit at typical fractions, several cm off by
    // design (posekit segment --model is the accurate path; eval bodies --model measures it): only
    // orientation and girths are held to "never silent" here.
    for (const auto& s : b.silent_nonsense) EXPECT_EQ(s.rfind("skeleton passed", 0), 0u) << b.name << ": " << s;
    if (!b.segmented) {  // refused loudly, with the cause
      EXPECT_FALSE(b.segment_error.empty()) << b.name;
    }
    // Each limb segment's length error is bounded by its two joints' errors.
    if (b.joint_error.empty()) continue;
    ASSERT_EQ(b.segment_length_error.size(), 8u) << b.name;
    for (const auto& [part, e] : b.segment_length_error) {
      int p = 0;
      while (part_name(p) != part) ++p;
      EXPECT_LE(std::abs(e), b.joint_error.at(joint_name(p - 1)) + b.joint_error.at(joint_name(p)) + 1e-12) << b.name << " " << part;
    }
  }
}

TEST(RobustnessSet, AJointTheFitSaysItGuessedIsNotSilentAndAnotherStillIs) {
  // A scanner cut the hands: the fit held the wrists and said so; a wrist 80 mm off is then no
  // silent result, an elbow 60 mm off still is.
  BodyResult r;
  r.by_body_model = r.segmented = r.orientation_right = r.unit_right = true;
  for (int j = 0; j < kNumJoints; ++j) r.joint_error[joint_name(j)] = 0.01;
  r.joint_error["left_wrist"] = 0.08;
  r.segmentation_agreement = 0.99;
  BodyResult unsaid = r;
  flag_silent_nonsense(true, &unsaid);
  ASSERT_EQ(unsaid.silent_nonsense.size(), 1u);
  EXPECT_NE(unsaid.silent_nonsense[0].find("left_wrist 80 mm off"), std::string::npos) << unsaid.silent_nonsense[0];
  r.guessed_joints = {"left_wrist", "right_wrist"};
  BodyResult said = r;
  flag_silent_nonsense(true, &said);
  EXPECT_TRUE(said.silent_nonsense.empty());
  r.joint_error["left_elbow"] = 0.06;
  flag_silent_nonsense(true, &r);
  ASSERT_EQ(r.silent_nonsense.size(), 1u);
  EXPECT_NE(r.silent_nonsense[0].find("left_elbow 60 mm off"), std::string::npos) << r.silent_nonsense[0];
}

Eigen::Vector3d truth_joint(const nlohmann::json& truth, const std::string& name) {
  const auto& j = truth["joints"][name];
  return Eigen::Vector3d(j[0], j[1], j[2]);
}

TEST(RobustnessSet, CutHandsAreLeftOutOfTheSegmentationAndStraightElbowsFound) {
  ASSERT_FALSE(test::test_data_root().empty());
  test::TempDir dir;
  const std::string set = make_set(dir);
  // Cut hands: the representation's hand layers fall on the stump. They used to label it hand and
  // fail the checks ("left_hand and right_hand differ in area 803%", a wrist 19 cm from its border).
  for (const char* name : {"s01_hands_cut", "s01_scanner"}) {
    const auto truth = nlohmann::json::parse(read_file_bytes(set + "/truth/" + name + ".json"));
    const TriangleMesh file = read_mesh(set + "/bodies/" + name + ".ply");
    TriangleMesh mesh;
    const BodyFeatures f = find_body_features(file.V, file.F, &mesh);
    ASSERT_TRUE(f.hand_cut[kLeft] && f.hand_cut[kRight]) << name;
    const BodySegmentation s = segment_standing_body(mesh.V, mesh.F, build_layered_representation(mesh.V, mesh.F, f), f, nullptr);
    EXPECT_TRUE(s.check.ok()) << name << ": " << s.check.summary();
    EXPECT_EQ((s.segmentation.triangle_part.array() == kLeftHand).count(), 0) << name;
    EXPECT_EQ((s.segmentation.triangle_part.array() == kRightHand).count(), 0) << name;
    for (const char* joint : {"left_wrist", "right_wrist", "left_elbow", "right_elbow"})
      EXPECT_LT((s.joints.row(find_joint_index(joint)).transpose() - truth_joint(truth, joint)).norm(), 0.03) << name << " " << joint;
  }
  // A nearly straight arm has little kink to find: at 23-30 degrees of flexion the elbow drifted
  // 6-7 cm along the arm, at 8 degrees 11-14 cm.
  const auto truth = nlohmann::json::parse(read_file_bytes(set + "/truth/s01_elbows_bent.json"));
  ASSERT_LT(truth["done"]["elbow_flexion_deg"].get<double>(), 30);
  const TriangleMesh straight = read_mesh(set + "/bodies/s01_elbows_bent.ply");
  const BodyFeatures f = find_body_features(straight.V, straight.F);
  EXPECT_LT((f.elbow[kLeft] - truth_joint(truth, "left_elbow")).norm(), 0.03);
  EXPECT_LT((f.elbow[kRight] - truth_joint(truth, "right_elbow")).norm(), 0.03);
}

TEST(RobustnessSet, CutHandsPutTheWristsAtTheCutAndACutHeadLeavesTheStatureUnmeasured) {
  ASSERT_FALSE(test::test_data_root().empty());
  test::TempDir dir;
  const std::string set = make_set(dir);
  const auto truth = nlohmann::json::parse(read_file_bytes(set + "/truth/s01_hands_cut.json"));
  const TriangleMesh hands = read_mesh(set + "/bodies/s01_hands_cut.ply");
  const BodyFeatures f = find_body_features(hands.V, hands.F);
  for (int side : {kLeft, kRight}) {
    EXPECT_TRUE(f.hand_cut[side]);
    const auto& w = truth["joints"][side == kLeft ? "left_wrist" : "right_wrist"];
    EXPECT_LT((f.wrist[side] - Eigen::Vector3d(w[0], w[1], w[2])).norm(), 0.02);
  }
  const TriangleMesh headless = read_mesh(set + "/bodies/s01_no_head.ply");
  const BodyMeasurements m = measure_body(headless.V, headless.F);
  EXPECT_TRUE(m.features.head_cut);
  EXPECT_FALSE(m.stature_measured);
  EXPECT_NEAR(m.stature, nlohmann::json::parse(read_file_bytes(set + "/truth/s01_no_head.json"))["body"]["stature_m"].get<double>(),
              0.06);  // estimated from where the arms separate
  EXPECT_FALSE(m.find("neck")->measured);
}

TEST(RobustnessSet, ThighsJoinedIntoOneSurfaceLeaveTheCrotchAboveTheJoin) {
  ASSERT_FALSE(test::test_data_root().empty());
  test::TempDir dir;
  RobustnessOptions o;
  o.data_root = test::test_data_root();
  o.shapes = 4;
  o.only = {"thighs_fused"};
  make_robustness_set(dir.file("set"), o);
  // A scan's reconstruction joins touching thighs into one surface: its sections there enclose the
  // body's axis, and were taken for the pelvis. s03's crotch fell 13 cm and its hips with it. s04's
  // tunnel between the thighs left a small loop inside the crotch's section, taken for the torso:
  // the crotch moved 18 mm forward and both hips 30 mm.
  for (const char* name : {"s01_thighs_fused", "s02_thighs_fused", "s03_thighs_fused", "s04_thighs_fused"}) {
    const auto truth = nlohmann::json::parse(read_file_bytes(dir.file("set") + "/truth/" + name + ".json"));
    const TriangleMesh mesh = read_mesh(dir.file("set") + "/bodies/" + name + ".ply");
    ASSERT_TRUE(validate_mesh(mesh).watertight) << name;
    TriangleMesh surface;
    const BodyFeatures f = find_body_features(mesh.V, mesh.F, &surface);
    EXPECT_NEAR(f.crotch_y, truth["levels_y"]["crotch"].get<double>(), 0.02) << name;
    // Each leg's layers take their side of a joined section: s02's left thigh part was 82% larger.
    const BodySegmentation s =
        segment_standing_body(surface.V, surface.F, build_layered_representation(surface.V, surface.F, f), f, nullptr);
    EXPECT_TRUE(s.check.ok()) << name << ": " << s.check.summary();
    EXPECT_LT((f.hip[kLeft] - truth_joint(truth, "left_hip")).norm(), 0.02) << name;
    EXPECT_LT((f.hip[kRight] - truth_joint(truth, "right_hip")).norm(), 0.02) << name;
    bool said = false;
    for (const std::string& w : f.warnings) said = said || w.find("thighs are joined") != std::string::npos;
    EXPECT_TRUE(said) << name;
  }
}

TEST(RobustnessSet, AnUnknownVariationOrAFolderThatIsNoSetIsANamedError) {
  test::TempDir dir;
  RobustnessOptions o;
  o.data_root = test::test_data_root();
  o.only = {"moonwalk"};
  EXPECT_THROW(make_robustness_set(dir.file("x"), o), InvalidInput);
  EXPECT_THROW(evaluate_bodies(dir.path()), IoError);
}

}  // namespace
}  // namespace posekit
