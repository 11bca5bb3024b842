#include "posekit/segmentation/skeleton_embedding.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_topology.h"

namespace posekit {

namespace {

/// Heights (m) of the first and last torso layers of a representation: crotch and neck base.
std::pair<double, double> torso_span(const LayeredRepresentation& rep) {
  double lo = 0, hi = 0;
  bool found = false;
  for (const RepresentationLayer& layer : rep.layers) {
    if (layer.chain != 0) continue;  // chain 0 is the torso
    if (!found) lo = layer.centre.y();
    hi = layer.centre.y();
    found = true;
  }
  if (!found || !(hi > lo)) throw InvalidInput("torso_span: the representation has no torso chain");
  return {lo, hi};
}

}  // namespace

SkeletonPrior make_skeleton_prior(const Eigen::MatrixXd& template_joints, const LayeredRepresentation& template_rep) {
  if (template_joints.rows() != kNumJoints || template_joints.cols() != 3)
    throw InvalidInput("make_skeleton_prior: expected " + std::to_string(kNumJoints) + " x 3 joint centres, got " +
                       std::to_string(template_joints.rows()) + " x " + std::to_string(template_joints.cols()));
  SkeletonPrior prior{ctffd_parametrize(template_joints, template_rep)};
  const auto [lo, hi] = torso_span(template_rep);
  for (int j = 0; j < 3; ++j) prior.torso_fraction[j] = (template_joints(j, 1) - lo) / (hi - lo);
  return prior;
}

namespace {

/// Length-weighted centre of each joint's border edges; weight 0 where the parts do not touch.
Eigen::MatrixXd border_centres(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                               Eigen::VectorXd* weight) {
  const Eigen::MatrixXi TT = face_adjacency(F);
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(kNumJoints, 3);
  Eigen::VectorXd& w = *weight;
  w = Eigen::VectorXd::Zero(kNumJoints);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    for (int c = 0; c < 3; ++c) {
      const int g = TT(f, c);
      if (g < f) continue;  // each edge once; skips boundaries (-1)
      const int a = triangle_part[f], b = triangle_part[g];
      int child = -1;
      if (part_parent(a) == b) child = a;
      else if (part_parent(b) == a) child = b;
      if (child < 1) continue;
      const Eigen::RowVector3d p = V.row(F(f, c)), q = V.row(F(f, (c + 1) % 3));
      const double len = (p - q).norm();
      sum.row(child - 1) += len * 0.5 * (p + q);
      w[child - 1] += len;
    }
  }
  for (int j = 0; j < kNumJoints; ++j)
    if (w[j] > 0) sum.row(j) /= w[j];
  return sum;
}

}  // namespace

Eigen::MatrixXd embed_skeleton(const SkeletonPrior& prior, const LayeredRepresentation& rep) {
  Eigen::MatrixXd joints = ctffd_evaluate(prior.joints, rep);
  const auto [lo, hi] = torso_span(rep);
  for (int j = 0; j < 3; ++j) joints(j, 1) = lo + prior.torso_fraction[j] * (hi - lo);
  return joints;
}

Eigen::MatrixXd reconcile_limb_joints(const Eigen::MatrixXd& joints, const BodyFeatures& f, double tolerance,
                                      std::vector<std::string>* replaced) {
  if (joints.rows() != kNumJoints || joints.cols() != 3)
    throw InvalidInput("reconcile_limb_joints: expected " + std::to_string(kNumJoints) + " x 3 joint centres");
  Eigen::MatrixXd J = joints;
  auto take = [&](int part, const Eigen::Vector3d& feature, bool always = false) {
    const int j = part - 1;
    const double d = (J.row(j).transpose() - feature).norm();
    if (always) J.row(j) = feature.transpose();
    if (!(d > tolerance)) return;
    if (replaced)
      replaced->push_back(joint_name(j) + ": the prior's joint lies " + std::to_string(static_cast<int>(std::lround(d * 1000))) +
                          " mm from the body's own; the body's taken");
    J.row(j) = feature.transpose();
  };
  for (int side : {kLeft, kRight}) {
    const bool left = side == kLeft;
    if (f.arm_found[side]) {
      // A cut hand shortens the arm's chain of layers, and the prior's elbow and wrist slide with it.
      take(left ? kLeftForearm : kRightForearm, f.elbow[side], f.hand_cut[side]);
      take(left ? kLeftHand : kRightHand, f.wrist[side], f.hand_cut[side]);
    }
    take(left ? kLeftThigh : kRightThigh, f.hip[side], true);
    take(left ? kLeftShank : kRightShank, f.knee[side]);
    take(left ? kLeftFoot : kRightFoot, f.ankle[side]);
  }
  return J;
}

