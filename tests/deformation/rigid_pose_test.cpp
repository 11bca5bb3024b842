#include "posekit/deformation/rigid_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SparseLU>
#include <cmath>
#include <limits>
#include <random>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/deformation/poisson_solver.h"
#include "posekit/deformation/pose_model.h"
#include "testing/makehuman_fixture.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

PartPose random_pose(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(-1, 1);
  PartPose p;
  for (auto& r : p.joint_rotation) r = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * max_angle * std::abs(u(rng));
  p.root_rotation = Eigen::Vector3d(u(rng), u(rng), u(rng)) * 0.3;
  return p;
}

}  // namespace

TEST(RigidPose, ChildrenTurnWithTheirParentsAndJointsStayPut) {
  Eigen::MatrixXd joints(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) joints.row(j) << 0.1 * j, 0.05 * j * j, -0.02 * j;
  PartPose pose;
  pose.joint_rotation[kLeftUpperArm - 1] = Eigen::Vector3d(0, 0, 0.7);  // left shoulder
  pose.joint_rotation[kLeftForearm - 1] = Eigen::Vector3d(0.4, 0, 0);   // left elbow
  const PartTransforms T = part_transforms(pose, joints);
  EXPECT_TRUE(T.R[kChest].isIdentity(1e-12));
  EXPECT_TRUE(T.R[kRightForearm].isIdentity(1e-12));
  EXPECT_TRUE(T.R[kLeftHand].isApprox(T.R[kLeftForearm], 1e-12));
  EXPECT_TRUE(T.R[kLeftForearm].isApprox(T.R[kLeftUpperArm] * rotation_from_axis_angle(Eigen::Vector3d(0.4, 0, 0)), 1e-12));
  // A joint is where both of its parts take it.
  for (int p = 1; p < kNumParts; ++p) {
    const Eigen::Vector3d j = joints.row(p - 1).transpose();
    const int q = part_parent(p);
    EXPECT_LT((T.R[p] * j + T.t[p] - (T.R[q] * j + T.t[q])).norm(), 1e-12) << part_name(p);
  }
  PartPose bad;
  bad.joint_rotation[3] = Eigen::Vector3d(std::nan(""), 0, 0);
  EXPECT_THROW(validate_part_pose(bad, "test"), InvalidInput);
  bad.joint_rotation[3] = Eigen::Vector3d(90, 0, 0);  // degrees by mistake
  EXPECT_THROW(validate_part_pose(bad, "test"), InvalidInput);
}

TEST(RigidPose, APivotsOffsetIsItsTurnAboutThePivotToSecondOrder) {
  // A joint turning about D (from its centre) instead of its centre: the offset coefficients give
  // (I - R(r)) D up to third-order terms, and with them T^R turns the child about the pivot.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Vector3d D = 0.07 * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Matrix<double, 3, kOffsetFeatures> A = pivot_offset_coefficients(D);
    for (const double angle : {0.01, 0.1, 0.35}) {
      PartPose pose;
      pose.joint_rotation[1] = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized() * angle;
      const Eigen::Vector3d exact = (Eigen::Matrix3d::Identity() - rotation_from_axis_angle(pose.joint_rotation[1])) * D;
      const Eigen::Vector3d second_order = A * joint_offset_features(pose, 1);
      EXPECT_LE((second_order - exact).norm(), 0.2 * std::pow(angle, 3) * D.norm()) << trial << " " << angle;
    }
  }
  // Posed with it, the chest turns about the pivot: the pivot point stays where the abdomen takes it.
  Eigen::MatrixXd joints(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) joints.row(j) << 0.1 * j, 0.05 * j, -0.02 * j;
  const Eigen::Vector3d D(0, 0.066, 0);
  Eigen::MatrixXd offsets = Eigen::MatrixXd::Zero(kNumJoints, 3 * kOffsetFeatures);
  const Eigen::Matrix<double, 3, kOffsetFeatures> A = pivot_offset_coefficients(D);
  for (int d = 0; d < 3; ++d)
    for (int f = 0; f < kOffsetFeatures; ++f) offsets(1, d * kOffsetFeatures + f) = A(d, f);
  PartPose bend;
  bend.joint_rotation[1] = Eigen::Vector3d(0, 0, 0.35);  // upper back, a side bend of 20 degrees
  const PartTransforms T = part_transforms(bend, joints, offsets, 1.0);
  const Eigen::Vector3d pivot = joints.row(1).transpose() + D;
  EXPECT_LT((T.R[kChest] * pivot + T.t[kChest] - (T.R[kAbdomen] * pivot + T.t[kAbdomen])).norm(), 0.2 * std::pow(0.35, 3) * D.norm());
  EXPECT_GT((part_transforms(bend, joints).t[kChest] - T.t[kChest]).norm(), 0.02);  // about 2.3 cm
}

