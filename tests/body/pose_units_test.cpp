#include "posekit/body/pose_units.h"

#include <gtest/gtest.h>

#include "posekit/core/error.h"
#include "posekit/core/point_grid.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {
Eigen::MatrixXd pose_with_units(const MakeHumanModel& model, const Body& b, const PoseUnits& units,
                                const std::vector<std::pair<std::string, double>>& w, std::vector<std::string>* skipped = nullptr) {
  const BonePose p = bone_pose_from_pose_units(model.rig, b, units, w, skipped);
  return linear_blend_skinning(b.mesh.V, model.weights, pose_bone_transforms(model.rig, b.bone_heads, p));
}

/// Largest distance from a vertex's mirror image (x -> -x) to its nearest vertex.
double mirror_asymmetry(const Eigen::MatrixXd& V) {
  const PointGrid grid(V);
  double worst = 0;
  for (Eigen::Index v = 0; v < V.rows(); v += 7) {
    double sq_distance = 0;
    grid.nearest(Eigen::Vector3d(-V(v, 0), V(v, 1), V(v, 2)), &sq_distance);
    worst = std::max(worst, std::sqrt(sq_distance));
  }
  return worst;
}
}  // namespace

TEST(PoseUnits, ReadsTheSixtyOneLeftSideUnits) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const PoseUnits units = read_pose_units(model.data_root + "/poseunits/body-poseunits.json");
  EXPECT_EQ(units.units.size(), 61u);
  for (const auto& [name, bones] : units.units)
    for (const auto& [bone, q] : bones) EXPECT_NEAR(q.norm(), 1.0, 1e-12) << name << " " << bone;
}

TEST(PoseUnits, RightUnitIsTheMirrorImageOfTheLeftOne) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const PoseUnits units = read_pose_units(model.data_root + "/poseunits/body-poseunits.json");
  const Body b = build_body(model, BodySpec{});
  const double rest_asymmetry = mirror_asymmetry(b.mesh.V);
  const std::pair<const char*, const char*> pairs[] = {{"UpperArmForwardLeft", "UpperArmForwardRight"},
                                                       {"LowerArmBend1Left1", "LowerArmBend1Right1"},
                                                       {"UpperLegBackwardLeft", "UpperLegBackwardRight"}};
  for (const auto& [left, right] : pairs) {
    const char* unit = left;
    const Eigen::MatrixXd U = pose_with_units(model, b, units, {{left, 1.0}, {right, 1.0}});
    EXPECT_GT((U - b.mesh.V).rowwise().norm().maxCoeff(), 0.05) << unit << " moves nothing";
    EXPECT_LT(mirror_asymmetry(U), rest_asymmetry + 1e-6) << unit << " is not mirrored";
  }
}

TEST(PoseUnits, WeightZeroIsRestAndUnknownNamesAreErrors) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const PoseUnits units = read_pose_units(model.data_root + "/poseunits/body-poseunits.json");
  const Body b = build_body(model, BodySpec{});
  EXPECT_LE((pose_with_units(model, b, units, {{"UpperArmForwardLeft", 0.0}}) - b.mesh.V).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_THROW(pose_with_units(model, b, units, {{"NoSuchUnit", 1.0}}), InvalidInput);
  EXPECT_THROW(pose_with_units(model, b, units, {{"UpperArmForwardLeft", 1.5}}), InvalidInput);
  std::vector<std::string> skipped;
  pose_with_units(model, b, units, {{"UpperArmForwardLeft", 1.0}}, &skipped);
  EXPECT_EQ(skipped, std::vector<std::string>{"shoulder.L"});  // a bone of another MakeHuman skeleton
}
