#include "posekit/deformation/part_pose_estimation.h"

#include "posekit/deformation/rigid_pose.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

#include "posekit/core/error.h"

namespace posekit {
namespace {

/// Weighted Kabsch: the proper rotation and translation taking X to Y in the weighted least-squares sense.
void weighted_procrustes(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, const std::vector<double>& w, Eigen::Matrix3d* R,
                         Eigen::Vector3d* t) {
  double total = 0;
  Eigen::Vector3d cx = Eigen::Vector3d::Zero(), cy = Eigen::Vector3d::Zero();
  for (Eigen::Index i = 0; i < X.rows(); ++i) {
    const double wi = w[static_cast<size_t>(i)];
    total += wi;
    cx += wi * X.row(i).transpose();
    cy += wi * Y.row(i).transpose();
  }
  cx /= total;
  cy /= total;
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  for (Eigen::Index i = 0; i < X.rows(); ++i)
    H += w[static_cast<size_t>(i)] * (X.row(i).transpose() - cx) * (Y.row(i).transpose() - cy).transpose();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
  *R = svd.matrixV() * D * svd.matrixU().transpose();
  *t = cy - *R * cx;
}

}  // namespace

PartPoseEstimator::PartPoseEstimator(const Eigen::MatrixXd& rest_V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                     const Eigen::MatrixXd& joint_centres, const PartFitOptions& options)
    : rest_V_(rest_V), joints_(joint_centres), options_(options) {
  if (triangle_part.size() != F.rows())
    throw InvalidInput("part pose estimation: " + std::to_string(triangle_part.size()) + " part labels for " + std::to_string(F.rows()) +
                       " triangles");
  if (joint_centres.rows() != kNumJoints || joint_centres.cols() != 3 || !joint_centres.allFinite())
    throw InvalidInput("part pose estimation: expected " + std::to_string(kNumJoints) + " x 3 finite joint centres");
  // Each vertex belongs to the part most of its triangles carry.
  std::vector<std::array<int, kNumParts>> votes(static_cast<size_t>(rest_V.rows()));
  for (auto& v : votes) v.fill(0);
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    const int p = triangle_part[k];
    if (p < 0 || p >= kNumParts)
      throw InvalidInput("part pose estimation: triangle " + std::to_string(k) + " has label " + std::to_string(p));
    for (int c = 0; c < 3; ++c) ++votes[static_cast<size_t>(F(k, c))][static_cast<size_t>(p)];
  }
  for (Eigen::Index v = 0; v < rest_V.rows(); ++v) {
    const auto& n = votes[static_cast<size_t>(v)];
    const auto best = std::max_element(n.begin(), n.end());
    if (*best > 0) part_vertices_[static_cast<size_t>(best - n.begin())].push_back(static_cast<int>(v));
  }
  // Each part's reach: the largest distance of its vertices from its nearest joint.
  std::array<double, kNumParts>& reach = reach_;
  reach.fill(0);
  for (int p = 0; p < kNumParts; ++p) {
    const auto& verts = part_vertices_[static_cast<size_t>(p)];
    if (verts.size() < 3)
      throw InvalidInput("part pose estimation: part '" + part_name(p) + "' has " + std::to_string(verts.size()) +
                         " vertices; a rigid fit needs at least 3");
    for (int v : verts) {
      double d = std::numeric_limits<double>::infinity();
      for (int j : joints_of_part(p)) d = std::min(d, (rest_V.row(v) - joint_centres.row(j)).norm());
      reach[static_cast<size_t>(p)] = std::max(reach[static_cast<size_t>(p)], d);
    }
  }
  // A joint's zone scales with the longer of its two parts, on both sides: the skin a thigh drags
  // reaches into the pelvis as far as the thigh's own seam.
  std::array<double, kNumJoints> zone{};
  for (int j = 0; j < kNumJoints; ++j)
    zone[static_cast<size_t>(j)] =
        options.joint_zone * std::max(reach[static_cast<size_t>(j + 1)], reach[static_cast<size_t>(part_parent(j + 1))]);
  for (int p = 0; p < kNumParts; ++p) {
    const auto& verts = part_vertices_[static_cast<size_t>(p)];
    auto& w = joint_weight_[static_cast<size_t>(p)];
    auto& core = away_from_joints_[static_cast<size_t>(p)];
    w.assign(verts.size(), 1.0);
    for (size_t i = 0; i < verts.size(); ++i)
      for (int j : joints_of_part(p)) {
        const double z = zone[static_cast<size_t>(j)];
        const double d = (rest_V.row(verts[i]) - joint_centres.row(j)).norm();
        if (z > 0) w[i] = std::min(w[i], std::clamp((d - z) / z, 0.0, 1.0) * 0.9 + 0.1);
      }
    core.resize(verts.size());
    for (size_t i = 0; i < verts.size(); ++i) core[i] = w[i] >= 1;
  }
}

