#include "posekit/deformation/pose_model.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/shape/body_features.h"

namespace posekit {
namespace {

/// Each row of Y (one per triangle) moved halfway to the mean of its edge neighbours in the same part,
/// `iterations` times: a smoothness prior on the observed T^Q fields (noise in the training meshes).
void smooth_within_parts(const Eigen::MatrixXi& adjacency, const Eigen::VectorXi& part, int iterations,
                         Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor>* Y) {
  Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor> next(Y->rows(), 9);
  for (int it = 0; it < iterations; ++it) {
    for (Eigen::Index k = 0; k < Y->rows(); ++k) {
      Eigen::Matrix<double, 1, 9> sum = Eigen::Matrix<double, 1, 9>::Zero();
      int n = 0;
      for (int c = 0; c < 3; ++c) {
        const int o = adjacency(k, c);
        if (o >= 0 && part[o] == part[k]) sum += Y->row(o), ++n;
      }
      next.row(k) = n > 0 ? Eigen::Matrix<double, 1, 9>(0.5 * Y->row(k) + 0.5 / n * sum) : Eigen::Matrix<double, 1, 9>(Y->row(k));
    }
    Y->swap(next);
  }
}

/// [e1 e2 n/sqrt|n|] of each triangle, the frame of the deformation gradient (4th vertex).
Eigen::Matrix3d triangle_frame(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::Index k) {
  const Eigen::Vector3d a = V.row(F(k, 0)), b = V.row(F(k, 1)), c = V.row(F(k, 2));
  Eigen::Matrix3d E;
  E.col(0) = b - a;
  E.col(1) = c - a;
  const Eigen::Vector3d n = E.col(0).cross(E.col(1));
  E.col(2) = n / std::sqrt(std::max(n.norm(), 1e-300));
  return E;
}

std::vector<Eigen::Matrix3d> inverse_frames(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
  std::vector<Eigen::Matrix3d> inv(static_cast<size_t>(F.rows()));
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    const Eigen::Matrix3d E = triangle_frame(V, F, k);
    inv[static_cast<size_t>(k)] = std::abs(E.determinant()) > 1e-300 ? Eigen::Matrix3d(E.inverse()) : Eigen::Matrix3d::Identity();
  }
  return inv;
}

Eigen::Matrix<double, kPoseFeatures, 1> features(const PartPose& pose, int a, int b) {
  Eigen::Matrix<double, kPoseFeatures, 1> x = Eigen::Matrix<double, kPoseFeatures, 1>::Zero();
  if (a >= 0) x.segment<3>(0) = pose.joint(a);
  if (b >= 0) x.segment<3>(3) = pose.joint(b);
  x[6] = 1;
  return x;
}

/// Joint offsets (rigid_pose.h), joint by joint from the pelvis out. The target of joint j in a
/// training example: where the child part must carry j so that T^R puts the child's own child joints
/// where their parts' rigid fits carry them (a part that bends inside, as a chest over two thoracic
/// bones, is placed by what hangs from it; a part without child joints by its own rigid fit),
/// relative to where the parent carries j posed with the offsets found so far, in the parent's frame.
/// Fitted in two steps on the examples where j moves: the point D the joint effectively turns about
/// ((I - R(r)) D, exact in r: a side bend's mirror image follows from it), then the general
/// regression on the twist features of what D leaves.
/// `placed[e]`: the parts' own rigid fits in example examples[e].
Eigen::MatrixXd fit_joint_offsets(const PoseDataset& data, const std::vector<int>& examples, const std::vector<PartPoseEstimate>& placed,
                                  const PoseModel& model, Eigen::MatrixXd* pivot_only = nullptr) {
  const int m = static_cast<int>(examples.size());
  Eigen::MatrixXd offsets = Eigen::MatrixXd::Zero(kNumJoints, 3 * kOffsetFeatures);
  if (pivot_only) pivot_only->setZero(kNumJoints, 3 * kOffsetFeatures);
  for (int j = 0; j < kNumJoints; ++j) {  // joint j moves part j + 1; parents come first
    const size_t c = static_cast<size_t>(j + 1), q = static_cast<size_t>(part_parent(j + 1));
    std::vector<int> below;  // the joints of part c's children
    for (int g = 0; g < kNumJoints; ++g)
      if (static_cast<size_t>(part_parent(g + 1)) == c) below.push_back(g);
    const Eigen::Vector3d centre = model.joint_centres.row(j).transpose();
    Eigen::MatrixXd X(m, kOffsetFeatures), O(m, 3);
    int moving = 0;
    for (int e = 0; e < m; ++e) {
      const PartPose& pose = data.poses[static_cast<size_t>(examples[static_cast<size_t>(e)])];
      const PartPoseEstimate& p = placed[static_cast<size_t>(e)];
      const PartTransforms T = part_transforms(pose, model.joint_centres, offsets, 1.0);
      Eigen::Vector3d by_child = p.R[c] * centre + p.t[c];
      if (!below.empty()) {
        by_child.setZero();
        for (int g : below) {
          const Eigen::Vector3d jg = model.joint_centres.row(g).transpose();
          by_child += (p.R[static_cast<size_t>(g + 1)] * jg + p.t[static_cast<size_t>(g + 1)] - T.R[c] * (jg - centre)) /
                      static_cast<double>(below.size());
        }
      }
      O.row(e) = (T.R[q].transpose() * (by_child - (T.R[q] * centre + T.t[q]))).transpose();
      X.row(e) = joint_offset_features(pose, j).transpose();
      moving += X.row(e).head<3>().norm() > 0.03;
    }
    // Ridges: the pivot's over the examples that turn the joint (a side bend may be one of them), the
    // general regression's over all (twists of 0.03 rad and below carry no offset of their own).
    Eigen::Matrix3d M = 1e-3 * std::max(moving, 1) * Eigen::Matrix3d::Identity();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    for (int e = 0; e < m; ++e) {
      const Eigen::Matrix3d K = Eigen::Matrix3d::Identity() - rotation_from_axis_angle(X.row(e).head<3>().transpose());
      M += K.transpose() * K;
      b += K.transpose() * O.row(e).transpose();
    }
    Eigen::MatrixXd A = pivot_offset_coefficients(M.ldlt().solve(b)).transpose();
    if (pivot_only)
      for (int d = 0; d < 3; ++d)
        for (int f = 0; f < kOffsetFeatures; ++f) (*pivot_only)(j, d * kOffsetFeatures + f) = A(f, d);
    Eigen::MatrixXd N = X.transpose() * X;
    N.diagonal().array() += 1e-3 * m;
    A += N.ldlt().solve(X.transpose() * (O - X * A));
    for (int d = 0; d < 3; ++d)
      for (int f = 0; f < kOffsetFeatures; ++f) offsets(j, d * kOffsetFeatures + f) = A(f, d);
  }
  return offsets;
}

/// Each joint's offset earns its place on examples it was not fitted to: in each of five folds the
/// offsets are fitted to the other examples, and the fold posed with them all, with that joint's
/// pivot alone and with none for that joint; per joint the one of the three with the lowest error of
/// the vertices it moves (its child part and everything below), summed over the folds, is kept, then
/// fitted to every example. On a rig whose joints do not move the offsets fit sliding skin and are
/// dropped; a rising shoulder girdle keeps its regression, a chest bending over two thoracic bones
/// (one side bend in training) its pivot.
Eigen::MatrixXd fit_joint_offsets_that_help(const PoseDataset& data, const std::vector<int>& examples, const PoseModel& model) {
  PartFitOptions fit;
  fit.joint_coupling = 0;    // each part where its own vertices put it
  fit.chain_iterations = 0;  // R and t are used, not the pose
  const PartPoseEstimator estimator(model.template_V, model.template_F, model.triangle_part, model.joint_centres, fit);
  std::vector<PartPoseEstimate> placed(examples.size());
  for (size_t e = 0; e < examples.size(); ++e) placed[e] = estimator.estimate(data.V[static_cast<size_t>(examples[e])]);
  SubjectSetupOptions setup;
  setup.is_template = true;
  TriangleMesh templ;
  templ.V = model.template_V;
  templ.F = model.template_F;
  const PoseSynthesizer synth(std::make_shared<const PoseModel>(model), templ, setup);
  const Eigen::VectorXi vertex_part = vertex_labels_from_triangles(templ.V, templ.F, model.triangle_part);
  // Which joints move each part: the joints on its way up to the pelvis.
  std::array<unsigned, kNumParts> moved_by{};
  for (int part = 0; part < kNumParts; ++part)
    for (int p = part; p > 0; p = part_parent(p)) moved_by[static_cast<size_t>(part)] |= 1u << (p - 1);
  // Per joint, the summed held-out error of the vertices it moves, with every offset and without its own.
  std::vector<double> with(kNumJoints, 0.0), without(kNumJoints, 0.0), pivot(kNumJoints, 0.0);
  Eigen::MatrixXd X;
  auto add_errors = [&](int ex, const Eigen::MatrixXd& offsets, int only_joint, std::vector<double>* sums) {
    synth.pose_with_joint_offsets(data.poses[static_cast<size_t>(ex)], offsets, &X);
    for (Eigen::Index v = 0; v < X.rows(); ++v) {
      const unsigned mask = moved_by[static_cast<size_t>(vertex_part[v])];
      if (only_joint >= 0 && !(mask & (1u << only_joint))) continue;
      const double e = (X.row(v) - data.V[static_cast<size_t>(ex)].row(v)).norm();
      for (int j = 0; j < kNumJoints; ++j)
        if ((only_joint < 0 || only_joint == j) && (mask & (1u << j))) (*sums)[static_cast<size_t>(j)] += e;
    }
  };
  constexpr int kFolds = 5;
  for (int fold = 0; fold < kFolds; ++fold) {
    std::vector<int> fitted, held_out;
    std::vector<PartPoseEstimate> fitted_placed;
    for (size_t e = 0; e < examples.size(); ++e) {
      if (static_cast<int>(e % kFolds) == fold) {
        held_out.push_back(examples[e]);
      } else {
        fitted.push_back(examples[e]);
        fitted_placed.push_back(placed[e]);
      }
    }
    if (held_out.empty() || fitted.size() < 2) continue;
    Eigen::MatrixXd pivots;
    const Eigen::MatrixXd offsets = fit_joint_offsets(data, fitted, fitted_placed, model, &pivots);
    for (int ex : held_out) {
      add_errors(ex, offsets, -1, &with);
      for (int j = 0; j < kNumJoints; ++j) {
        Eigen::MatrixXd reduced = offsets;
        reduced.row(j).setZero();
        add_errors(ex, reduced, j, &without);
        reduced.row(j) = pivots.row(j);
        add_errors(ex, reduced, j, &pivot);
      }
    }
  }
  Eigen::MatrixXd pivots;
  Eigen::MatrixXd kept = fit_joint_offsets(data, examples, placed, model, &pivots);
  for (int j = 0; j < kNumJoints; ++j) {
    const double best = std::min({with[static_cast<size_t>(j)], pivot[static_cast<size_t>(j)], without[static_cast<size_t>(j)]});
    if (best == without[static_cast<size_t>(j)]) kept.row(j).setZero();
    else if (best == pivot[static_cast<size_t>(j)]) kept.row(j) = pivots.row(j);
  }
  return kept.isZero(0) ? Eigen::MatrixXd() : kept;
}

}  // namespace