TEST(RigidPose, PartPoseSurvivesTheRoundTripThroughTheRig) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  std::mt19937 rng(3);
  for (int trial = 0; trial < 5; ++trial) {
    const PartPose pose = random_pose(rng, 1.2);
    const PartPose back = part_pose_from_bone_pose(model.rig, bone_pose_from_part_pose(model.rig, pose));
    for (int j = 0; j < kNumJoints; ++j)
      EXPECT_TRUE(rotation_from_axis_angle(back.joint_rotation[j]).isApprox(rotation_from_axis_angle(pose.joint_rotation[j]), 1e-9))
          << joint_name(j);
    EXPECT_TRUE(rotation_from_axis_angle(back.root_rotation).isApprox(rotation_from_axis_angle(pose.root_rotation), 1e-9));
  }
}

TEST(DeformationGradient, IsTheRotationOfARotatedMesh) {
  const TriangleMesh s = test::icosphere(2);
  const Eigen::Matrix3d R = rotation_from_axis_angle(Eigen::Vector3d(0.3, -0.5, 0.8));
  const Eigen::MatrixXd moved = (s.V * R.transpose()).rowwise() + Eigen::RowVector3d(1, 2, 3);
  const Eigen::MatrixXd D = deformation_gradients(s.V, moved, s.F);
  for (Eigen::Index k = 0; k < D.rows(); ++k)
    for (int e = 0; e < 9; ++e) ASSERT_NEAR(D(k, e), R(e / 3, e % 3), 1e-9);
  // A stretch along x: the triangles' gradients stretch along x too (up to the normal direction).
  Eigen::MatrixXd stretched = s.V;
  stretched.col(0) *= 1.5;
  const Eigen::MatrixXd S = deformation_gradients(s.V, stretched, s.F);
  for (Eigen::Index k = 0; k < S.rows(); ++k) {
    Eigen::Matrix3d G;
    G << S(k, 0), S(k, 1), S(k, 2), S(k, 3), S(k, 4), S(k, 5), S(k, 6), S(k, 7), S(k, 8);
    const Eigen::Vector3d e1 = (s.V.row(s.F(k, 1)) - s.V.row(s.F(k, 0))).transpose();
    EXPECT_LT((G * e1 - Eigen::Vector3d(1.5 * e1.x(), e1.y(), e1.z())).norm(), 1e-9);
  }
}

TEST(PoissonSolver, RecoversARigidMotionAndPlacesTheAnchor) {
  const TriangleMesh s = test::icosphere(3);
  const PoissonSolver solver(s.V, s.F);
  const Eigen::Matrix3d R = rotation_from_axis_angle(Eigen::Vector3d(0.2, 0.9, -0.4));
  Eigen::MatrixXd T(s.F.rows(), 9);
  for (Eigen::Index k = 0; k < T.rows(); ++k)
    for (int e = 0; e < 9; ++e) T(k, e) = R(e / 3, e % 3);
  const Eigen::Vector3d t(0.5, -1, 2);
  const Eigen::MatrixXd X = solver.solve(T, Eigen::VectorXd::Ones(s.F.rows()), R, t);
  const Eigen::MatrixXd expected = (s.V * R.transpose()).rowwise() + t.transpose();
  EXPECT_LT((X - expected).rowwise().norm().maxCoeff(), 1e-9);
  // With soft position constraints the same motion is reproduced from targets alone.
  const PoissonSolver anchored(s.V, s.F, Eigen::VectorXd::Constant(s.V.rows(), 0.01));
  EXPECT_LT((anchored.solve(T, expected) - expected).rowwise().norm().maxCoeff(), 1e-9);
  // The lowest level: the rest edges' divergence assembled in factor order and solved in place give
  // the rest shape up to a translation, vertex v at row factor_rows()[v].
  double* Y = solver.start_right_hand_side();
  const PoissonSolver::EdgeMatrix& edges = solver.weighted_rest_edges();
  for (Eigen::Index k = 0; k < s.F.rows(); ++k)
    for (int c = 0; c < 3; ++c)
      for (int d = 0; d < 3; ++d) Y[4 * solver.factor_corners()[3 * k + c] + d] += edges(k, 4 * ((c + 2) % 3) + d) - edges(k, 4 * c + d);
  solver.solve_in_place(Y);
  Eigen::MatrixXd rest(s.V.rows(), 3);
  for (Eigen::Index v = 0; v < s.V.rows(); ++v)
    for (int d = 0; d < 3; ++d) rest(v, d) = Y[4 * solver.factor_rows()[v] + d];
  const Eigen::RowVector3d shift = (rest - s.V).colwise().mean();
  EXPECT_LT(((rest.rowwise() - shift) - s.V).rowwise().norm().maxCoeff(), 1e-9);
  // Two separate spheres cannot be posed as one body.
  TriangleMesh two = s;
  two.V.conservativeResize(2 * s.V.rows(), 3);
  two.V.bottomRows(s.V.rows()) = s.V.rowwise() + Eigen::RowVector3d(3, 0, 0);
  two.F.conservativeResize(2 * s.F.rows(), 3);
  two.F.bottomRows(s.F.rows()) = s.F.array() + static_cast<int>(s.V.rows());
  EXPECT_THROW(PoissonSolver(two.V, two.F), InvalidInput);
  EXPECT_THROW(solver.solve(Eigen::MatrixXd::Zero(3, 9), Eigen::VectorXd::Ones(s.F.rows()), R, t), InvalidInput);
}