PartPoseEstimate PartPoseEstimator::estimate(const Eigen::MatrixXd& posed_V) const {
  if (posed_V.rows() != rest_V_.rows() || posed_V.cols() != 3)
    throw InvalidInput("part pose estimation: the example has " + std::to_string(posed_V.rows()) + " vertices, the rest mesh " +
                       std::to_string(rest_V_.rows()));
  if (!posed_V.allFinite()) throw InvalidInput("part pose estimation: the example has a vertex that is not finite");
  PartPoseEstimate out;
  std::array<std::vector<double>, kNumParts> weights;
  for (int p = 0; p < kNumParts; ++p) {
    const auto& verts = part_vertices_[static_cast<size_t>(p)];
    const auto& wj = joint_weight_[static_cast<size_t>(p)];
    const auto& core_mask = away_from_joints_[static_cast<size_t>(p)];
    const Eigen::Index n = static_cast<Eigen::Index>(verts.size());
    Eigen::MatrixXd X(n, 3), Y(n, 3);
    for (Eigen::Index i = 0; i < n; ++i) {
      X.row(i) = rest_V_.row(verts[static_cast<size_t>(i)]);
      Y.row(i) = posed_V.row(verts[static_cast<size_t>(i)]);
    }
    std::vector<double> w = wj, r(static_cast<size_t>(n));
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    for (int it = 0;; ++it) {
      weighted_procrustes(X, Y, w, &R, &t);
      if (it == options_.robust_iterations) break;
      for (Eigen::Index i = 0; i < n; ++i) r[static_cast<size_t>(i)] = (R * X.row(i).transpose() + t - Y.row(i).transpose()).norm();
      // Cauchy weights on a robust scale: the median residual of the part's core.
      std::vector<double> core;
      for (size_t i = 0; i < r.size(); ++i)
        if (core_mask[i]) core.push_back(r[i]);
      if (core.empty()) core = r;
      std::nth_element(core.begin(), core.begin() + static_cast<long>(core.size() / 2), core.end());
      const double scale = std::max(options_.min_robust_scale, 2.0 * core[core.size() / 2]);
      for (size_t i = 0; i < w.size(); ++i) w[i] = wj[i] / (1 + (r[i] / scale) * (r[i] / scale));
    }
    out.R[static_cast<size_t>(p)] = R;
    out.t[static_cast<size_t>(p)] = t;
    weights[static_cast<size_t>(p)] = std::move(w);
  }
  if (options_.joint_coupling > 0) couple_at_joints(posed_V, weights, &out);

  double total_sq = 0;
  long total_n = 0;
  for (int p = 0; p < kNumParts; ++p) {
    const size_t s = static_cast<size_t>(p);
    const auto& verts = part_vertices_[s];
    const auto& core_mask = away_from_joints_[s];
    double core_sq = 0, all_sq = 0, reach = 0;
    long core_n = 0;
    for (size_t i = 0; i < verts.size(); ++i) {
      const Eigen::Vector3d x = rest_V_.row(verts[i]).transpose();
      const double r2 = (out.R[s] * x + out.t[s] - posed_V.row(verts[i]).transpose()).squaredNorm();
      all_sq += r2;
      if (core_mask[i]) core_sq += r2, ++core_n;
      double d = std::numeric_limits<double>::infinity();
      for (int j : joints_of_part(p)) d = std::min(d, (x - joints_.row(j).transpose()).norm());
      reach = std::max(reach, d);
    }
    const double n = static_cast<double>(verts.size());
    out.part_rms[s] = std::sqrt(all_sq / n);
    out.core_rms[s] = core_n ? std::sqrt(core_sq / static_cast<double>(core_n)) : out.part_rms[s];
    out.reach[s] = reach;
    total_sq += all_sq;
    total_n += static_cast<long>(verts.size());
    if (out.core_rms[s] > out.core_rms[static_cast<size_t>(out.worst_part)]) out.worst_part = p;
  }
  out.rms = std::sqrt(total_sq / static_cast<double>(std::max<long>(total_n, 1)));
  out.pose.root_rotation = axis_angle_from_rotation(out.R[kPelvis]);
  // part_transforms turns the pelvis about the mean of its three joints, then moves it.
  const Eigen::Vector3d pivot = (joints_.row(kAbdomen - 1) + joints_.row(kLeftThigh - 1) + joints_.row(kRightThigh - 1)).transpose() / 3;
  out.pose.root_translation = out.t[kPelvis] - pivot + out.R[kPelvis] * pivot;
  for (int p = 1; p < kNumParts; ++p)
    out.pose.joint(p - 1) =
        axis_angle_from_rotation(out.R[static_cast<size_t>(part_parent(p))].transpose() * out.R[static_cast<size_t>(p)]);
  if (options_.chain_iterations > 0) refine_along_chain(posed_V, weights, &out.pose);
  return out;
}

