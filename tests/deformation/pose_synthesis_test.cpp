#include "posekit/deformation/pose_synthesis.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <iostream>
#include <map>
#include <numeric>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/datasets/dataset.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/poisson_solver.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/io/mesh_io.h"
#include "testing/small_dataset.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

std::shared_ptr<const PoseModel> small_model() {
  static const auto model = std::make_shared<const PoseModel>(train_on_dataset(test::small_dataset().root));
  return model;
}

double method_mean(const std::vector<MethodErrors>& errors, PoseMethod m) {
  for (const auto& e : errors)
    if (e.method == m) return e.all.mean_mm;
  return -1;
}

}  // namespace

TEST(PoseSynthesis, LearnedBeatsBothBaselinesOnTemplateAndSubjects) {
  const auto& ds = test::small_dataset();
  const PoseEvaluation ev = evaluate_poses(ds.root, small_model());
  ASSERT_GT(ev.test_poses, 3);
  ASSERT_EQ(ev.subjects.size(), 2u);
  const double learned = method_mean(ev.template_errors, PoseMethod::kLearned);
  EXPECT_LT(learned, 5.0);
  EXPECT_LT(learned, method_mean(ev.template_errors, PoseMethod::kRigid));
  // The template's held-out poses move few vertices (0.2-0.3 mm on average). With Eq. 6 weighted by
  // the training residuals learned is ahead of LBS there too (0.24 against 0.28 mm; by area alone it
  // was behind, 0.30).
  EXPECT_LT(learned, method_mean(ev.template_errors, PoseMethod::kLbs));
  for (const auto& s : ev.subjects) {
    const double l = method_mean(s.methods, PoseMethod::kLearned);
    EXPECT_LT(l, 10.0) << s.id;
    EXPECT_LT(l, method_mean(s.methods, PoseMethod::kRigid)) << s.id;
    EXPECT_LT(l, method_mean(s.methods, PoseMethod::kLbs)) << s.id;
    EXPECT_GT(s.segmentation_agreement, 0.92) << s.id;
  }
}

TEST(PoseSynthesis, IsAPureFunctionOfModelSubjectAndPose) {
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = read_mesh(ds.root + "/subjects/m01/rest.ply");
  PartPose pose;
  pose.joint_rotation[find_joint_index("left_elbow")] = Eigen::Vector3d(1.0, 0, 0);
  pose.joint_rotation[find_joint_index("right_hip")] = Eigen::Vector3d(-0.6, 0, 0.1);
  const PoseSynthesizer a(small_model(), subject), b(small_model(), subject);
  const Eigen::MatrixXd first = a.pose(pose);
  a.pose(PartPose{});  // an unrelated pose in between changes nothing
  EXPECT_TRUE(a.pose(pose) == first);
  EXPECT_TRUE(b.pose(pose) == first);
  // Zero pose: the rest mesh back (soft anchors and T^Q = I agree).
  EXPECT_LT((a.pose(PartPose{}) - subject.V).rowwise().norm().maxCoeff(), 1e-6);
}

TEST(PoseSynthesis, WeightingEq6ByTheTrainingResidualsLowersTheHeldOutError) {
  const auto& ds = test::small_dataset();
  const PoseModel& model = *small_model();
  const Eigen::VectorXd w = eq6_triangle_weights(model);
  ASSERT_EQ(w.size(), model.template_F.rows());
  EXPECT_GT(w.minCoeff(), 0.0);
  EXPECT_LE(w.maxCoeff(), 1.0);
  // Relative to the model's own pooled residual: scaling every residual changes nothing.
  PoseModel scaled = model;
  scaled.triangle_rms *= 10;
  EXPECT_LT((eq6_triangle_weights(scaled) - w).cwiseAbs().maxCoeff(), 1e-12);
  // Where T^Q is predicted well (the head, nearly rigid) Eq. 6 holds the shape; where it is not
  // (the hips, whose skin folds) the mismatch between the parts goes.
  double head = 0, hips = 0;
  int head_count = 0, hips_count = 0;
  for (Eigen::Index k = 0; k < w.size(); ++k) {
    if (model.triangle_part[k] == kHead) head += w[k], ++head_count;
    if (model.triangle_part[k] == kPelvis) hips += w[k], ++hips_count;
  }
  std::cerr << "mean weight: head " << head / head_count << ", pelvis " << hips / hips_count << "\n";
  EXPECT_GT(head / head_count, hips / hips_count);
  // The template in the held-out poses, with and without the weights.
  PoseEvaluationOptions o;
  o.subjects = false;
  o.methods = {PoseMethod::kLearned};
  PoseModel unweighted = model;
  unweighted.triangle_rms.resize(0);
  const double weighted_mm = method_mean(evaluate_poses(ds.root, small_model(), o).template_errors, PoseMethod::kLearned);
  const double area_mm =
      method_mean(evaluate_poses(ds.root, std::make_shared<const PoseModel>(unweighted), o).template_errors, PoseMethod::kLearned);
  std::cerr << "held-out template, learned: " << weighted_mm << " mm weighted, " << area_mm << " mm by area alone\n";
  EXPECT_LT(weighted_mm, 0.9 * area_mm);
}

