#include "posekit/segmentation/segmentation_prior.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/segmentation/segmentation.h"

namespace posekit {
namespace {

constexpr int kPointStride = 4;  ///< every 4th point of a layer goes into the shape descriptor

/// Region of each layer: chains 1-5 keep their index, the torso (chain 0) splits at its middle layer.
std::vector<int> layer_regions(const LayeredRepresentation& rep) {
  std::vector<int> region(rep.layers.size());
  int torso_count = 0;
  for (const RepresentationLayer& layer : rep.layers) torso_count += layer.chain == 0;
  int torso_index = 0;
  for (size_t l = 0; l < rep.layers.size(); ++l) {
    const int chain = rep.layers[l].chain;
    if (chain < 0 || chain >= kShapeRegions - 1)
      throw InvalidInput("segmentation prior: representation chain " + std::to_string(chain) + " is not one of the 6");
    region[l] = chain == 0 ? (torso_index++ < torso_count / 2 ? kShapeRegions - 1 : 0) : chain;
  }
  return region;
}

/// Indices of the prior's bodies, nearest first, by `distance(body)`; at most `count`.
template <typename Distance>
std::vector<std::pair<double, int>> nearest_bodies(const SegmentationPrior& prior, int count, Distance distance) {
  std::vector<std::pair<double, int>> d;
  d.reserve(prior.bodies.size());
  for (size_t b = 0; b < prior.bodies.size(); ++b) d.emplace_back(distance(prior.bodies[b]), static_cast<int>(b));
  const size_t k = std::min(d.size(), static_cast<size_t>(std::max(count, 1)));
  std::partial_sort(d.begin(), d.begin() + static_cast<std::ptrdiff_t>(k), d.end());
  d.resize(k);
  return d;
}

double inverse_distance_weight(double distance) { return 1.0 / (distance + 1e-9); }

void check_prior(const SegmentationPrior& prior, const LayeredRepresentation& rep, const RepresentationShape& shape) {
  if (prior.bodies.empty()) throw InvalidInput("segmentation prior: no calibration bodies");
  for (size_t b = 0; b < prior.bodies.size(); ++b) {
    const CalibrationBody& body = prior.bodies[b];
    bool same = body.labels.size() == rep.mesh.F.rows() && body.shape.region.size() == shape.region.size();
    for (size_t r = 0; same && r < shape.region.size(); ++r) same = body.shape.region[r].size() == shape.region[r].size();
    if (!same)
      throw InvalidInput("segmentation prior: calibration body " + std::to_string(b) +
                         " has another representation topology than the body's (" + std::to_string(rep.mesh.F.rows()) + " triangles)");
  }
}

}  // namespace

RepresentationShape representation_shape(const LayeredRepresentation& rep) {
  const std::vector<int> region = layer_regions(rep);
  const int P = rep.points_per_layer;
  RepresentationShape out;
  out.region.resize(kShapeRegions);
  for (int r = 0; r < kShapeRegions; ++r) {
    std::vector<Eigen::Index> ids;
    for (size_t l = 0; l < rep.layers.size(); ++l)
      if (region[l] == r)
        for (int k = 0; k < P; k += kPointStride) ids.push_back(static_cast<Eigen::Index>(l) * P + k);
    Eigen::MatrixXd points(static_cast<Eigen::Index>(ids.size()), 3);
    for (size_t i = 0; i < ids.size(); ++i) points.row(static_cast<Eigen::Index>(i)) = rep.mesh.V.row(ids[i]);
    if (points.rows() > 0) {
      points.rowwise() -= points.colwise().mean();
      const double rms = std::sqrt(points.squaredNorm() / static_cast<double>(points.rows()));
      if (rms > 0) points /= rms;
    }
    Eigen::MatrixXd transposed = points.transpose();  // x, y, z of each point together
    out.region[static_cast<size_t>(r)] = Eigen::Map<Eigen::VectorXd>(transposed.data(), transposed.size()).cast<float>();
  }
  return out;
}

namespace {

/// Region of each representation triangle (#rep triangles, values in [0, kShapeRegions)).
Eigen::VectorXi representation_regions(const LayeredRepresentation& rep) {
  const std::vector<int> region = layer_regions(rep);
  Eigen::VectorXi out(rep.triangle_layer.size());
  for (Eigen::Index t = 0; t < out.size(); ++t) out[t] = region[static_cast<size_t>(rep.triangle_layer[t])];
  return out;
}

}  // namespace

CalibrationBody make_calibration_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                      const Eigen::MatrixXd& joint_centres, const LayeredRepresentation& rep) {
  CalibrationBody body;
  body.shape = representation_shape(rep);
  body.labels = representation_labels_from_body(V, F, triangle_part, rep).cast<std::uint8_t>();
  body.skeleton = make_skeleton_prior(joint_centres, rep);
  return body;
}