TEST(PoissonSolver, MatchesADirectSolveOfEq6ForNonRigidTransformations) {
  const TriangleMesh s = test::icosphere(3);
  std::srand(7);
  Eigen::MatrixXd T = Eigen::MatrixXd::Random(s.F.rows(), 9) * 0.3;
  for (Eigen::Index k = 0; k < T.rows(); ++k) T(k, 0) += 1, T(k, 4) += 1, T(k, 8) += 1;
  const Eigen::VectorXd weight = (Eigen::VectorXd::Random(s.V.rows()).array() + 1.0) * 0.01;
  const Eigen::MatrixXd targets = Eigen::MatrixXd::Random(s.V.rows(), 3);
  // Reference: the normal equations of Eq. 6 (each triangle's area times its weight) assembled here
  // and solved by a general sparse LU.
  const Eigen::VectorXd area = face_areas(s.V, s.F);
  auto direct_solve = [&](const Eigen::VectorXd& triangle_weight) {
    std::vector<Eigen::Triplet<double>> entries;
    Eigen::MatrixXd rhs = (targets.array().colwise() * weight.array()).matrix();
    for (Eigen::Index k = 0; k < s.F.rows(); ++k) {
      const double w = (area[k] + 1e-6 * area.mean()) * triangle_weight[k];
      Eigen::Matrix3d Tk;
      for (int e = 0; e < 9; ++e) Tk(e / 3, e % 3) = T(k, e);
      for (int c = 0; c < 3; ++c) {
        const int i = s.F(k, c), j = s.F(k, (c + 1) % 3);
        entries.insert(entries.end(), {{i, i, w}, {j, j, w}, {i, j, -w}, {j, i, -w}});
        const Eigen::RowVector3d d = w * (Tk * (s.V.row(j) - s.V.row(i)).transpose()).transpose();
        rhs.row(j) += d;
        rhs.row(i) -= d;
      }
    }
    for (Eigen::Index v = 0; v < s.V.rows(); ++v) entries.emplace_back(v, v, weight[v]);
    Eigen::SparseMatrix<double> A(s.V.rows(), s.V.rows());
    A.setFromTriplets(entries.begin(), entries.end());
    Eigen::SparseLU<Eigen::SparseMatrix<double>> lu(A);
    return Eigen::MatrixXd(lu.solve(rhs));
  };
  const Eigen::VectorXd uniform = Eigen::VectorXd::Ones(s.F.rows());
  const Eigen::VectorXd uneven = (Eigen::VectorXd::Random(s.F.rows()).array() + 1.05).matrix();  // 0.05 to 2.05
  const Eigen::MatrixXd expected = direct_solve(uniform), expected_uneven = direct_solve(uneven);
  ASSERT_GT((expected_uneven - expected).cwiseAbs().maxCoeff(), 1e-3 * expected.cwiseAbs().maxCoeff());  // the weights matter
  const PoissonSolver solver(s.V, s.F, weight), weighted(s.V, s.F, weight, uneven);
  for (bool avx2 : {true, false}) {  // the AVX2 kernels where the CPU has them, and the baseline ones
    use_avx2_kernels(avx2);
    const Eigen::MatrixXd X = solver.solve(T, targets), Y = weighted.solve(T, targets);
    use_avx2_kernels(true);
    EXPECT_LT((X - expected).cwiseAbs().maxCoeff(), 1e-9 * expected.cwiseAbs().maxCoeff()) << "avx2 " << avx2;
    EXPECT_LT((Y - expected_uneven).cwiseAbs().maxCoeff(), 1e-9 * expected_uneven.cwiseAbs().maxCoeff()) << "avx2 " << avx2;
  }
  // Weights must be one per triangle, positive and finite.
  EXPECT_THROW(PoissonSolver(s.V, s.F, weight, Eigen::VectorXd::Ones(3)), InvalidInput);
  Eigen::VectorXd bad = uniform;
  bad[5] = 0;
  EXPECT_THROW(PoissonSolver(s.V, s.F, weight, bad), InvalidInput);
  bad[5] = std::numeric_limits<double>::infinity();
  EXPECT_THROW(PoissonSolver(s.V, s.F, weight, bad), InvalidInput);
}