// The fused float kernels of pose() against Eq. 1, 4 and 6 evaluated plainly in double (pelvis
// anchor, no soft position constraints, so that the reference needs only public pieces).
TEST(PoseSynthesis, FastKernelsAgreeWithEq4AndEq6EvaluatedInDouble) {
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = read_mesh(ds.root + "/subjects/m01/rest.ply");
  SubjectSetupOptions options;
  options.placement = PosePlacement::kPelvis;
  const PoseSynthesizer synth(small_model(), subject, options);
  const PoseModel& model = *small_model();
  PartPose pose;
  pose.joint_rotation[find_joint_index("left_elbow")] = Eigen::Vector3d(1.2, 0.1, 0);
  pose.joint_rotation[find_joint_index("right_hip")] = Eigen::Vector3d(-0.7, 0, 0.2);
  pose.joint_rotation[find_joint_index("left_knee")] = Eigen::Vector3d(0.9, 0, 0);
  pose.root_rotation = Eigen::Vector3d(0, 0.4, 0);
  const SubjectSetupInfo& info = synth.info();
  const PartTransforms parts = part_transforms(pose, info.joint_centres);
  const Eigen::VectorXd area = face_areas(subject.V, subject.F);
  for (PoseMethod method : {PoseMethod::kLearned}) {
    Eigen::MatrixXd T(subject.F.rows(), 9);
    Eigen::VectorXd anchor = Eigen::VectorXd::Zero(subject.F.rows());
    for (Eigen::Index k = 0; k < subject.F.rows(); ++k) {
      const int source = info.template_triangle[k];
      Eigen::Matrix<double, kPoseFeatures, 1> x = Eigen::Matrix<double, kPoseFeatures, 1>::Zero();
      for (int slot = 0; slot < 2; ++slot)
        if (model.triangle_joints(source, slot) >= 0) x.segment<3>(3 * slot) = pose.joint(model.triangle_joints(source, slot));
      x[6] = 1;
      Eigen::Matrix3d Q;
      for (int m = 0; m < 9; ++m) Q(m / 3, m % 3) = model.coefficients.row(source).segment<kPoseFeatures>(m * kPoseFeatures).dot(x);
      // T^Q turns with the part it was learned in: its template triangle's, not the subject's label.
      const Eigen::Matrix3d Tk = parts.R[static_cast<size_t>(model.triangle_part[source])] * Q;
      for (int e = 0; e < 9; ++e) T(k, e) = Tk(e / 3, e % 3);
      if (info.triangle_part[k] == kPelvis)
        anchor[k] = area[k] * std::exp(-(Q - Eigen::Matrix3d::Identity()).squaredNorm() / (0.02 * 0.02));
    }
    // Eq. 6 weighted by the training residuals of each triangle's template triangle.
    const Eigen::VectorXd template_weight = eq6_triangle_weights(model);
    ASSERT_EQ(template_weight.size(), model.template_F.rows());
    Eigen::VectorXd weight(subject.F.rows());
    for (Eigen::Index k = 0; k < subject.F.rows(); ++k) weight[k] = template_weight[info.template_triangle[k]];
    const Eigen::MatrixXd expected =
        PoissonSolver(subject.V, subject.F, Eigen::VectorXd(), weight).solve(T, anchor, parts.R[kPelvis], parts.t[kPelvis]);
    for (bool avx2 : {true, false}) {
      use_avx2_kernels(avx2);
      const Eigen::MatrixXd X = synth.pose(pose, method);
      use_avx2_kernels(true);
      // Float coefficients: a few nanometres here (measured 2.9e-9 m).
      EXPECT_LT((X - expected).rowwise().norm().maxCoeff(), 1e-7) << pose_method_name(method) << " avx2 " << avx2;
    }
  }
}

