#include "posekit/segmentation/skeleton_embedding.h"

#include <string>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_topology.h"

namespace posekit {

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

SkeletonPrior make_skeleton_prior(const Eigen::MatrixXd& template_joints, const LayeredRepresentation& template_rep) {
  if (template_joints.rows() != kNumJoints || template_joints.cols() != 3)
    throw InvalidInput("make_skeleton_prior: expected " + std::to_string(kNumJoints) + " x 3 joint centres, got " +
                       std::to_string(template_joints.rows()) + " x " + std::to_string(template_joints.cols()));
  SkeletonPrior prior{ctffd_parametrize(template_joints, template_rep)};
  const auto [lo, hi] = torso_span(template_rep);
  for (int j = 0; j < 3; ++j) prior.torso_fraction[j] = (template_joints(j, 1) - lo) / (hi - lo);
  return prior;
}

Eigen::MatrixXd embed_skeleton(const SkeletonPrior& prior, const LayeredRepresentation& rep) {
  Eigen::MatrixXd joints = ctffd_evaluate(prior.joints, rep);
  const auto [lo, hi] = torso_span(rep);
  for (int j = 0; j < 3; ++j) joints(j, 1) = lo + prior.torso_fraction[j] * (hi - lo);
  return joints;
}

Eigen::MatrixXd joint_centres_from_segmentation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                                const Eigen::VectorXi& triangle_part) {
  const Eigen::MatrixXi TT = face_adjacency(F);
  Eigen::MatrixXd sum = Eigen::MatrixXd::Zero(kNumJoints, 3);
  Eigen::VectorXd weight = Eigen::VectorXd::Zero(kNumJoints);
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
      weight[child - 1] += len;
    }
  }
  for (int j = 0; j < kNumJoints; ++j) {
    if (weight[j] <= 0)
      throw InvalidInput("joint_centres_from_segmentation: the parts of joint '" + joint_name(j) + "' do not touch");
    sum.row(j) /= weight[j];
  }
  return sum;
}

}  // namespace posekit
