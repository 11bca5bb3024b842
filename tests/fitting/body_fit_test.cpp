#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <random>

#include "posekit/body/parts.h"
#include "posekit/body/skinning.h"
#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/point_grid.h"
#include "posekit/core/sanitizer.h"
#include "posekit/customization/model_silhouette_fit.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/fitting/fitted_measurements.h"
#include "posekit/population/ansur.h"
#include "posekit/population/survey_fit.h"
#include "posekit/registration/shape_space.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {

/// The body model of a small ANSUR II sample (the shapes of real adults), and held-out subjects'
/// fitted MakeHuman bodies to fit it to.
struct Population {
  std::unique_ptr<BodyModel> model;
  std::vector<BodySpec> held_out;
};

// The sanitizer build runs the two tests that need no accuracy from the space (the box, the two
// silhouettes) on a third of the sample: the same code, a third of the survey fits (each 8x slower).
#if POSEKIT_ADDRESS_SANITIZER
constexpr int kSampledSubjects = 24;
#else
constexpr int kSampledSubjects = 64;
#endif

const Population& population() {
  static const Population p = [] {
    Population out;
    const auto mh = test::makehuman();
    const std::string folder = find_ansur_root("", test::test_data_root());
    const auto subjects = sample_survey(read_ansur2(folder), kSampledSubjects, 11);
    const SurveyBodyFitter fitter(mh);
    const auto fits = fit_survey(fitter, subjects, 2);
    std::vector<BodySpec> specs;
    for (size_t i = 0; i < fits.size(); ++i) (i % 8 == 7 ? out.held_out : specs).push_back(fits[i].spec);
    out.model = std::make_unique<BodyModel>(population_shape_space(*mh, specs, "test sample"), *mh);
    return out;
  }();
  return p;
}

struct Truth {
  Eigen::MatrixXd V, joints;
  Eigen::MatrixXi F;
  Eigen::VectorXi part;
  BodyMeasurements standing;  ///< the body measured at rest (A-pose) by the rules
};

/// A held-out body posed by the rig (MakeHuman's 163 bones, dual quaternions: not the model's own
/// skinning), in metres and Y up.
Truth posed_body(const BodySpec& spec, const PartPose& pose) {
  const auto mh = test::makehuman();
  const Body rest = build_body(*mh, spec);
  const Body posed = skin_body(*mh, rest, bone_pose_from_part_pose(mh->rig, pose));
  return {posed.mesh.V, joint_centres(mh->rig, posed), posed.mesh.F, vertex_part_labels(*mh), measure_body(rest.mesh.V, rest.mesh.F)};
}

PartPose pose_of(const std::vector<std::pair<const char*, Eigen::Vector3d>>& joints_deg) {
  PartPose p;
  for (const auto& [name, v] : joints_deg) p.joint(find_joint_index(name)) = v * M_PI / 180;
  return p;
}

struct Score {
  double agreement = 0, worst_joint = 0;
  std::string worst;
};

Score score(const BodyFit& fit, const Truth& truth, const Eigen::Matrix3d& to_file) {
  Score s;
  int agree = 0;
  for (Eigen::Index v = 0; v < truth.part.size(); ++v) agree += fit.target_part[v] == truth.part[v];
  s.agreement = static_cast<double>(agree) / static_cast<double>(truth.part.size());
  const Eigen::MatrixXd joints = truth.joints * to_file.transpose();
  for (int j = 0; j < kNumJoints; ++j)
    if ((fit.joints.row(j) - joints.row(j)).norm() > s.worst_joint)
      s.worst_joint = (fit.joints.row(j) - joints.row(j)).norm(), s.worst = joint_name(j);
  return s;
}

}  // namespace