namespace {

PartPose a_test_pose() {
  PartPose pose;
  pose.joint(find_joint_index("left_elbow")) = Eigen::Vector3d(1.2, 0.1, 0);
  pose.joint(find_joint_index("right_shoulder")) = Eigen::Vector3d(0.3, 0, -0.9);
  pose.joint(find_joint_index("right_hip")) = Eigen::Vector3d(-0.7, 0, 0.2);
  pose.joint(find_joint_index("left_knee")) = Eigen::Vector3d(0.9, 0, 0);
  pose.joint(find_joint_index("lower_back")) = Eigen::Vector3d(0.3, 0, 0);
  pose.root_rotation = Eigen::Vector3d(0, 0.4, 0);
  return pose;
}

/// The small dataset's model with every twist coefficient tripled: as a model learned from noisy
/// meshes, larger everywhere.
std::shared_ptr<const PoseModel> small_model_with_tripled_coefficients() {
  auto inflated = std::make_shared<PoseModel>(*small_model());
  for (Eigen::Index k = 0; k < inflated->coefficients.rows(); ++k)
    for (int m = 0; m < 9; ++m) inflated->coefficients.row(k).segment<6>(m * kPoseFeatures) *= 3;
  return inflated;
}

/// Mean distance (mm) between two posings of a subject over the vertices of its hands and feet.
double extremities_apart_mm(const PoseSynthesizer& synth, const Eigen::MatrixXd& a, const Eigen::MatrixXd& b) {
  double sum = 0;
  int count = 0;
  for (Eigen::Index v = 0; v < a.rows(); ++v) {
    const int part = synth.vertex_parts()[v];
    if (part != kLeftHand && part != kRightHand && part != kLeftFoot && part != kRightFoot) continue;
    sum += (a.row(v) - b.row(v)).norm(), ++count;
  }
  return 1000 * sum / std::max(1, count);
}

}  // namespace

TEST(PoseSynthesis, RigidMovesEveryVertexExactlyWithItsPart) {
  const TriangleMesh subject = read_mesh(test::small_dataset().root + "/subjects/m01/rest.ply");
  const PoseSynthesizer synth(small_model(), subject);
  const PartPose pose = a_test_pose();
  const PartTransforms parts = synth.part_motions(pose, PoseMethod::kRigid);
  const Eigen::MatrixXd X = synth.pose(pose, PoseMethod::kRigid);
  double worst = 0;
  for (Eigen::Index v = 0; v < X.rows(); ++v) {
    const auto p = static_cast<size_t>(synth.vertex_parts()[v]);
    worst = std::max(worst, (X.row(v).transpose() - (parts.R[p] * subject.V.row(v).transpose() + parts.t[p])).norm());
  }
  EXPECT_LT(worst, 1e-12);
}

// A model whose learned coefficients are larger everywhere (noisy training meshes, another body's
// scans) moves the surface more; placed by the parts' rigid cores, the hands and feet still sit
// where the skeleton puts them, where placed by the pelvis they drift with the integrated T^Q.
TEST(PoseSynthesis, PartsStayWhereTheSkeletonPutsThemWhateverTheSizeOfTheCoefficients) {
  const TriangleMesh subject = read_mesh(test::small_dataset().root + "/subjects/m01/rest.ply");
  const std::shared_ptr<const PoseModel> inflated = small_model_with_tripled_coefficients();
  const PartPose pose = a_test_pose();
  std::map<std::string, double> apart;
  for (const auto& [name, model] : {std::pair<std::string, std::shared_ptr<const PoseModel>>{"learned", small_model()},
                                    std::pair<std::string, std::shared_ptr<const PoseModel>>{"inflated", inflated}})
    for (PosePlacement placement : {PosePlacement::kParts, PosePlacement::kPelvis}) {
      SubjectSetupOptions options;
      options.placement = placement;
      const PoseSynthesizer synth(model, subject, options);
      const std::string key = name + (placement == PosePlacement::kParts ? " parts" : " pelvis");
      apart[key] = extremities_apart_mm(synth, synth.pose(pose, PoseMethod::kLearned), synth.pose(pose, PoseMethod::kRigid));
      std::cerr << key << ": hands and feet " << apart[key] << " mm from the rigid posing\n";
    }
  EXPECT_LT(apart["inflated parts"], 1.5 * apart["learned parts"] + 1.0);
  EXPECT_LT(apart["inflated parts"], 0.5 * apart["inflated pelvis"]);
}