void PartPoseEstimator::refine_along_chain(const Eigen::MatrixXd& Y, const std::array<std::vector<double>, kNumParts>& weights,
                                           PartPose* pose) const {
  // Gauss-Newton on the pose itself: every vertex placed by forward kinematics about the rest joint
  // centres (T^R), so the parts' places follow from the joint rotations as posing puts them.
  // Unknowns as apply_pose_increment's; a part's twist (shift d, rotation w) is B times them.
  const Eigen::Vector3d pelvis_pivot =
      (joints_.row(kAbdomen - 1) + joints_.row(kLeftThigh - 1) + joints_.row(kRightThigh - 1)).transpose() / 3;
  double previous = std::numeric_limits<double>::infinity();
  PartPose before = *pose;
  for (int iteration = 0; iteration < options_.chain_iterations; ++iteration) {
    const PartTransforms T = part_transforms(*pose, joints_);
    Eigen::Matrix<double, kPoseIncrementSize, kPoseIncrementSize> N = Eigen::Matrix<double, kPoseIncrementSize, kPoseIncrementSize>::Zero();
    Eigen::Matrix<double, kPoseIncrementSize, 1> g = Eigen::Matrix<double, kPoseIncrementSize, 1>::Zero();
    double cost = 0;
    for (int q = 0; q < kNumParts; ++q) {
      const size_t s = static_cast<size_t>(q);
      Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
      Eigen::Matrix<double, 6, 1> b = Eigen::Matrix<double, 6, 1>::Zero();
      const auto& verts = part_vertices_[s];
      for (size_t i = 0; i < verts.size(); ++i) {
        const Eigen::Vector3d y = T.R[s] * rest_V_.row(verts[i]).transpose() + T.t[s];
        const Eigen::Vector3d r = y - Y.row(verts[i]).transpose();
        Eigen::Matrix<double, 3, 6> J;
        J << Eigen::Matrix3d::Identity(), -cross_product_matrix(y);
        const double w = weights[s][i];
        H += w * J.transpose() * J;
        b += w * J.transpose() * r;
        cost += w * r.squaredNorm();
      }
      // The pose unknowns that move part q: root shift, root turn about the posed pelvis pivot, and
      // each joint on its chain about its posed centre (carried by the joint's parent part).
      std::vector<std::pair<int, Eigen::Vector3d>> turns = {{3, T.R[kPelvis] * pelvis_pivot + T.t[kPelvis]}};
      for (int c = q; c != kPelvis; c = part_parent(c)) {
        const size_t parent = static_cast<size_t>(part_parent(c));
        turns.emplace_back(6 + 3 * (c - 1), T.R[parent] * joints_.row(c - 1).transpose() + T.t[parent]);
      }
      std::vector<int> column = {0, 1, 2};
      Eigen::Matrix<double, 6, Eigen::Dynamic> B =
          Eigen::Matrix<double, 6, Eigen::Dynamic>::Zero(6, 3 + 3 * static_cast<Eigen::Index>(turns.size()));
      B.topLeftCorner<3, 3>().setIdentity();
      for (size_t k = 0; k < turns.size(); ++k) {
        const Eigen::Index c = 3 + 3 * static_cast<Eigen::Index>(k);
        B.block<3, 3>(0, c) = cross_product_matrix(turns[k].second);
        B.block<3, 3>(3, c).setIdentity();
        for (int a = 0; a < 3; ++a) column.push_back(turns[k].first + a);
      }
      const Eigen::MatrixXd BtHB = B.transpose() * H * B;
      const Eigen::VectorXd Btb = B.transpose() * b;
      for (Eigen::Index a = 0; a < B.cols(); ++a) {
        g[column[static_cast<size_t>(a)]] += Btb[a];
        for (Eigen::Index k = 0; k < B.cols(); ++k) N(column[static_cast<size_t>(a)], column[static_cast<size_t>(k)]) += BtHB(a, k);
      }
    }
    if (cost >= previous) {  // the last step did not help: back to the pose before it
      *pose = before;
      return;
    }
    if (cost > previous * (1 - 1e-6)) return;
    previous = cost;
    before = *pose;
    // A light Levenberg damping keeps a joint whose parts barely constrain it (a hand seen edge-on) still.
    N.diagonal() += 1e-9 * N.diagonal().cwiseAbs().maxCoeff() * Eigen::Matrix<double, kPoseIncrementSize, 1>::Ones();
    const Eigen::Matrix<double, kPoseIncrementSize, 1> step = N.ldlt().solve(-g);
    if (!step.allFinite()) return;
    apply_pose_increment(pose, step);
  }
}