Eigen::VectorXi representation_labels_from_prior(const SegmentationPrior& prior, const LayeredRepresentation& rep) {
  const RepresentationShape shape = representation_shape(rep);
  check_prior(prior, rep, shape);
  const Eigen::VectorXi region = representation_regions(rep);
  Eigen::VectorXi labels(rep.mesh.F.rows());
  Eigen::MatrixXd votes(rep.mesh.F.rows(), kNumParts);
  votes.setZero();
  for (int r = 0; r < kShapeRegions; ++r) {
    const Eigen::VectorXf& mine = shape.region[static_cast<size_t>(r)];
    const auto nearest = nearest_bodies(prior, prior.neighbours, [&](const CalibrationBody& b) {
      return static_cast<double>((b.shape.region[static_cast<size_t>(r)] - mine).norm());
    });
    for (const auto& [distance, b] : nearest) {
      const double w = inverse_distance_weight(distance);
      const auto& body_labels = prior.bodies[static_cast<size_t>(b)].labels;
      for (Eigen::Index t = 0; t < labels.size(); ++t)
        if (region[t] == r) votes(t, body_labels[t]) += w;
    }
  }
  for (Eigen::Index t = 0; t < labels.size(); ++t) {
    Eigen::Index best;
    votes.row(t).maxCoeff(&best);
    labels[t] = static_cast<int>(best);
  }
  return labels;
}

Eigen::MatrixXd embed_skeleton(const SegmentationPrior& prior, const LayeredRepresentation& rep) {
  const RepresentationShape shape = representation_shape(rep);
  check_prior(prior, rep, shape);
  // Each joint's neighbours are the bodies shaped most like this one, the arms left out unless the
  // joint is on one: how the arms are held says nothing about where the spine bends or the legs join.
  const std::vector<int> layer_region = layer_regions(rep);
  std::array<bool, kShapeRegions> is_arm{};
  for (size_t l = 0; l < rep.layers.size(); ++l)
    if (rep.layers[l].part >= kLeftUpperArm && rep.layers[l].part <= kRightHand) is_arm[static_cast<size_t>(layer_region[l])] = true;
  auto nearest_with_arms = [&](bool arms) {
    return nearest_bodies(prior, prior.neighbours, [&](const CalibrationBody& b) {
      double squared = 0;
      for (size_t r = 0; r < shape.region.size(); ++r)
        if (arms || !is_arm[r]) squared += (b.shape.region[r] - shape.region[r]).squaredNorm();
      return std::sqrt(squared);
    });
  };
  const auto arm_neighbours = nearest_with_arms(true), other_neighbours = nearest_with_arms(false);
  std::vector<Eigen::MatrixXd> embedded(prior.bodies.size());
  Eigen::MatrixXd joints = Eigen::MatrixXd::Zero(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) {
    const int child = j + 1;
    const bool on_arm = child >= kLeftUpperArm && child <= kRightHand;
    double total = 0;
    for (const auto& [distance, b] : on_arm ? arm_neighbours : other_neighbours) {
      Eigen::MatrixXd& skeleton = embedded[static_cast<size_t>(b)];
      if (skeleton.size() == 0) skeleton = embed_skeleton(prior.bodies[static_cast<size_t>(b)].skeleton, rep);
      const double w = inverse_distance_weight(distance);
      joints.row(j) += w * skeleton.row(j);
      total += w;
    }
    joints.row(j) /= total;
  }
  return joints;
}

}  // namespace posekit
