#include "posekit/deformation/pose_model.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "posekit/core/error.h"
#include "posekit/deformation/segmentation_calibration.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/checksum.h"
#include "testing/makehuman_fixture.h"
#include "testing/small_dataset.h"

using namespace posekit;

TEST(PoseModel, FitsTheTrainingPosesAndSavesLosslessly) {
  const auto& ds = test::small_dataset();
  const PoseModel model = train_on_dataset(ds.root);
  EXPECT_GT(model.training_poses, 10);
  EXPECT_EQ(model.coefficients.rows(), model.template_F.rows());
  EXPECT_EQ(model.coefficients.cols(), 63);
  EXPECT_LT(model.fit_rms, 0.03);  // measured 0.012 on the full dataset
  // Zero pose: T^Q is the identity everywhere (the bias of Eq. 4 is fixed there).
  const Eigen::MatrixXd Q = predict_nonrigid(model, PartPose{});
  for (Eigen::Index k = 0; k < Q.rows(); k += 97)
    for (int e = 0; e < 9; ++e) ASSERT_NEAR(Q(k, e), e % 4 == 0 ? 1.0 : 0.0, 1e-12);

  test::TempDir dir;
  write_pose_model(dir.file("m.pkm"), model);
  const PoseModel back = read_pose_model(dir.file("m.pkm"));
  EXPECT_EQ(back.template_F, model.template_F);
  EXPECT_EQ(back.triangle_part, model.triangle_part);
  EXPECT_EQ(back.triangle_joints, model.triangle_joints);
  EXPECT_TRUE(back.coefficients == model.coefficients);
  EXPECT_TRUE(back.template_V == model.template_V);
  EXPECT_EQ(dir.count(), 1);  // no temporary left behind

  // Truncated, foreign and corrupted files name the file.
  const std::string bytes = read_file_bytes(dir.file("m.pkm"));
  dir.write("cut.pkm", bytes.substr(0, bytes.size() / 2));
  dir.write("foreign.pkm", "ply\nformat ascii 1.0\n");
  // Edits below are re-sealed with a fresh CRC, so each reaches the check it is aimed at.
  auto sealed = [](std::string b) {
    const std::uint32_t crc = crc32(b.data(), b.size() - 4);
    std::memcpy(&b[b.size() - 4], &crc, 4);
    return b;
  };
  std::string nan_bytes = bytes;
  const double nan = std::nan("");
  // The last coefficient, before the (empty) segmentation prior's count and neighbours and the CRC.
  std::memcpy(&nan_bytes[nan_bytes.size() - 4 - 8 - sizeof(double)], &nan, sizeof(double));
  dir.write("nan.pkm", sealed(nan_bytes));
  std::string rms_bytes = bytes;
  std::memcpy(&rms_bytes[8 + 4 * 5 + 4], &nan, sizeof(double));  // after the magic, 5 counts and the pose count
  dir.write("nan_rms.pkm", sealed(rms_bytes));
  std::string huge = bytes;
  const std::uint32_t forty_million = 40000000;
  std::memcpy(&huge[12], &forty_million, 4);  // the vertex count: 960 MB if allocated before the size check
  dir.write("huge.pkm", sealed(huge));
  const std::vector<std::pair<const char*, const char*>> bad = {
      {"cut.pkm", "checksum"},          {"foreign.pkm", "not a posekit pose model"},
      {"nan.pkm", "NaN"},               {"nan_rms.pkm", "fit RMS nan"},
      {"huge.pkm", "40000000 x 3 values"}, {"missing.pkm", "missing.pkm"}};
  for (const auto& [name, phrase] : bad) {
    try {
      read_pose_model(dir.file(name));
      FAIL() << name;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(phrase), std::string::npos) << e.what();
    }
  }
  // Any flipped bit is refused (the fuzzer found 15 of 18 accepted before the checksum).
  std::mt19937 rng(11);
  int refused = 0;
  constexpr int kFlips = 40;
  for (int k = 0; k < kFlips; ++k) {
    std::string flipped = bytes;
    flipped[rng() % flipped.size()] ^= static_cast<char>(1u << (rng() % 8));
    try {
      read_pose_model(dir.write("flip.pkm", flipped));
    } catch (const IoError& e) {
      refused += std::string(e.what()).find("flip.pkm") != std::string::npos;
    }
  }
  EXPECT_EQ(refused, kFlips);
  // Version 2 files (no checksum) are still read.
  std::string v2 = bytes.substr(0, bytes.size() - 4);
  const std::uint32_t two = 2;
  std::memcpy(&v2[8], &two, 4);
  EXPECT_TRUE(read_pose_model(dir.write("v2.pkm", v2)).coefficients == model.coefficients);
}

