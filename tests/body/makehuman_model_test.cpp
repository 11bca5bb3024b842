#include "posekit/body/makehuman_model.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/winding_number.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {

double stature(const Body& b) { return b.mesh.V.col(1).maxCoeff() - b.mesh.V.col(1).minCoeff(); }

/// Tape girth of the torso at the waist: the convex hull of the section loop nearest the body axis,
/// halfway between the lower-back and upper-back joints.
double waist_girth(const MakeHumanModel& model, const Body& b) {
  const Eigen::MatrixXd J = joint_centres(model.rig, b);
  const double y = 0.5 * (J(find_joint_index("lower_back"), 1) + J(find_joint_index("upper_back"), 1));
  const auto loops = slice_mesh(b.mesh.V, b.mesh.F, Eigen::Vector3d::UnitY(), y);
  const int torso = nearest_loop(loops, Eigen::Vector3d(0, y, 0));
  return convex_hull_perimeter(loops.at(torso).points, Eigen::Vector3d::UnitY());
}

BodySpec spec(double gender, double weight, double muscle = 0.5, double height = 0.5) {
  BodySpec s;
  s.gender = gender;
  s.weight = weight;
  s.muscle = muscle;
  s.height = height;
  return s;
}

}  // namespace

TEST(MakeHumanModel, DefaultBodyHas13380VerticesAndIsWatertight) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Body b = build_body(model, BodySpec{});
  EXPECT_EQ(b.mesh.num_vertices(), 13380);
  const MeshReport r = validate_mesh(b.mesh);
  EXPECT_TRUE(r.watertight) << r.boundary_loops << " boundary loops";
  EXPECT_EQ(r.components, 1);
  EXPECT_GT(r.signed_volume, 0.0);  // outward-facing triangles
  EXPECT_EQ(model.rig.num_bones(), 163);
}

TEST(MakeHumanModel, MaleSliderMakesATallerBody) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const double female = stature(build_body(model, spec(0, 0.5))), male = stature(build_body(model, spec(1, 0.5)));
  EXPECT_GT(male, female + 0.05) << "female " << female << " m, male " << male << " m";
}

TEST(MakeHumanModel, WeightSliderWidensTheWaist) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  for (double g : {0.0, 1.0}) {
    const double thin = waist_girth(model, build_body(model, spec(g, 0))), heavy = waist_girth(model, build_body(model, spec(g, 1)));
    EXPECT_GT(heavy, thin + 0.05) << "gender " << g << ": waist " << thin << " m vs " << heavy << " m";
    EXPECT_GT(thin, 0.5);
    EXPECT_LT(heavy, 1.5);
  }
}

TEST(MakeHumanModel, HeightSliderSpansAdultStatures) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  // Measured: female 1.37 .. 2.02 m and male 1.51 .. 2.16 m for height 0.2 .. 0.8 (linear in the
  // slider, as the macro rule makes it): the range covers adults of 1.5 .. 1.9 m with room to spare.
  for (double g : {0.0, 1.0}) {
    double previous = 0;
    for (double h : {0.2, 0.35, 0.5, 0.65, 0.8}) {
      const double s = stature(build_body(model, spec(g, 0.5, 0.5, h)));
      EXPECT_GT(s, previous + 0.05) << "gender " << g << " height " << h;
      previous = s;
    }
  }
  const double short_female = stature(build_body(model, spec(0, 0.5, 0.5, 0.2)));
  const double tall_male = stature(build_body(model, spec(1, 0.5, 0.5, 0.8)));
  RecordProperty("stature_range_m", std::to_string(short_female) + " .. " + std::to_string(tall_male));
  EXPECT_GT(short_female, 1.30);
  EXPECT_LT(short_female, 1.50);
  EXPECT_GT(tall_male, 1.90);
  EXPECT_LT(tall_male, 2.25);
}

TEST(MakeHumanModel, JointCentresLieInsideTheBodyAcrossSliders) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  for (double g : {0.0, 1.0})
    for (double w : {0.0, 1.0})
      for (double m : {0.0, 1.0})
        for (double h : {0.2, 0.8}) {
          const Body b = build_body(model, spec(g, w, m, h));
          const Eigen::MatrixXd J = joint_centres(model.rig, b);
          for (int j = 0; j < kNumJoints; ++j)
            EXPECT_GT(winding_number(b.mesh.V, b.mesh.F, J.row(j).transpose()), 0.5)
                << joint_name(j) << " outside for gender " << g << " weight " << w << " muscle " << m << " height " << h;
        }
}