TEST(BodyFit, KneelingSittingAndArmsCloseInAnyFrame) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Population& pop = population();
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX(), Z = Eigen::Vector3d::UnitZ();
  struct Case {
    const char* name;
    PartPose pose;
    Eigen::Matrix3d to_file;  // Y-up body -> the file's frame
    double joint_bar;         // m
    // Girths on its surface against the body's at rest (arms moved, or kneeling) or as it stands
    // (another stance: a tape's reading).
    enum Girths { kNone, kAtRest, kAsItStands } measure = kNone;
  };
  const Eigen::Matrix3d z_up = (Eigen::AngleAxisd(M_PI / 2, X) * Eigen::AngleAxisd(8 * M_PI / 180, Z)).toRotationMatrix();
  const Eigen::Matrix3d facing_x = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  std::vector<Case> cases = {
      {"kneeling, tilted 8 degrees, Z up",
       pose_of({{"left_knee", 90 * X}, {"right_knee", 90 * X}, {"left_shoulder", -20 * X}, {"right_shoulder", -20 * X}}), z_up, 0.03},
      {"arms close, facing +X", pose_of({{"left_shoulder", -30 * Z}, {"right_shoulder", 30 * Z}}), facing_x, 0.03, Case::kAtRest},
      // Feet together: the stance changes the hip (up to 4 cm on the robustness set's shapes).
      {"feet together", pose_of({{"left_hip", -5 * Z}, {"right_hip", 5 * Z}}), Eigen::Matrix3d::Identity(), 0.03, Case::kAsItStands},
      // Hips flexed 90 degrees: the rig's many pelvis and thigh bones fold the groin otherwise than the
      // model's 16 parts do; with the priors pulling towards the rest the pelvis tipped back and the hips
      // came out 4-5 cm off, towards the recognised sitting pose 1.8 cm.
      {"sitting", pose_of({{"left_hip", -90 * X}, {"right_hip", -90 * X}, {"left_knee", 90 * X}, {"right_knee", 90 * X}}),
       Eigen::Matrix3d::Identity(), 0.03},
      // A deep squat with the arms crossed: neither is a pose a bone swung towards one direction says.
      {"squatting, arms crossed",
       pose_of({{"left_hip", -110 * X},
                {"right_hip", -110 * X},
                {"left_knee", 130 * X},
                {"right_knee", 130 * X},
                {"lower_back", 20 * X},
                {"left_shoulder", -45 * X},
                {"right_shoulder", -45 * X},
                {"left_elbow", Eigen::Vector3d(-60, -55, 0)},
                {"right_elbow", Eigen::Vector3d(-60, 55, 0)}}),
       Eigen::Matrix3d::Identity(), 0.03},
  };
  // The natural rest pose: the upper arms 5 degrees from the vertical, resting on the torso below
  // the armpits (the rule-based bust cannot be measured there).
  const BodySpec& touching_spec = pop.held_out[cases.size() % pop.held_out.size()];
  PartPose touching;
  {
    const auto mh = test::makehuman();
    const Eigen::MatrixXd J = joint_centres(mh->rig, build_body(*mh, touching_spec));
    for (const char* side : {"left", "right"}) {
      const Eigen::Vector3d arm =
          J.row(find_joint_index(std::string(side) + "_elbow")) - J.row(find_joint_index(std::string(side) + "_shoulder"));
      const double from_vertical = std::atan2(std::abs(arm.x()), -arm.y());
      const double sign = side[0] == 'l' ? -1 : 1;
      touching.joint(find_joint_index(std::string(side) + "_shoulder")) = sign * (from_vertical - 5 * M_PI / 180) * Z;
    }
  }
  cases.push_back({"arms touching the torso", touching, Eigen::Matrix3d::Identity(), 0.03, Case::kAtRest});
  for (size_t k = 0; k < cases.size(); ++k) {
    const Case& c = cases[k];
    const Truth truth = posed_body(pop.held_out[k % pop.held_out.size()], c.pose);
    const Eigen::MatrixXd target = truth.V * c.to_file.transpose();
    // frame_chosen reports the frame the fit ends in, before the fit ends (the last call counts: a
    // fit redone from another start calls it again).
    BodyFitOptions options;
    std::vector<Eigen::Matrix3d> frames_chosen;
    options.frame_chosen = [&](const Eigen::Matrix3d& to_fit_frame) { frames_chosen.push_back(to_fit_frame); };
    const BodyFit fit = fit_body_model(*pop.model, target, options);
    ASSERT_FALSE(frames_chosen.empty()) << c.name;
    EXPECT_TRUE(frames_chosen.back().isApprox(fit.to_fit_frame)) << c.name;
    // The frame is one of the six axis directions: a tilt stays in the pose (8 degrees here).
    EXPECT_GT((frames_chosen.back() * c.to_file * Eigen::Vector3d::UnitY()).y(), std::cos(15 * M_PI / 180)) << c.name << ": up is +Y";
    const Score s = score(fit, truth, c.to_file);
    std::printf("%s: start %s, agreement %.3f, worst joint %.1f mm (%s), coverage %.3f, p95 %.1f mm, |c| %.1f, %.2f s%s\n", c.name,
                fit.start.c_str(), s.agreement, 1000 * s.worst_joint, s.worst.c_str(), fit.coverage, 1000 * fit.target_p95,
                fit.shape_mahalanobis, fit.seconds, fit.confident ? "" : " (poor)");
    for (const auto& r : fit.reasons) std::printf("  reason: %s\n", r.c_str());
    EXPECT_GE(s.agreement, 0.95) << c.name;
    EXPECT_LE(s.worst_joint, c.joint_bar) << c.name;
    EXPECT_TRUE(fit.confident) << c.name;
    const FittedMeasurements m = measure_by_body_fit(*pop.model, fit, target, truth.F);
    // Seated or squatting (both thighs near the horizontal): the hip and thigh are not given
    // standing (the seated hip with that reason, its girth as posed still given; the others' sections
    // the pose folds); kneeling upright (thighs hanging) is not said to be seated.
    const std::string name(c.name);
    const bool thighs_raised = name.rfind("sitting", 0) == 0 || name.rfind("squatting", 0) == 0;
    for (size_t g = 0; g < m.target.girths.size(); ++g) {
      const Girth& girth = m.target.girths[g];
      // A girth refused for its section (not for the posture) has no section as posed either.
      if (!girth.measured && girth.note.find("seated or squatting") == std::string::npos)
        EXPECT_FALSE(std::isfinite(m.as_posed[g])) << c.name << ": " << girth.name << ": " << girth.note;
      if (girth.name != "hip" && girth.name != "thigh") continue;
      const bool said = girth.note.find("seated or squatting") != std::string::npos;
      std::printf("  %s: %s\n", girth.name.c_str(), girth.measured ? "measured" : girth.note.c_str());
      if (!thighs_raised) EXPECT_FALSE(said) << c.name << ": " << girth.name << ": " << girth.note;
      if (thighs_raised) EXPECT_FALSE(girth.measured) << c.name << ": " << girth.name;
      if (name == "sitting" && girth.name == "hip") {
        EXPECT_TRUE(said) << girth.note;
        EXPECT_TRUE(std::isfinite(m.as_posed[g])) << "the seated hip as posed";
      }
    }
    if (c.measure == Case::kNone) continue;
    // Girths on the body's own surface in the fitted body's planes, within ISO 20685-1's mean
    // absolute errors (bust 15 mm, waist and hip 12) of the standing body's.
    const BodyMeasurements truth_girths = c.measure == Case::kAtRest ? truth.standing : measure_body(truth.V, truth.F);
    for (const auto& [name, bar] : {std::pair<const char*, double>{"bust", 0.015}, {"waist", 0.012}, {"hip", 0.012}}) {
      const Girth *ours = m.target.find(name), *standing = truth_girths.find(name);
      ASSERT_TRUE(ours && standing && standing->measured) << name;
      EXPECT_TRUE(ours->measured) << c.name << ": " << name << ": " << ours->note;
      std::printf("  %s %.1f cm, truth %.1f cm, fitted body %.1f cm\n", name, 100 * ours->value, 100 * standing->value,
                  100 * m.fitted.find(name)->value);
      EXPECT_NEAR(ours->value, standing->value, bar) << c.name << ": " << name;
    }
    if (k + 1 != cases.size()) continue;
    // The target's waist pushed 15% out from its axis after the fit: its section no longer matches
    // the fitted body's, so the waist is refused, and it has no section as posed either.
    const Girth& waist = *m.target.find("waist");
    Eigen::MatrixXd pushed = target;
    for (Eigen::Index v = 0; v < pushed.rows(); ++v) {
      const Eigen::Vector3d d = pushed.row(v).transpose() - waist.point;
      const Eigen::Vector3d across = d - d.dot(waist.normal) * waist.normal;
      if (std::abs(d.dot(waist.normal)) < 0.02 && across.norm() < 0.2) pushed.row(v) += 0.15 * across.transpose();
    }
    const FittedMeasurements off = measure_by_body_fit(*pop.model, fit, pushed, truth.F);
    const auto w = static_cast<size_t>(
        std::find_if(off.target.girths.begin(), off.target.girths.end(), [](const Girth& g) { return g.name == "waist"; }) -
        off.target.girths.begin());
    ASSERT_LT(w, off.target.girths.size());
    EXPECT_FALSE(off.target.girths[w].measured);
    EXPECT_NE(off.target.girths[w].note.find("differs from the fitted body's"), std::string::npos) << off.target.girths[w].note;
    EXPECT_FALSE(std::isfinite(off.as_posed[w])) << off.as_posed[w];
  }
}