void PartPoseEstimator::couple_at_joints(const Eigen::MatrixXd& Y, const std::array<std::vector<double>, kNumParts>& weights,
                                         PartPoseEstimate* e) const {
  // Gauss-Newton on all 16 rigid motions at once: each part's weighted vertex residuals, plus each
  // joint centre carried by parent and child to the same place, weighted like the lighter part's
  // vertices times joint_coupling. Unknowns per part: a small rotation w and a shift d.
  constexpr int kUnknowns = 6 * kNumParts;
  std::array<double, kNumParts> part_weight{};
  for (int p = 0; p < kNumParts; ++p)
    for (double w : weights[static_cast<size_t>(p)]) part_weight[static_cast<size_t>(p)] += w;
  auto skew = [](const Eigen::Vector3d& v) {
    Eigen::Matrix3d S;
    S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
    return S;
  };
  // A part that fits far from where its neighbour puts their joint (a broken or mislabelled part)
  // is not allowed to drag the neighbour along: Cauchy weight on that first gap, on a quarter of
  // the lighter part's reach.
  std::array<double, kNumJoints> trust{};
  for (int j = 0; j < kNumJoints; ++j) {
    const size_t a = static_cast<size_t>(part_parent(j + 1)), b = static_cast<size_t>(j + 1);
    const Eigen::Vector3d c = joints_.row(j).transpose();
    const double gap = ((e->R[a] * c + e->t[a]) - (e->R[b] * c + e->t[b])).norm();
    const double scale = std::max(options_.min_robust_scale, 0.25 * std::min(reach_[a], reach_[b]));
    trust[static_cast<size_t>(j)] = 1 / (1 + (gap / scale) * (gap / scale));
  }
  for (int iteration = 0; iteration < 3; ++iteration) {
    Eigen::Matrix<double, kUnknowns, kUnknowns> N = Eigen::Matrix<double, kUnknowns, kUnknowns>::Zero();
    Eigen::Matrix<double, kUnknowns, 1> g = Eigen::Matrix<double, kUnknowns, 1>::Zero();
    for (int p = 0; p < kNumParts; ++p) {
      const size_t s = static_cast<size_t>(p);
      const auto& verts = part_vertices_[s];
      for (size_t i = 0; i < verts.size(); ++i) {
        const Eigen::Vector3d q = e->R[s] * rest_V_.row(verts[i]).transpose();
        const Eigen::Vector3d r = q + e->t[s] - Y.row(verts[i]).transpose();
        Eigen::Matrix<double, 3, 6> J;
        J << -skew(q), Eigen::Matrix3d::Identity();
        const double w = weights[s][i];
        N.block<6, 6>(6 * p, 6 * p) += w * J.transpose() * J;
        g.segment<6>(6 * p) += w * J.transpose() * r;
      }
    }
    for (int j = 0; j < kNumJoints; ++j) {
      const int child = j + 1, parent = part_parent(child);
      const size_t a = static_cast<size_t>(parent), b = static_cast<size_t>(child);
      const Eigen::Vector3d c = joints_.row(j).transpose();
      const Eigen::Vector3d qa = e->R[a] * c, qb = e->R[b] * c;
      const Eigen::Vector3d r = (qa + e->t[a]) - (qb + e->t[b]);
      Eigen::Matrix<double, 3, 12> J;
      J << -skew(qa), Eigen::Matrix3d::Identity(), skew(qb), -Eigen::Matrix3d::Identity();
      const double w = options_.joint_coupling * trust[static_cast<size_t>(j)] * std::min(part_weight[a], part_weight[b]);
      const int idx[2] = {6 * parent, 6 * child};
      for (int u = 0; u < 2; ++u) {
        g.segment<6>(idx[u]) += w * J.middleCols<6>(6 * u).transpose() * r;
        for (int v = 0; v < 2; ++v) N.block<6, 6>(idx[u], idx[v]) += w * J.middleCols<6>(6 * u).transpose() * J.middleCols<6>(6 * v);
      }
    }
    const Eigen::Matrix<double, kUnknowns, 1> step = N.ldlt().solve(-g);
    if (!step.allFinite()) return;
    for (int p = 0; p < kNumParts; ++p) {
      const size_t s = static_cast<size_t>(p);
      const Eigen::Vector3d w = step.segment<3>(6 * p), d = step.segment<3>(6 * p + 3);
      const Eigen::Matrix3d dR = rotation_from_axis_angle(w);
      e->R[s] = dR * e->R[s];
      e->t[s] = dR * e->t[s] + d;  // the rotation turns about the origin, as the linearisation does
    }
  }
}