TEST(MakeHumanModel, ModifiersChangeTheirRegionAndRejectUnknownNames) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  ASSERT_NE(model.find_modifier("measure/measure-waist-circ-decr|incr"), nullptr);
  BodySpec s;
  const double base = waist_girth(model, build_body(model, s));
  s.modifiers["measure/measure-waist-circ-decr|incr"] = 1.0;
  EXPECT_GT(waist_girth(model, build_body(model, s)), base + 0.02);
  s.modifiers["measure/no-such-modifier"] = 0.5;
  EXPECT_THROW(build_body(model, s), InvalidInput);
}

TEST(MakeHumanModel, SpecRoundTripRegeneratesTheSameBits) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  test::TempDir dir;
  BodySpec s = spec(0.3, 0.7, 0.4, 0.6);
  s.modifiers["measure/measure-bust-circ-decr|incr"] = -0.35;
  s.african = 0.2;
  write_body_spec(dir.file("s.json"), s);
  const BodySpec r = read_body_spec(dir.file("s.json"));
  EXPECT_EQ(build_body(model, s).mesh.V, build_body(model, r).mesh.V);
}

TEST(MakeHumanModel, MacroWeightsFollowTheProductRule) {
  BodySpec s;
  s.gender = 0.25;
  s.muscle = 0.75;  // maxmuscle 0.5, averagemuscle 0.5
  s.weight = 0.5;   // averageweight 1
  EXPECT_NEAR(macro_target_weight({"female", "young", "maxmuscle", "averageweight"}, s), 0.75 * 0.5, 1e-12);
  EXPECT_NEAR(macro_target_weight({"male", "young", "minmuscle", "averageweight"}, s), 0.0, 1e-12);
  s.height = 0.9;
  EXPECT_NEAR(macro_target_weight({"male", "young", "averagemuscle", "averageweight", "maxheight"}, s), 0.25 * 0.5 * 0.8, 1e-12);
}

TEST(MakeHumanModel, BadInputNamesTheFile) {
  test::TempDir dir;
  EXPECT_THROW(body_spec_from_json("{\"gender\": 0.5, \"wieght\": 1}", "s.json"), InvalidInput);
  EXPECT_THROW(body_spec_from_json("{\"gender\": 1.5}", "s.json"), InvalidInput);
  EXPECT_THROW(body_spec_from_json("{\"gender\": ", "s.json"), IoError);
  // A data root whose macro targets are missing.
  namespace fs = std::filesystem;
  const std::string root = test::test_data_root();
  ASSERT_FALSE(root.empty());
  fs::create_directories(dir.file("3dobjs"));
  fs::create_symlink(fs::absolute(root + "/3dobjs/base.obj"), dir.file("3dobjs/base.obj"));
  try {
    load_makehuman_model(dir.path());
    FAIL() << "no exception";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("macrodetails"), std::string::npos) << e.what();
  }
  // One macro target missing from an otherwise complete copy is named.
  fs::create_directories(dir.file("targets"));
  for (const auto& e : fs::directory_iterator(root))
    if (e.path().filename() != "targets" && e.path().filename() != "3dobjs")
      fs::create_symlink(e.path(), dir.file(e.path().filename().string()));
  for (const auto& e : fs::directory_iterator(root + "/targets"))
    if (e.path().filename() != "macrodetails") fs::create_symlink(e.path(), dir.file("targets/" + e.path().filename().string()));
  for (const auto& e : fs::recursive_directory_iterator(root + "/targets/macrodetails")) {
    const fs::path to = dir.file("targets/macrodetails") / fs::relative(e.path(), root + "/targets/macrodetails");
    if (e.is_directory()) continue;
    fs::create_directories(to.parent_path());
    fs::create_symlink(e.path(), to);
  }
  fs::remove(dir.file("targets/macrodetails/height/male-young-maxmuscle-minweight-maxheight.target"));
  try {
    load_makehuman_model(dir.path());
    FAIL() << "no exception";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("male-young-maxmuscle-minweight-maxheight.target: missing"), std::string::npos) << e.what();
  }
}