// The shape and the pose found together: held-out bodies at rest come back as themselves, vertex for
// vertex. Shape and pose fitted in turns crawled along the valley where wider shoulders and arms
// hung at another angle explain the surface alike: on these four bodies 3.6 mm between vertices and
// a worst joint 9.3 mm off on average (16 mm at worst), together 2.3 and 6.1 (11.6).
TEST(BodyFit, ShapeAndPoseTogetherGiveTheHeldOutBodiesBack) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Population& pop = population();
  constexpr int kBodies = 4;
  double vertex_mean = 0, worst_joint_mean = 0;
  for (size_t k = 0; k < kBodies; ++k) {
    const Truth truth = posed_body(pop.held_out[k], PartPose());
    const BodyFit fit = fit_body_model(*pop.model, truth.V);
    const Score s = score(fit, truth, Eigen::Matrix3d::Identity());
    const double apart = (fit.V - truth.V).rowwise().norm().mean();
    std::printf("body %zu: vertices %.1f mm apart on average, worst joint %.1f mm (%s), %.2f s%s\n", k, 1000 * apart, 1000 * s.worst_joint,
                s.worst.c_str(), fit.seconds, fit.confident ? "" : " (poor)");
    EXPECT_TRUE(fit.confident) << k;
    vertex_mean += apart / kBodies;
    worst_joint_mean += s.worst_joint / kBodies;
  }
  EXPECT_LE(vertex_mean, 0.003);
  EXPECT_LE(worst_joint_mean, 0.008);
}