// Where a posing puts each joint: the joint's rest centre carried by the rigid motion that best
// maps the rest vertices of its child part onto the posed ones (least squares).
Eigen::MatrixXd joints_of_posing(const PoseSynthesizer& synth, const Eigen::MatrixXd& X) {
  const Eigen::MatrixXd& V = synth.rest_vertices();
  Eigen::MatrixXd joints(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) {
    std::vector<Eigen::Index> rows;
    for (Eigen::Index v = 0; v < V.rows(); ++v)
      if (synth.vertex_parts()[v] == j + 1) rows.push_back(v);
    Eigen::MatrixXd rest(3, static_cast<Eigen::Index>(rows.size())), posed(3, static_cast<Eigen::Index>(rows.size()));
    for (size_t k = 0; k < rows.size(); ++k)
      rest.col(static_cast<Eigen::Index>(k)) = V.row(rows[k]).transpose(),
      posed.col(static_cast<Eigen::Index>(k)) = X.row(rows[k]).transpose();
    const Eigen::Matrix4d m = Eigen::umeyama(rest, posed, false);
    joints.row(j) = (m.topLeftCorner<3, 3>() * synth.info().joint_centres.row(j).transpose() + m.topRightCorner<3, 1>()).transpose();
  }
  return joints;
}

// The learned surface deforms each part (a flexed hip's thigh bulges), so its best rigid fit moves a
// little; placed by the rigid cores its joints stay within a few millimetres of the skeleton's (LBS's
// as close), where a model with larger coefficients placed by the pelvis carries them off.
TEST(PoseSynthesis, TheThreeMethodsPutTheJointsInOnePlace) {
  const TriangleMesh subject = read_mesh(test::small_dataset().root + "/subjects/m01/rest.ply");
  const std::shared_ptr<const PoseModel> inflated = small_model_with_tripled_coefficients();
  const PartPose pose = a_test_pose();
  auto apart = [&](std::shared_ptr<const PoseModel> model, PosePlacement placement, PoseMethod method) {
    SubjectSetupOptions options;
    options.placement = placement;
    const PoseSynthesizer synth(model, subject, options);
    const Eigen::MatrixXd rigid = joints_of_posing(synth, synth.pose(pose, PoseMethod::kRigid));
    return Eigen::VectorXd((joints_of_posing(synth, synth.pose(pose, method)) - rigid).rowwise().norm() * 1000);
  };
  const Eigen::VectorXd learned = apart(small_model(), PosePlacement::kParts, PoseMethod::kLearned),
                        lbs = apart(small_model(), PosePlacement::kParts, PoseMethod::kLbs),
                        inflated_parts = apart(inflated, PosePlacement::kParts, PoseMethod::kLearned),
                        inflated_pelvis = apart(inflated, PosePlacement::kPelvis, PoseMethod::kLearned);
  std::cerr << "joints from rigid's, mean / max mm: learned " << learned.mean() << " / " << learned.maxCoeff() << ", LBS " << lbs.mean()
            << " / " << lbs.maxCoeff() << ", tripled coefficients " << inflated_parts.mean() << " / " << inflated_parts.maxCoeff()
            << " (placed by the pelvis " << inflated_pelvis.mean() << " / " << inflated_pelvis.maxCoeff() << ")\n";
  EXPECT_LT(learned.mean(), 2.5);       // measured 1.67 (LBS 0.80)
  EXPECT_LT(learned.maxCoeff(), 10.0);  // 7.0, the flexed right hip (LBS 3.8 at the bent knee)
  EXPECT_LT(inflated_parts.mean(), 0.5 * inflated_pelvis.mean());
}