TEST(PoseModel, KeepsItsSegmentationPrior) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  PoseModel m = train_on_dataset(test::small_dataset().root);
  CalibrationOptions o;
  o.bodies = 4;
  int progress_calls = 0, skipped = -1;
  o.progress = [&](int done, int total) {
    ++progress_calls;
    EXPECT_LE(done, total);
  };
  m.segmentation_prior = calibrate_segmentation(model, o, &skipped);
  EXPECT_EQ(progress_calls, 5);
  ASSERT_EQ(static_cast<int>(m.segmentation_prior.bodies.size()) + skipped, 5);
  ASSERT_GE(m.segmentation_prior.bodies.size(), 3u);

  test::TempDir dir;
  write_pose_model(dir.file("m.pkm"), m);
  const PoseModel back = read_pose_model(dir.file("m.pkm"));
  ASSERT_EQ(back.segmentation_prior.bodies.size(), m.segmentation_prior.bodies.size());
  EXPECT_EQ(back.segmentation_prior.neighbours, m.segmentation_prior.neighbours);
  for (size_t b = 0; b < back.segmentation_prior.bodies.size(); ++b) {
    const CalibrationBody &x = back.segmentation_prior.bodies[b], &y = m.segmentation_prior.bodies[b];
    EXPECT_EQ(x.labels, y.labels);
    for (int r = 0; r < kShapeRegions; ++r) EXPECT_EQ(x.shape.region[r], y.shape.region[r]);
    EXPECT_EQ(x.skeleton.joints.triangle, y.skeleton.joints.triangle);
    EXPECT_TRUE(x.skeleton.joints.bary == y.skeleton.joints.bary && x.skeleton.joints.offset == y.skeleton.joints.offset);
    EXPECT_EQ(x.skeleton.torso_fraction, y.skeleton.torso_fraction);
  }
  // Body 0 is the default body: the template's own labelling.
  EXPECT_EQ(segmentation_prior_of(m).bodies.size(), m.segmentation_prior.bodies.size());
  PoseModel bare = m;
  bare.segmentation_prior = {};
  const SegmentationPrior own = segmentation_prior_of(bare);
  ASSERT_EQ(own.bodies.size(), 1u);
  EXPECT_EQ(own.bodies[0].labels, m.segmentation_prior.bodies[0].labels);

  // A prior cut short or with a label outside the 16 parts names the file.
  const std::string bytes = read_file_bytes(dir.file("m.pkm"));
  dir.write("cut_prior.pkm", bytes.substr(0, bytes.size() - 100));
  std::string bad_label = bytes;
  const CalibrationBody& last = m.segmentation_prior.bodies.back();
  const size_t skeleton_bytes = kNumJoints * (4 + 6 * 8) + 3 * 8;
  bad_label[bytes.size() - skeleton_bytes - 1] = static_cast<char>(200);  // the last body's last label
  ASSERT_EQ(last.labels.size() > 0, true);
  dir.write("bad_label.pkm", bad_label);
  for (const char* name : {"cut_prior.pkm", "bad_label.pkm"}) {
    try {
      read_pose_model(dir.file(name));
      FAIL() << name;
    } catch (const IoError& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

TEST(PoseModel, RejectsDatasetsItCannotLearnFrom) {
  PoseDataset data;
  data.F = Eigen::MatrixXi(1, 3);
  data.F << 0, 1, 2;
  data.V.push_back(Eigen::MatrixXd::Identity(3, 3));
  data.names.push_back("rest");
  data.has_pose.push_back(true);
  data.poses.emplace_back();
  data.test.push_back(false);
  data.rest_name = "rest";
  TrainingOptions o;
  o.triangle_part = Eigen::VectorXi::Zero(1);
  o.joint_centres = Eigen::MatrixXd::Zero(kNumJoints, 3);
  EXPECT_THROW(train_pose_model(data, o), InvalidInput);  // one example only
  data.V.push_back(Eigen::MatrixXd::Identity(3, 3));
  data.names.push_back("bad");
  data.has_pose.push_back(true);
  data.poses.emplace_back();
  data.poses.back().joint_rotation[2] = Eigen::Vector3d(std::nan(""), 0, 0);
  data.test.push_back(false);
  try {
    train_pose_model(data, o);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("'bad'"), std::string::npos) << e.what();
  }
}

TEST(PoseModel, LearnsFromAFolderOfRegisteredMeshesWithoutLabels) {
  // A user's SCAPE-style folder: meshes with same-named pose JSONs, no manifest, no labels.
  const auto& ds = test::small_dataset();
  test::TempDir dir;
  for (const auto& e : std::filesystem::directory_iterator(ds.root + "/pose_dataset"))
    std::filesystem::copy_file(e.path(), dir.file(e.path().filename().string()));
  const PoseModel model = train_on_dataset(dir.path());
  const PoseModel annotated = train_on_dataset(ds.root);
  EXPECT_GT(model.training_poses, annotated.training_poses);  // nothing is held out without a manifest
  // The template is the rest example, not the first file.
  EXPECT_LT((model.template_V - annotated.template_V).cwiseAbs().maxCoeff(), 1e-12);
  // Its own skeleton: limb joints from the body's features, within 3 cm of the rig's.
  for (const char* name : {"left_shoulder", "right_elbow", "left_knee", "right_ankle", "left_wrist"}) {
    const int j = find_joint_index(name);
    EXPECT_LT((model.joint_centres.row(j) - annotated.joint_centres.row(j)).norm(), 0.03) << name;
  }
  PoseEvaluationOptions o;
  o.subjects = false;
  const PoseEvaluation ev = evaluate_poses(ds.root, std::make_shared<const PoseModel>(model), o);
  EXPECT_LT(ev.template_errors.front().all.mean_mm, 10.0);  // measured 5.7 mm on the full dataset
}

TEST(PoseModel, WritesFuzzSeedsThatReadBack) {
  // Seeds of the .pkm fuzz target (scripts/fuzz.sh): a model small enough to mutate quickly,
  // with and without a segmentation prior, as version 3 and as version 2 (no checksum, so
  // mutations reach the counts and values). Written to $POSEKIT_FUZZ_SEEDS/pkm when set.
  test::TempDir tmp;
  const char* root = std::getenv("POSEKIT_FUZZ_SEEDS");
  const std::string dir = (root && *root ? std::string(root) : tmp.path()) + "/pkm";
  std::filesystem::create_directories(dir);
  PoseModel m;
  m.template_V = Eigen::MatrixXd::Random(4, 3);
  m.template_F.resize(2, 3);
  m.template_F << 0, 1, 2, 0, 2, 3;
  m.triangle_part = Eigen::VectorXi::Zero(2);
  m.joint_centres = Eigen::MatrixXd::Zero(kNumJoints, 3);
  m.triangle_joints = Eigen::MatrixXi::Constant(2, 2, -1);
  m.coefficients.setZero(2, kPoseCoefficients);
  m.training_poses = 3;
  m.fit_rms = 0.01;
  write_pose_model(dir + "/plain.pkm", m);
  CalibrationBody body;
  body.shape.region.assign(kShapeRegions, Eigen::VectorXf::Ones(2));
  body.labels = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 1>::Constant(4, 3);
  body.skeleton.joints.triangle = Eigen::VectorXi::Zero(kNumJoints);
  body.skeleton.joints.bary = Eigen::MatrixXd::Constant(kNumJoints, 3, 1.0 / 3);
  body.skeleton.joints.offset = Eigen::MatrixXd::Zero(kNumJoints, 3);
  m.segmentation_prior.bodies = {body, body};
  write_pose_model(dir + "/prior.pkm", m);
  std::string v2 = read_file_bytes(dir + "/prior.pkm");
  v2.resize(v2.size() - 4);
  const std::uint32_t two = 2;
  std::memcpy(&v2[8], &two, 4);
  write_file_atomically(dir + "/prior_v2.pkm", [&](std::ostream& out) { out << v2; });
  for (const char* name : {"plain.pkm", "prior.pkm", "prior_v2.pkm"}) {
    const PoseModel back = read_pose_model(dir + "/" + name);
    EXPECT_TRUE(back.template_V == m.template_V) << name;
  }
  EXPECT_EQ(read_pose_model(dir + "/prior.pkm").segmentation_prior.bodies.size(), 2u);
}