// Legs as no library pose holds them (one thigh raised with the knee bent, the other leg back with
// the knee bent behind), the back bent and the arms apart, as in the robustness set's random poses.
// From the library's starts alone all eight held-out bodies so posed were fitted poor (the legs
// left 1-2 m off); with the legs searched 8 of 8 are confident, 7 with every joint within 3 cm.
TEST(BodyFit, LegsAsNoLibraryPoseHoldsThem) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Population& pop = population();
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX();
  const PartPose pose = pose_of({{"lower_back", Eigen::Vector3d(19, 7, 1)},
                                 {"left_hip", -76 * X},
                                 {"left_knee", 94 * X},
                                 {"right_hip", Eigen::Vector3d(11, 2, -16)},
                                 {"right_knee", 77 * X},
                                 {"left_shoulder", Eigen::Vector3d(-20, 9, 49)},
                                 {"left_elbow", Eigen::Vector3d(-33, -29, 3)},
                                 {"right_shoulder", Eigen::Vector3d(0, 0, 6)},
                                 {"right_elbow", Eigen::Vector3d(-46, 40, -5)}});
  const Truth truth = posed_body(pop.held_out[1], pose);
  const BodyFit fit = fit_body_model(*pop.model, truth.V);
  const Score s = score(fit, truth, Eigen::Matrix3d::Identity());
  std::printf("start %s, agreement %.3f, worst joint %.1f mm (%s), %.2f s%s\n", fit.start.c_str(), s.agreement, 1000 * s.worst_joint,
              s.worst.c_str(), fit.seconds, fit.confident ? "" : " (poor)");
  for (const auto& r : fit.reasons) std::printf("  reason: %s\n", r.c_str());
  EXPECT_TRUE(fit.confident);
  EXPECT_GE(s.agreement, 0.95);
  EXPECT_LE(s.worst_joint, 0.03);
}