TEST(PoseSynthesis, RejectsBadPosesAndBodies) {
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = read_mesh(ds.root + "/subjects/f01/rest.ply");
  const PoseSynthesizer s(small_model(), subject);
  PartPose nan_pose;
  nan_pose.joint_rotation[4] = Eigen::Vector3d(0, std::nan(""), 0);
  try {
    s.pose(nan_pose);
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("left_elbow"), std::string::npos) << e.what();
  }
  // Two bodies side by side are not one subject.
  TriangleMesh two = subject;
  two.V.conservativeResize(2 * subject.V.rows(), 3);
  two.V.bottomRows(subject.V.rows()) = subject.V.rowwise() + Eigen::RowVector3d(1.5, 0, 0);
  two.F.conservativeResize(2 * subject.F.rows(), 3);
  two.F.bottomRows(subject.F.rows()) = subject.F.array() + static_cast<int>(subject.V.rows());
  EXPECT_THROW(PoseSynthesizer(small_model(), two), Error);
  // Not a body at all.
  EXPECT_THROW(PoseSynthesizer(small_model(), test::icosphere(3)), Error);
  // The template flag on a mesh that is not the template.
  SubjectSetupOptions o;
  o.is_template = true;
  EXPECT_THROW(PoseSynthesizer(small_model(), subject, o), InvalidInput);
}

TEST(PoseSynthesis, JointPivotsAreTheCentresOrTheLearnedOffsetsPivots) {
  // The fit's Jacobian turns each joint about its pivot: the centre, or with the learned method's
  // offsets the pivot of their linear part, scaled to the subject, and T^R as the posing uses it.
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = read_mesh(ds.root + "/subjects/f01/rest.ply");
  PoseModel with_pivot = *small_model();
  with_pivot.joint_offsets = Eigen::MatrixXd::Zero(kNumJoints, 3 * kOffsetFeatures);
  const Eigen::Vector3d D(0.01, 0.066, -0.02);
  const Eigen::Matrix<double, 3, kOffsetFeatures> A = pivot_offset_coefficients(D);
  for (int d = 0; d < 3; ++d)
    for (int f = 0; f < kOffsetFeatures; ++f) with_pivot.joint_offsets(1, d * kOffsetFeatures + f) = A(d, f);
  const PoseSynthesizer plain(small_model(), subject), pivoted(std::make_shared<const PoseModel>(with_pivot), subject);
  const Eigen::MatrixXd& centres = plain.info().joint_centres;
  EXPECT_TRUE(plain.joint_pivots(PoseMethod::kLearned) == centres);
  EXPECT_TRUE(pivoted.joint_pivots(PoseMethod::kLbs) == centres);
  const Eigen::MatrixXd p = pivoted.joint_pivots(PoseMethod::kLearned);
  const double scale = (p.row(1) - centres.row(1)).norm() / D.norm();
  EXPECT_GT(scale, 0.8);  // the subject's height over the template's
  EXPECT_LT(scale, 1.2);
  EXPECT_LT((p.row(1) - centres.row(1) - scale * D.transpose()).norm(), 1e-12);
  EXPECT_TRUE(p.bottomRows(kNumJoints - 2) == centres.bottomRows(kNumJoints - 2));
  PartPose bend;
  bend.joint_rotation[1] = Eigen::Vector3d(0, 0, 0.35);
  const PartTransforms T = pivoted.part_motions(bend, PoseMethod::kLearned);
  const Eigen::Vector3d pivot = p.row(1).transpose();
  EXPECT_LT((T.R[kChest] * pivot + T.t[kChest] - (T.R[kAbdomen] * pivot + T.t[kAbdomen])).norm(),
            0.2 * std::pow(0.35, 3) * scale * D.norm());
}

TEST(PoseEvaluation, RefusesAModelOfAnotherTemplate) {
  const auto& ds = test::small_dataset();
  auto other = std::make_shared<PoseModel>(*small_model());
  other->template_V.col(0) *= 1.1;  // a wider template
  EXPECT_THROW(evaluate_poses(ds.root, other), InvalidInput);
}