Eigen::MatrixXd deformation_gradients(const Eigen::MatrixXd& V0, const Eigen::MatrixXd& V1, const Eigen::MatrixXi& F) {
  if (V0.rows() != V1.rows())
    throw InvalidInput("deformation_gradients: meshes of " + std::to_string(V0.rows()) + " and " + std::to_string(V1.rows()) + " vertices");
  const auto inv = inverse_frames(V0, F);
  Eigen::MatrixXd D(F.rows(), 9);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    const Eigen::Matrix3d G = triangle_frame(V1, F, k) * inv[static_cast<size_t>(k)];
    for (int m = 0; m < 9; ++m) D(k, m) = G(m / 3, m % 3);
  }
  return D;
}

namespace {

/// The examples train_pose_model learns from (posed, not held out), with the options checked.
std::vector<int> training_examples(const PoseDataset& data, const TrainingOptions& options) {
  const Eigen::MatrixXi& F = data.F;
  std::vector<int> examples;
  for (size_t i = 0; i < data.names.size(); ++i) {
    if (!data.has_pose[i] || data.test[i]) continue;
    validate_part_pose(data.poses[i], "pose of example '" + data.names[i] + "'");
    examples.push_back(static_cast<int>(i));
  }
  if (examples.size() < 2)
    throw InvalidInput("train_pose_model: " + std::to_string(examples.size()) +
                       " training examples with a known pose; at least 2 are needed");
  if (options.triangle_part.size() != F.rows())
    throw InvalidInput("train_pose_model: " + std::to_string(options.triangle_part.size()) + " template labels for " +
                       std::to_string(F.rows()) + " triangles");
  if (options.triangle_part.minCoeff() < 0 || options.triangle_part.maxCoeff() >= kNumParts)
    throw InvalidInput("train_pose_model: a template label is outside [0, 16)");
  if (options.joint_centres.rows() != kNumJoints || options.joint_centres.cols() != 3 || !options.joint_centres.allFinite())
    throw InvalidInput("train_pose_model: expected " + std::to_string(kNumJoints) + " x 3 finite joint centres");
  return examples;
}

/// The two joints nearest to each triangle among those next to its part (Eq. 4), the nearer first
/// by index.
Eigen::MatrixXi nearest_two_joints(const PoseModel& model) {
  const Eigen::MatrixXi& F = model.template_F;
  const Eigen::MatrixXd centroids = face_centroids(model.template_V, F);
  Eigen::MatrixXi triangle_joints = Eigen::MatrixXi::Constant(F.rows(), 2, -1);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    std::vector<std::pair<double, int>> near;
    for (int j : joints_of_part(model.triangle_part[k]))
      near.emplace_back((centroids.row(k) - model.joint_centres.row(j)).squaredNorm(), j);
    std::sort(near.begin(), near.end());
    for (size_t n = 0; n < near.size() && n < 2; ++n) triangle_joints(k, static_cast<Eigen::Index>(n)) = near[n].second;
    if (triangle_joints(k, 1) >= 0 && triangle_joints(k, 1) < triangle_joints(k, 0))
      std::swap(triangle_joints(k, 0), triangle_joints(k, 1));
  }
  return triangle_joints;
}

}  // namespace