// A crouch with the back bent (the 10-shape robustness set's s08 random pose): the library's poses
// matched it best upside down and filled the search's best starts, its upright ones cut before their
// arms were tried. Searched again with every up direction keeping its own best starts, 3 of the 8
// held-out bodies so posed are found upright (2 before; the others are refused, upside down); this
// is one that was not before.
TEST(BodyFit, ACrouchTheLibraryMatchesUpsideDownIsFoundUpright) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Population& pop = population();
  const Eigen::Vector3d X = Eigen::Vector3d::UnitX();
  const PartPose pose = pose_of({{"lower_back", Eigen::Vector3d(26, 12, 3)},
                                 {"neck", -9 * X},
                                 {"left_shoulder", Eigen::Vector3d(-10, 5, 56)},
                                 {"left_elbow", Eigen::Vector3d(11, 10, -1)},
                                 {"right_shoulder", Eigen::Vector3d(13, 0, -1)},
                                 {"right_elbow", Eigen::Vector3d(4, -3, 0)},
                                 {"left_hip", Eigen::Vector3d(-45, 4, 10)},
                                 {"left_knee", 23 * X},
                                 {"right_hip", Eigen::Vector3d(-33, -6, -19)},
                                 {"right_knee", 59 * X}});
  const Truth truth = posed_body(pop.held_out[4], pose);
  const BodyFit fit = fit_body_model(*pop.model, truth.V);
  const Score s = score(fit, truth, Eigen::Matrix3d::Identity());
  std::printf("start %s, up (%.0f %.0f %.0f), agreement %.3f, worst joint %.1f mm (%s), %.2f s%s\n", fit.start.c_str(), fit.up.x(),
              fit.up.y(), fit.up.z(), s.agreement, 1000 * s.worst_joint, s.worst.c_str(), fit.seconds, fit.confident ? "" : " (poor)");
  EXPECT_TRUE(fit.confident);
  EXPECT_GT(fit.up.y(), 0.99);
  EXPECT_GE(s.agreement, 0.95);
  EXPECT_LE(s.worst_joint, 0.03);
}