TEST(PoseFitting, FindsThePoseOfAScanWithoutMarkersAndAtAnyHeading) {
  // Issue 18, part 2: the subject's scan in a held-out pose (holes, noise, outliers), no markers.
  const auto& ds = test::small_dataset();
  const auto model = std::make_shared<const PoseModel>(train_on_dataset(ds.root));
  const TriangleMesh subject = load_subject_mesh(ds.root + "/subjects/f01/rest.ply");
  const PoseSynthesizer synth(model, subject);
  const PartPose truth = read_part_pose(ds.root + "/subjects/f01/posed/walk_phase_1.json");
  const TriangleMesh truth_mesh = read_mesh(ds.root + "/subjects/f01/posed/walk_phase_1.ply");
  const PointCloud scan = load_scan(ds.root + "/scans/f01/walk_phase_1.pcd");
  auto angle_error = [&](const PartPose& p) {
    double sum = 0;
    for (int j = 0; j < kNumJoints; ++j) sum += rotation_difference(p.joint(j), truth.joint(j));
    return sum / kNumJoints * 180 / M_PI;
  };
  const PoseFitResult fit = fit_pose(synth, scan.P);
  const double vertex_error = (fit.V - truth_mesh.V).rowwise().norm().mean();
  // Measured 3.7 degrees (mean over the 15 joints) and 3.0 mm against the true posed mesh (5.8 and
  // 4.7 before the hinge prior and up to 100 final steps instead of 40).
  std::cout << "walk: " << angle_error(fit.pose) << " degrees, " << 1000 * vertex_error << " mm\n";
  EXPECT_LT(angle_error(fit.pose), 5.0);
  EXPECT_LT(vertex_error, 0.005);
  EXPECT_GT(fit.coverage, 0.6);
  EXPECT_TRUE(fit.warnings.empty()) << fit.warnings.front();
  // The same body facing the other way: the heading is found, the joints are the same.
  Eigen::MatrixXd turned = truth_mesh.V;
  turned.col(0) *= -1;
  turned.col(2) *= -1;
  const PoseFitResult back = fit_pose(synth, turned);
  EXPECT_LT(angle_error(back.pose), 4.0);  // measured 1.3 degrees
  EXPECT_NEAR(Eigen::AngleAxisd(rotation_from_axis_angle(back.pose.root_rotation)).angle(), M_PI, 0.2);
  EXPECT_THROW(fit_pose(synth, Eigen::MatrixXd::Zero(10, 3)), InvalidInput);
}

namespace {

// Each named joint's rotation error (degrees) of a fitted pose against the truth.
std::vector<double> joint_errors_degrees(const PartPose& fitted, const PartPose& truth, std::initializer_list<const char*> names) {
  std::vector<double> e;
  for (const char* name : names) {
    const size_t j = static_cast<size_t>(find_joint_index(name));
    e.push_back(rotation_difference(fitted.joint_rotation[j], truth.joint_rotation[j]) * 180 / M_PI);
  }
  return e;
}

// The small dataset's f01 with the small model, its true pose and its simulated scan in `pose`.
struct F01InPose {
  explicit F01InPose(const std::string& pose)
      : synth(small_model(), load_subject_mesh(test::small_dataset().root + "/subjects/f01/rest.ply")),
        truth(read_part_pose(test::small_dataset().root + "/subjects/f01/posed/" + pose + ".json")),
        scan(load_scan(test::small_dataset().root + "/scans/f01/" + pose + ".pcd")) {}
  const PoseSynthesizer synth;
  const PartPose truth;
  const PointCloud scan;
};

}  // namespace

TEST(PoseFitting, GivesTheSamePoseOnAnyNumberOfThreads) {
  // The pairs are summed per fixed block, the blocks in order: not a bit of difference.
  const F01InPose f("walk_phase_1");
  PoseFitOptions o;
  o.start = f.truth;
  o.iterations = 10;
  o.threads = 1;
  const PartPose one = fit_pose(f.synth, f.scan.P, o).pose;
  o.threads = 2;
  const PartPose two = fit_pose(f.synth, f.scan.P, o).pose;
  EXPECT_EQ(one.root_translation, two.root_translation);
  EXPECT_EQ(one.root_rotation, two.root_rotation);
  for (int j = 0; j < kNumJoints; ++j) EXPECT_EQ(one.joint(j), two.joint(j)) << joint_name(j);
}