Eigen::VectorXd PartPoseEstimator::learn_rigid_cores(const std::vector<const Eigen::MatrixXd*>& examples) {
  const Eigen::Index n = rest_V_.rows();
  std::vector<std::vector<double>> residuals(static_cast<size_t>(n));
  std::vector<int> part_of(static_cast<size_t>(n), -1);
  for (int p = 0; p < kNumParts; ++p)
    for (int v : part_vertices_[static_cast<size_t>(p)]) part_of[static_cast<size_t>(v)] = p;
  for (const Eigen::MatrixXd* X : examples) {
    const PartPoseEstimate e = estimate(*X);
    for (Eigen::Index v = 0; v < n; ++v) {
      const int p = part_of[static_cast<size_t>(v)];
      if (p < 0) continue;
      const size_t s = static_cast<size_t>(p);
      residuals[static_cast<size_t>(v)].push_back((e.R[s] * rest_V_.row(v).transpose() + e.t[s] - X->row(v).transpose()).norm());
    }
  }
  Eigen::VectorXd rms = Eigen::VectorXd::Zero(n);
  for (Eigen::Index v = 0; v < n; ++v) {
    const auto& r = residuals[static_cast<size_t>(v)];
    if (r.empty()) continue;
    double sq = 0;
    for (double x : r) sq += x * x;
    rms[v] = std::sqrt(sq / static_cast<double>(r.size()));
  }
  if (examples.empty()) return rms;
  for (int p = 0; p < kNumParts; ++p) {
    const auto& verts = part_vertices_[static_cast<size_t>(p)];
    std::vector<double> m;
    for (int v : verts) m.push_back(rms[v]);
    std::nth_element(m.begin(), m.begin() + static_cast<long>(m.size() / 2), m.end());
    const double scale = std::max(options_.min_robust_scale, m[m.size() / 2]);
    auto& w = joint_weight_[static_cast<size_t>(p)];
    for (size_t i = 0; i < verts.size(); ++i) {
      const double q = rms[verts[i]] / scale;
      w[i] *= 1 / (1 + q * q);
    }
  }
  return rms;
}

double rotation_difference(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Eigen::AngleAxisd(rotation_from_axis_angle(a).transpose() * rotation_from_axis_angle(b)).angle();
}

std::vector<std::string> pose_estimate_problems(const PartPoseEstimate& e, double max_core_rms) {
  std::vector<std::pair<double, std::string>> found;  // (how far over its limit, what)
  for (int p = 0; p < kNumParts; ++p) {
    const size_t s = static_cast<size_t>(p);
    const double limit = std::min(max_core_rms, 0.25 * e.reach[s]);
    if (e.core_rms[s] > limit) {
      std::ostringstream msg;
      msg.precision(1);
      msg << std::fixed << "part '" << part_name(p) << "' is no rigid motion of the rest part (residual " << 1000 * e.core_rms[s]
          << " mm RMS away from its joints, over " << 1000 * limit << " mm)";
      found.emplace_back(e.core_rms[s] / limit, msg.str());
    }
  }
  for (int j = 0; j < kNumJoints; ++j) {
    const double deg = e.pose.joint(j).norm() * 180 / M_PI;
    if (deg > 175) {
      std::ostringstream msg;
      msg.precision(0);
      msg << std::fixed << "joint '" << joint_name(j) << "' turned " << deg << " degrees, more than a body bends";
      found.emplace_back(deg / 175, msg.str());
    }
  }
  std::stable_sort(found.begin(), found.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::vector<std::string> problems;
  for (auto& f : found) problems.push_back(std::move(f.second));
  return problems;
}

}  // namespace posekit