TEST(BodyFit, PosesTheSpacesBodyAboutItsOwnJointsAndRefusesANonBody) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Population& pop = population();
  const BodyModel& m = *pop.model;
  // At rest the shaped body is the space's, its joints the space's; a turned elbow moves only the
  // forearm and hand, about the elbow.
  Eigen::VectorXd c = Eigen::VectorXd::Zero(m.components());
  c[0] = 1.5, c[1] = -1;
  const ShapedBody body(m, c);
  Eigen::MatrixXd X;
  body.pose(PartPose{}, &X);
  EXPECT_LT((X - m.space().body(c)).cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_LT((body.posed_joints(PartPose{}) - m.space().joints(c)).cwiseAbs().maxCoeff(), 1e-12);
  const PartPose bent = pose_of({{"left_elbow", Eigen::Vector3d(60, 0, 0)}});
  body.pose(bent, &X);
  const Eigen::MatrixXd J = body.posed_joints(bent);
  EXPECT_LT((J.row(find_joint_index("left_elbow")) - body.joint_centres().row(find_joint_index("left_elbow"))).norm(), 1e-12);
  EXPECT_GT((J.row(find_joint_index("left_wrist")) - body.joint_centres().row(find_joint_index("left_wrist"))).norm(), 0.1);
  for (Eigen::Index v = 0; v < X.rows(); ++v)
    if (m.part_weights()[static_cast<size_t>(v)].size() == 1 && m.vertex_parts()[v] == kPelvis) {
      ASSERT_LT((X.row(v) - body.rest_vertices().row(v)).norm(), 1e-12) << v;
    }
  // The library's poses are named once each and within the joints' ranges.
  const auto library = pose_library(body.joint_centres());
  EXPECT_GE(library.size(), 15u);
  for (size_t i = 0; i < library.size(); ++i) {
    for (size_t k = 0; k < i; ++k) EXPECT_NE(library[i].name, library[k].name);
    for (int j = 0; j < kNumJoints; ++j) EXPECT_LE(library[i].pose.joint(j).norm() * 180 / M_PI, joint_limit_degrees(j)) << library[i].name;
  }
  // Motion frames join the library by how far they are from it and from each other, heading aside:
  // the A-pose turned about the vertical is no new pose, a frame with a raised knee is, once.
  std::vector<LibraryPose> frames;
  PartPose turned;
  turned.root_rotation = Eigen::Vector3d(0, 1.2, 0);
  frames.push_back({"turned a-pose", "turned a-pose", turned});
  PartPose knee = pose_of(
      {{"left_hip", Eigen::Vector3d(-100, 0, 0)}, {"left_knee", Eigen::Vector3d(110, 0, 0)}, {"left_shoulder", Eigen::Vector3d(0, 0, 60)}});
  for (const double heading : {0.3, 2.0}) {
    knee.root_rotation = Eigen::Vector3d(0, heading, 0);
    frames.push_back({"knee " + std::to_string(heading), "knee", knee});
  }
  const auto chosen = distinct_motion_poses(frames, library, 10, 30);
  ASSERT_EQ(chosen.size(), 1u);
  EXPECT_EQ(chosen[0].name.rfind("knee", 0), 0u);
  EXPECT_LT(chosen[0].pose.root_rotation.norm(), 1e-9);  // its heading taken off
  EXPECT_LT((pose_from_row(pose_row(knee)).joint_rotation[3] - knee.joint_rotation[3]).norm(), 1e-15);
  // A box of random points is no body: the fit says so, with its reason.
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(0, 1);
  Eigen::MatrixXd box(4000, 3);
  for (Eigen::Index i = 0; i < box.rows(); ++i) box.row(i) << u(rng), 1.8 * u(rng), 0.5 * u(rng);
  BodyFitOptions quick;
  quick.headings = 4, quick.shape_rounds = 1, quick.hypotheses_refined = 1;  // one start: no runner-up to retry
  quick.legs_searched = 1;                                                   // the second search (a poor fit's), on one start
  const BodyFit fit = fit_body_model(m, box, quick);
  EXPECT_FALSE(fit.confident);
  EXPECT_FALSE(fit.reasons.empty());
  // Its brief fits leave the box's corners far off, so no finish goes on to the shape (see
  // fit_body_model); the refusal itself is still the best start's fit, finished whole.
  EXPECT_GT(fit.coefficients.norm(), 0);
  EXPECT_TRUE(std::any_of(fit.stage_seconds.begin(), fit.stage_seconds.end(), [](const auto& s) { return s.first == "shape and pose"; }));
  EXPECT_THROW(fit_body_model(m, Eigen::MatrixXd::Zero(50, 3)), InvalidInput);
}