TEST(PoseFitting, EndsARefinementThatCrawlsAtNearlyThePoseItWouldReach) {
  // Started 3 degrees off at a shoulder, a knee and the lower back, the full refinement crawls on to
  // its millionth (58 steps, the last 25 gaining under 0.02% each); ended once five kept steps gain
  // under 0.1% together (33), it is as near. (From 15 degrees off every step gains 1-4%: no end.)
  const F01InPose f("walk_phase_1");
  PartPose start = f.truth;
  for (const char* name : {"left_shoulder", "right_knee", "lower_back"})
    start.joint(find_joint_index(name)) += 3 * M_PI / 180 * Eigen::Vector3d::UnitX();
  PoseFitOptions o;
  o.start = start;
  const PoseFitResult full = fit_pose(f.synth, f.scan.P, o);
  o.stall_gain = 1e-3;
  const PoseFitResult ended = fit_pose(f.synth, f.scan.P, o);
  EXPECT_LT(ended.iterations, full.iterations);
  auto mean_error = [&](const PartPose& p) {
    double sum = 0;
    for (int j = 0; j < kNumJoints; ++j) sum += rotation_difference(p.joint(j), f.truth.joint(j));
    return sum / kNumJoints * 180 / M_PI;
  };
  EXPECT_LT(mean_error(full.pose), 4.0);
  EXPECT_LT(mean_error(ended.pose), mean_error(full.pose) + 0.5) << full.iterations << " and " << ended.iterations << " steps";
}

TEST(PoseFitting, LeavesTheTwistOfAStraightArmToTheData) {
  // Started at the true pose of arms reaching forward (-90 degrees about X at each shoulder), a prior
  // pulling the whole rotation towards the rest twisted the arms towards the smallest rotation that
  // points them forward: 27 degrees off at the shoulders. Twist weighted 0.1 of swing leaves them.
  const F01InPose f("reach_forward");
  auto shoulder_error = [&](const PartPose& p) {
    const auto e = joint_errors_degrees(p, f.truth, {"left_shoulder", "right_shoulder"});
    return *std::max_element(e.begin(), e.end());
  };
  PoseFitOptions o;
  o.start = f.truth;
  const double as_default = shoulder_error(fit_pose(f.synth, f.scan.P, o).pose);
  EXPECT_LT(as_default, 4.0);
  // The pull shows most at the search's strength (the final refinement's default is weaker).
  o.refinement_rest_prior = o.rest_prior;
  const double light_twist = shoulder_error(fit_pose(f.synth, f.scan.P, o).pose);
  o.refinement_twist_weight = 1;
  const double whole = shoulder_error(fit_pose(f.synth, f.scan.P, o).pose);
  EXPECT_LT(light_twist, 8.0);
  EXPECT_GT(whole, light_twist + 10);
  std::cout << "shoulder error from the true pose: " << as_default << " degrees; at the search's rest prior " << light_twist
            << " (twist weighted as swing: " << whole << ")\n";
}

TEST(PoseFitting, WarnsWhenTheTargetDoesNotShowAPart) {
  // With the hands cut off a scan leaves the wrists to the priors (57 degrees off once): they are held
  // at rest, and that is said.
  const auto& ds = test::small_dataset();
  const TriangleMesh subject = load_subject_mesh(ds.root + "/subjects/f01/rest.ply");
  const PoseSynthesizer synth(small_model(), subject);
  const TriangleMesh truth_mesh = read_mesh(ds.root + "/subjects/f01/posed/walk_phase_1.ply");
  std::vector<Eigen::Index> kept;
  for (Eigen::Index v = 0; v < truth_mesh.V.rows(); ++v)
    if (synth.vertex_parts()[v] != kLeftHand && synth.vertex_parts()[v] != kRightHand) kept.push_back(v);
  const PoseFitResult fit = fit_pose(synth, truth_mesh.V(kept, Eigen::all));
  int wrists = 0;
  for (const auto& w : fit.warnings) wrists += w.find("wrist' is held at its rest rotation") != std::string::npos;
  EXPECT_EQ(wrists, 2);
  for (const char* name : {"left_wrist", "right_wrist"}) EXPECT_LT(fit.pose.joint(find_joint_index(name)).norm() * 180 / M_PI, 1.0) << name;
  // And said where a program reads it: the two wrists, and no other joint, are guessed.
  EXPECT_EQ(joint_names_where(fit.joint_guessed), (std::vector<std::string>{"left_wrist", "right_wrist"}));
  const PoseFitResult whole = fit_pose(synth, truth_mesh.V);
  EXPECT_TRUE(whole.warnings.empty());
  EXPECT_TRUE(joint_names_where(whole.joint_guessed).empty());
}