Eigen::Vector3d typical_torso_fractions() { return Eigen::Vector3d(0.245, 0.490, 1.006); }

RefitConstant refit_typical_torso_fractions(const std::vector<FeatureCalibrationSample>& samples) {
  const char* joints[3] = {"lower_back", "upper_back", "neck"};
  const Eigen::Vector3d shipped = typical_torso_fractions();
  RefitConstant c;
  c.name = "typical_torso_fractions";
  c.what = "lower back, upper back and neck joint heights as fractions of the torso span";
  c.fit = "median";
  c.shipped.assign(shipped.data(), shipped.data() + 3);
  std::vector<double> fraction[3], span;
  for (const FeatureCalibrationSample& s : samples) {
    if (!s.torso || !(s.torso_high > s.torso_low)) continue;
    span.push_back(s.torso_high - s.torso_low);
    for (int j = 0; j < 3; ++j) fraction[j].push_back((s.joints(find_joint_index(joints[j]), 1) - s.torso_low) / span.back());
  }
  c.samples = static_cast<int>(span.size());
  if (span.empty()) throw InvalidInput("calibration: no torso spans for typical_torso_fractions");
  double old_sum = 0, new_sum = 0;
  for (int j = 0; j < 3; ++j) {
    std::vector<double> v = fraction[j];
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    c.refit.push_back(v[v.size() / 2]);
    for (size_t i = 0; i < span.size(); ++i) {
      old_sum += std::pow((fraction[j][i] - shipped[j]) * span[i], 2);
      new_sum += std::pow((fraction[j][i] - c.refit[static_cast<size_t>(j)]) * span[i], 2);
    }
  }
  const double n = 3.0 * static_cast<double>(span.size());
  c.shipped_rms_mm = 1000 * std::sqrt(old_sum / n), c.refit_rms_mm = 1000 * std::sqrt(new_sum / n);
  return c;
}

Eigen::MatrixXd joint_centres_from_features(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                            const LayeredRepresentation& rep, const BodyFeatures& f) {
  Eigen::VectorXd weight;
  Eigen::MatrixXd J = border_centres(V, F, triangle_part, &weight);
  const auto [lo, hi] = torso_span(rep);
  const Eigen::Vector3d fraction = typical_torso_fractions();
  for (int j = 0; j < 3; ++j) {
    // On the torso axis: the centre of the torso layers at that height.
    const double y = lo + fraction[j] * (hi - lo);
    Eigen::Vector3d below = Eigen::Vector3d::Zero(), above = Eigen::Vector3d::Zero();
    bool have_below = false, have_above = false;
    for (const RepresentationLayer& layer : rep.layers) {
      if (layer.chain != 0) continue;
      if (layer.centre.y() <= y) below = layer.centre, have_below = true;
      if (layer.centre.y() >= y && !have_above) above = layer.centre, have_above = true;
    }
    Eigen::Vector3d c = have_below ? below : above;
    if (have_below && have_above && above.y() > below.y()) c = below + (y - below.y()) / (above.y() - below.y()) * (above - below);
    J.row(j) << f.axis_x, y, c.z();
  }
  for (int side : {kLeft, kRight}) {
    const bool left = side == kLeft;
    if (f.arm_found[side]) {
      J.row((left ? kLeftUpperArm : kRightUpperArm) - 1) = f.shoulder[side].transpose();
      J.row((left ? kLeftForearm : kRightForearm) - 1) = f.elbow[side].transpose();
      J.row((left ? kLeftHand : kRightHand) - 1) = f.wrist[side].transpose();
    }
    J.row((left ? kLeftThigh : kRightThigh) - 1) = f.hip[side].transpose();
    J.row((left ? kLeftShank : kRightShank) - 1) = f.knee[side].transpose();
    J.row((left ? kLeftFoot : kRightFoot) - 1) = f.ankle[side].transpose();
  }
  return J;
}

Eigen::MatrixXd joint_centres_from_segmentation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part) {
  Eigen::VectorXd weight;
  const Eigen::MatrixXd J = border_centres(V, F, triangle_part, &weight);
  for (int j = 0; j < kNumJoints; ++j)
    if (weight[j] <= 0) throw InvalidInput("joint_centres_from_segmentation: the parts of joint '" + joint_name(j) + "' do not touch");
  return J;
}

}  // namespace posekit