// The body model fitted to two silhouettes (issue 46, part 5, customize --method model): a held-out
// body of real proportions, its arms held 8 degrees nearer the body than the model's rest and turned
// 4 degrees, photographed by a phone at chest height aimed at the body's middle. Stature within 1
// cm, bust, waist and hip within 2 cm, the surface within 6 mm on average; and two silhouettes of
// a sack (no body) refused as not looking like their photos.
TEST(BodyFit, FittedToTwoSilhouettesFromAPhoneAtChestHeight) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const Population& pop = population();
  PartPose pose;
  pose.joint(find_joint_index("left_shoulder")) = Eigen::Vector3d(0, 0, -0.14);
  pose.joint(find_joint_index("right_shoulder")) = Eigen::Vector3d(0, 0, 0.14);
  const Truth truth = posed_body(pop.held_out[1], pose);
  TriangleMesh body;
  body.V = truth.V, body.F = truth.F;
  const Eigen::RowVector3d centre = body.V.colwise().mean();
  const Eigen::Matrix3d turn = Eigen::AngleAxisd(4 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  body.V = ((body.V.rowwise() - centre) * turn.transpose()).rowwise() + centre;
  const double floor = body.V.col(1).minCoeff(), mid = 0.5 * (floor + body.V.col(1).maxCoeff());
  PhotoCameras cams;
  cams.front = PinholeCamera::look_at(Eigen::Vector3d(centre.x(), floor + 1.3, centre.z() + 2.3),
                                      Eigen::Vector3d(centre.x(), mid, centre.z()), Eigen::Vector3d::UnitY(), 800, 1200, 1000);
  cams.side = PinholeCamera::look_at(Eigen::Vector3d(centre.x() + 2.3, floor + 1.3, centre.z()),
                                     Eigen::Vector3d(centre.x(), mid, centre.z()), Eigen::Vector3d::UnitY(), 800, 1200, 1000);
  const Silhouette front = silhouette_from_render(render_mesh(body, cams.front));
  const Silhouette side = silhouette_from_render(render_mesh(body, cams.side));
  const CustomizedBody fitted = customize_by_body_model(*pop.model, front, side, cams);
  const BodyMeasurements want = measure_body(body.V, body.F), got = measure_body(fitted.mesh.V, fitted.mesh.F);
  const double surface = TriangleTree(fitted.mesh.V, fitted.mesh.F).closest(body.V, 1).distance.mean();
  std::printf("stature %+.1f mm, surface %.1f mm, agreement %.3f\n", 1000 * (got.stature - want.stature), 1000 * surface,
              fitted.photo_agreement);
  EXPECT_NEAR(got.stature, want.stature, 0.01);
  EXPECT_LE(surface, 0.006);
  for (const char* name : {"bust", "waist", "hip"}) {
    const Girth *a = got.find(name), *b = want.find(name);
    ASSERT_TRUE(a && b && a->measured && b->measured) << name;
    std::printf("%s %+.1f mm\n", name, 1000 * (a->value - b->value));
    EXPECT_NEAR(a->value, b->value, 0.02) << name;
  }

  // A sack: an upright ellipse in both views, about as tall as a person.
  Silhouette sack = front;
  for (int v = 0; v < sack.height; ++v)
    for (int u = 0; u < sack.width; ++u) {
      const double x = (u - 400) / 150.0, y = (v - 600) / 380.0;
      sack.mask[static_cast<size_t>(v) * sack.width + u] = x * x + y * y <= 1 ? 255 : 0;
    }
  EXPECT_THROW(customize_by_body_model(*pop.model, sack, sack, cams), BelowConfidence);
}