TEST(PoseFitting, StaysAtADeepSquatThatItPosesExactly) {
  // The hinge prior once measured a knee's varus as the swing left after taking out the twist about
  // the shank, which grows with the flexion: a knee bent 138 degrees about an axis 5 degrees off the
  // hinge read as 25 degrees of twist, and the prior turned the robustness set's squatting thighs
  // 20 degrees about themselves, the knees back. Started at the pose of a target the model itself
  // poses, nothing but the priors can move the fit away.
  const F01InPose f("squat_half");
  PartPose deep;
  auto set = [&](const char* name, double degrees) {
    deep.joint(find_joint_index(name)) = degrees * M_PI / 180 * Eigen::Vector3d::UnitX();
  };
  set("left_hip", -110), set("right_hip", -110), set("left_knee", 135), set("right_knee", 135);
  set("lower_back", 20), set("left_shoulder", -60), set("right_shoulder", -60);
  PoseFitOptions o;
  o.start = o.prior_pose = deep;
  const Eigen::MatrixXd target = f.synth.pose(deep, o.method);
  const auto e = joint_errors_degrees(fit_pose(f.synth, target, o).pose, deep, {"left_hip", "left_knee", "right_hip", "right_knee"});
  for (size_t k = 0; k < e.size(); ++k) EXPECT_LT(e[k], 3.0) << "joint " << k;
}

TEST(PoseFitting, KeepsTheKneesOfASquatOnTheirHinge) {
  // A knee or elbow swinging off its hinge (varus, valgus) traded against the hip's or shoulder's
  // twist: a half squat's hips and knees came out twisted 9 degrees, the knees 8 off their hinge.
  const F01InPose f("squat_half");
  // The knees' largest swing off their hinge: how far the shank (knee to ankle) leaves the cone
  // that a flexion about the body's left-right axis keeps it on.
  const Eigen::MatrixXd& joints = f.synth.info().joint_centres;
  auto off_hinge = [&](const PartPose& p) {
    double worst = 0;
    for (const char* name : {"left_knee", "right_knee"}) {
      const int knee = find_joint_index(name), ankle = knee + 1;
      const Eigen::Vector3d shank = (joints.row(ankle) - joints.row(knee)).transpose().normalized();
      const Eigen::Vector3d hinge = Eigen::Vector3d::UnitX();
      const Eigen::Vector3d moved = rotation_from_axis_angle(p.joint(knee)) * shank;
      worst = std::max(worst, std::abs(std::asin(moved.dot(hinge)) - std::asin(shank.dot(hinge))) * 180 / M_PI);
    }
    return worst;
  };
  auto leg_error = [&](const PartPose& p) {
    const auto e = joint_errors_degrees(p, f.truth, {"left_hip", "left_knee", "right_hip", "right_knee"});
    return std::accumulate(e.begin(), e.end(), 0.0) / static_cast<double>(e.size());
  };
  PoseFitOptions o;
  const PartPose hinge = fit_pose(f.synth, f.scan.P, o).pose;
  o.hinge_prior = 0;
  const PartPose ball = fit_pose(f.synth, f.scan.P, o).pose;
  std::cout << "half squat: knees " << off_hinge(hinge) << " degrees off their hinge, hips and knees " << leg_error(hinge)
            << " degrees off the truth (as ball joints: " << off_hinge(ball) << ", " << leg_error(ball) << ")\n";
  // Measured (2026-11-28, the knees' hinge the body's left-right axis, their swing off it taken
  // after the flexion) 0.3 degrees off the hinge and 1.6 off the truth, against 4.6 and 4.3 as ball
  // joints. (With the hinge across the leaning leg and the swing taken after the twist: 1.65 and
  // 4.8 degrees off the truth with the prior, 4.3 as ball joints.)
  EXPECT_LT(off_hinge(hinge), 1.0);
  EXPECT_LT(leg_error(hinge), 3.0);
  EXPECT_LT(leg_error(hinge) + 1, leg_error(ball));
}