PoseModel train_pose_model(const PoseDataset& data, const TrainingOptions& options) {
  const Eigen::MatrixXi& F = data.F;
  const int rest = find_rest_example(data);
  if (rest < 0) throw InvalidInput("train_pose_model: the dataset has no rest-pose example (all joint rotations zero)");
  const std::vector<int> examples = training_examples(data, options);
  PoseModel model;
  const Eigen::MatrixXd& V0 = data.V[static_cast<size_t>(rest)];
  model.template_V = V0;
  model.template_F = F;
  model.triangle_part = options.triangle_part;
  model.joint_centres = options.joint_centres;
  model.training_poses = static_cast<int>(examples.size());

  model.triangle_joints = nearest_two_joints(model);  // Eq. 4

  // Per joint pair, PCA of the observed twists, then the ridge least-squares operator H that maps
  // a triangle's observed T^Q entries (m x 9) to its reduced coefficients (Eq. 5).
  struct Group {
    Eigen::MatrixXd P;  // 6 x d principal directions
    Eigen::Matrix<double, 6, 1> mean;
    Eigen::MatrixXd H;  // (d+1) x m
  };
  const int m = static_cast<int>(examples.size());
  std::map<std::pair<int, int>, Group> groups;
  for (Eigen::Index k = 0; k < F.rows(); ++k) groups[{model.triangle_joints(k, 0), model.triangle_joints(k, 1)}];
  for (auto& [key, g] : groups) {
    Eigen::MatrixXd X(m, 6);
    for (int e = 0; e < m; ++e)
      X.row(e) = features(data.poses[static_cast<size_t>(examples[static_cast<size_t>(e)])], key.first, key.second).head<6>().transpose();
    g.mean = options.identity_at_rest ? Eigen::Matrix<double, 6, 1>::Zero() : Eigen::Matrix<double, 6, 1>(X.colwise().mean().transpose());
    const Eigen::MatrixXd Xc = X.rowwise() - g.mean.transpose();
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(Xc, Eigen::ComputeThinV);
    const Eigen::VectorXd s = svd.singularValues();
    const double total = s.squaredNorm();
    int d = 0;
    while (d < s.size() && total > 0 && s[d] * s[d] > options.pca_energy * total) ++d;
    g.P = svd.matrixV().leftCols(d);
    // With a free bias the last column of Z is ones; with the identity at rest there is none.
    const int bias_columns = options.identity_at_rest ? 0 : 1;
    Eigen::MatrixXd Z(m, d + bias_columns);
    Z.leftCols(d) = Xc * g.P;
    if (bias_columns) Z.col(d).setOnes();
    Eigen::MatrixXd N = Z.transpose() * Z;
    for (int c = 0; c < d; ++c) N(c, c) += options.ridge * m;
    g.H = N.ldlt().solve(Z.transpose());
  }

  std::vector<const Group*> group_of(static_cast<size_t>(F.rows()));
  for (Eigen::Index k = 0; k < F.rows(); ++k)
    group_of[static_cast<size_t>(k)] = &groups.at({model.triangle_joints(k, 0), model.triangle_joints(k, 1)});

  // Stream over the examples: B_k += H(:, e) * T^Q_k(e).
  std::vector<Eigen::MatrixXd> reduced(static_cast<size_t>(F.rows()));
  for (Eigen::Index k = 0; k < F.rows(); ++k)
    reduced[static_cast<size_t>(k)] = Eigen::MatrixXd::Zero(group_of[static_cast<size_t>(k)]->H.rows(), 9);
  // Each example's deformation from its own person's rest (one person: the template).
  if (!data.rest_of.empty() && data.rest_of.size() != data.names.size())
    throw InvalidInput("train_pose_model: " + std::to_string(data.rest_of.size()) + " rest indices for " +
                       std::to_string(data.names.size()) + " examples");
  std::map<int, std::vector<Eigen::Matrix3d>> inverse_rest_frames;
  for (int ex : examples) {
    const int r = data.rest_of.empty() ? rest : data.rest_of[static_cast<size_t>(ex)];
    if (r < 0 || r >= static_cast<int>(data.names.size()))
      throw InvalidInput("train_pose_model: example '" + data.names[static_cast<size_t>(ex)] + "' has no rest example");
    if (!inverse_rest_frames.count(r)) inverse_rest_frames[r] = inverse_frames(data.V[static_cast<size_t>(r)], F);
  }
  if (options.learn_joint_offsets && inverse_rest_frames.size() > 1)
    throw InvalidInput("train_pose_model: joint offsets are learned on one person's examples, these come from " +
                       std::to_string(inverse_rest_frames.size()));
  const Eigen::MatrixXi adjacency = options.smoothing_iterations > 0 ? face_adjacency(F) : Eigen::MatrixXi();
  auto nonrigid = [&](int example, Eigen::Index k, const std::array<Eigen::Matrix3d, kNumParts>& R) {
    const auto& inv0 = inverse_rest_frames.at(data.rest_of.empty() ? rest : data.rest_of[static_cast<size_t>(example)]);
    const Eigen::Matrix3d D = triangle_frame(data.V[static_cast<size_t>(example)], F, k) * inv0[static_cast<size_t>(k)];
    return Eigen::Matrix3d(R[static_cast<size_t>(model.triangle_part[k])].transpose() * D);
  };
  for (int e = 0; e < m; ++e) {
    const int ex = examples[static_cast<size_t>(e)];
    if (data.V[static_cast<size_t>(ex)].rows() != V0.rows())
      throw InvalidInput("train_pose_model: example '" + data.names[static_cast<size_t>(ex)] + "' has another vertex count");
    const auto R = part_rotations(data.poses[static_cast<size_t>(ex)]);
    Eigen::Matrix<double, Eigen::Dynamic, 9, Eigen::RowMajor> Y(F.rows(), 9);
    for (Eigen::Index k = 0; k < F.rows(); ++k) {
      const Eigen::Matrix3d Q = nonrigid(ex, k, R);
      const Eigen::Matrix3d y = options.identity_at_rest ? Eigen::Matrix3d(Q - Eigen::Matrix3d::Identity()) : Q;
      Y.row(k) << y(0, 0), y(0, 1), y(0, 2), y(1, 0), y(1, 1), y(1, 2), y(2, 0), y(2, 1), y(2, 2);
    }
    if (options.smoothing_iterations > 0) smooth_within_parts(adjacency, model.triangle_part, options.smoothing_iterations, &Y);
    for (Eigen::Index k = 0; k < F.rows(); ++k) reduced[static_cast<size_t>(k)] += group_of[static_cast<size_t>(k)]->H.col(e) * Y.row(k);
    if (options.progress) options.progress(e + 1, 2 * m);
  }
  // Back to raw twists: x -> P^T (x - mean), so W = P B_lin and bias = B_bias - mean^T W.
  model.coefficients.resize(F.rows(), kPoseCoefficients);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    const Group& g = *group_of[static_cast<size_t>(k)];
    const Eigen::MatrixXd& B = reduced[static_cast<size_t>(k)];
    const int d = static_cast<int>(g.P.cols());
    const Eigen::MatrixXd W = g.P * B.topRows(d);  // 6 x 9
    Eigen::RowVectorXd bias(9);
    if (options.identity_at_rest) bias << 1, 0, 0, 0, 1, 0, 0, 0, 1;
    else bias = B.row(d) - g.mean.transpose() * W;
    for (int entry = 0; entry < 9; ++entry) {
      for (int f = 0; f < 6; ++f) model.coefficients(k, entry * kPoseFeatures + f) = W(f, entry);
      model.coefficients(k, entry * kPoseFeatures + 6) = bias[entry];
    }
  }
  // Residual of Eq. 5 over the training set.
  double sq = 0;
  long count = 0;
  Eigen::VectorXd triangle_sq = Eigen::VectorXd::Zero(F.rows());
  for (int e = 0; e < m; ++e) {
    const int ex = examples[static_cast<size_t>(e)];
    const auto R = part_rotations(data.poses[static_cast<size_t>(ex)]);
    const Eigen::MatrixXd predicted = predict_nonrigid(model, data.poses[static_cast<size_t>(ex)]);
    for (Eigen::Index k = 0; k < F.rows(); ++k) {
      const Eigen::Matrix3d Q = nonrigid(ex, k, R);
      for (int entry = 0; entry < 9; ++entry) {
        const double r = predicted(k, entry) - Q(entry / 3, entry % 3);
        sq += r * r;
        triangle_sq[k] += r * r;
        ++count;
      }
    }
    if (options.progress) options.progress(m + e + 1, 2 * m);
  }
  model.fit_rms = std::sqrt(sq / std::max<long>(count, 1));
  model.triangle_rms = (triangle_sq / (9.0 * std::max(m, 1))).cwiseSqrt();
  if (options.learn_joint_offsets) {
    model.joint_offsets = fit_joint_offsets_that_help(data, examples, model);
  }
  return model;
}

Eigen::MatrixXd predict_nonrigid(const PoseModel& model, const PartPose& pose) {
  const Eigen::Index nf = model.coefficients.rows();
  Eigen::MatrixXd Q(nf, 9);
  for (Eigen::Index k = 0; k < nf; ++k) {
    const Eigen::Matrix<double, kPoseFeatures, 1> x = features(pose, model.triangle_joints(k, 0), model.triangle_joints(k, 1));
    const Eigen::Map<const Eigen::Matrix<double, 9, kPoseFeatures, Eigen::RowMajor>> B(model.coefficients.row(k).data());
    Q.row(k) = (B * x).transpose();
  }
  return Q;
}

SegmentationPrior segmentation_prior_of(const PoseModel& model) {
  if (!model.segmentation_prior.bodies.empty()) return model.segmentation_prior;
  const LayeredRepresentation rep =
      build_layered_representation(model.template_V, model.template_F, find_body_features(model.template_V, model.template_F));
  SegmentationPrior prior;
  prior.bodies.push_back(make_calibration_body(model.template_V, model.template_F, model.triangle_part, model.joint_centres, rep));
  return prior;
}

}  // namespace posekit