namespace {

/// n points on the side of the cylinder of radius r from a to b (a golden-angle spiral).
Eigen::MatrixXd cylinder(const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r, int n) {
  const Eigen::Vector3d axis = (b - a).normalized();
  const Eigen::Vector3d u = axis.unitOrthogonal(), w = axis.cross(u);
  Eigen::MatrixXd P(n, 3);
  for (int i = 0; i < n; ++i) {
    const double t = (i + 0.5) / n, phi = 2.399963 * i;
    P.row(i) = (a + t * (b - a) + r * (std::cos(phi) * u + std::sin(phi) * w)).transpose();
  }
  return P;
}

Eigen::MatrixXd stacked(const std::vector<Eigen::MatrixXd>& parts) {
  Eigen::Index rows = 0;
  for (const auto& p : parts) rows += p.rows();
  Eigen::MatrixXd out(rows, 3);
  rows = 0;
  for (const auto& p : parts) out.middleRows(rows, p.rows()) = p, rows += p.rows();
  return out;
}

}  // namespace

// A start whose arms differ from the target's: stood on it by the boxes' centres it lies beside the
// target's trunk, by the median points near it, and centred on the cloud on it.
TEST(BodyFit, AStartWithOtherArmsIsStoodOnTheTrunk) {
  using V = Eigen::Vector3d;
  const std::vector<Eigen::MatrixXd> trunk = {
      cylinder(V(0, 0, 0), V(0, 0.6, 0), 0.15, 900), cylinder(V(0, 0.6, 0), V(0, 0.85, 0), 0.09, 200),
      cylinder(V(0.09, 0, 0), V(0.09, -0.85, 0), 0.07, 400), cylinder(V(-0.09, 0, 0), V(-0.09, -0.85, 0), 0.07, 400)};
  // The target's arms hang; the start's left arm is half raised to the side and its right arm forward.
  std::vector<Eigen::MatrixXd> target_parts = trunk, start_parts = trunk;
  target_parts.push_back(cylinder(V(0.21, 0.55, 0), V(0.21, -0.05, 0), 0.045, 200));
  target_parts.push_back(cylinder(V(-0.21, 0.55, 0), V(-0.21, -0.05, 0), 0.045, 200));
  start_parts.push_back(cylinder(V(0.2, 0.5, 0), V(0.6, 0.15, 0), 0.045, 200));
  start_parts.push_back(cylinder(V(-0.21, 0.5, 0.05), V(-0.21, 0.15, 0.45), 0.045, 200));
  const Eigen::RowVector3d where(0.4, 1.0, -0.3);
  const Eigen::MatrixXd target = stacked(target_parts).rowwise() + where;
  Eigen::MatrixXd start = stacked(start_parts);
  auto box_centre = [](const Eigen::MatrixXd& P) { return Eigen::RowVector3d(0.5 * (P.colwise().minCoeff() + P.colwise().maxCoeff())); };
  Eigen::RowVector3d by_boxes = box_centre(target) - box_centre(start);
  by_boxes.y() = target.col(1).minCoeff() - start.col(1).minCoeff();
  const Eigen::RowVector3d stood = stand_on_cloud(start, target);
  start.rowwise() += stood;
  const PointGrid grid(target, 0.075);
  const Eigen::RowVector3d centred = stood + centre_on_cloud(target, grid, 0.15, 0.075, 3, &start);
  std::printf("the trunk off by %.1f mm stood on the boxes' centres, %.1f mm on the medians, %.1f mm centred\n",
              1000 * (by_boxes - where).norm(), 1000 * (stood - where).norm(), 1000 * (centred - where).norm());
  EXPECT_GT((by_boxes - where).norm(), 0.2);
  EXPECT_LT((stood - where).norm(), 0.03);
  EXPECT_LT((centred - where).norm(), 0.01);
}
