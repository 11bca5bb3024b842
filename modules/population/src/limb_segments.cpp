#include "posekit/population/limb_segments.h"

#include <Eigen/QR>
#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"

namespace posekit {
namespace {

/// The segments' parts on the subject's left (the right side mirrors them).
constexpr Part kSegmentPart[kLimbSegmentCount] = {kLeftUpperArm, kLeftForearm, kLeftThigh, kLeftShank};

bool is_below(int part, int segment_part) {
  for (int p = part_parent(part); p >= 0; p = part_parent(p))
    if (p == segment_part) return true;
  return false;
}

}  // namespace

std::array<double, kLimbSegmentCount> limb_segment_spread(const std::vector<SurveySubject>& subjects) {
  constexpr int regressors = kSurveyMeasureCount + 2;  // the measurements, sex, a constant
  std::array<double, kLimbSegmentCount> spread;
  for (int k = 0; k < kLimbSegmentCount; ++k) {
    std::vector<const SurveySubject*> measured;
    for (const SurveySubject& s : subjects)
      if (std::isfinite(s.segments[k])) measured.push_back(&s);
    const auto n = static_cast<Eigen::Index>(measured.size());
    if (n < 10 * regressors) {
      spread[k] = std::numeric_limits<double>::quiet_NaN();
      continue;
    }
    Eigen::MatrixXd X(n, regressors);
    Eigen::VectorXd y(n);
    for (Eigen::Index i = 0; i < n; ++i) {
      const SurveySubject& s = *measured[static_cast<size_t>(i)];
      for (int m = 0; m < kSurveyMeasureCount; ++m) X(i, m) = s.values[m];
      X(i, kSurveyMeasureCount) = s.male ? 1 : 0;
      X(i, kSurveyMeasureCount + 1) = 1;
      y[i] = s.segments[k];
    }
    const Eigen::VectorXd b = X.colPivHouseholderQr().solve(y);
    spread[k] = std::sqrt((y - X * b).squaredNorm() / static_cast<double>(n - regressors));
  }
  return spread;
}

void add_limb_segment_components(const MakeHumanModel& model, const std::array<double, kLimbSegmentCount>& spread, ShapeSpace* space) {
  const int nv = space->vertices();
  if (nv != model.num_body_vertices || !space->has_joints() || space->joint_mean.rows() != kNumJoints || space->components() < 1)
    throw InvalidInput("limb segment components: the shape space (" + std::to_string(nv) +
                       " vertices) is not of the MakeHuman template's topology with its joints and components");
  const auto weights = vertex_part_weights(model);
  // The components' variance shares in the space's own total (component 0's share gives it).
  const double total = space->basis.col(0).squaredNorm() / std::max(space->variance_share.front(), 1e-300);
  int added = 0;
  double added_variance = 0;
  for (int k = 0; k < kLimbSegmentCount; ++k) {
    if (!(spread[k] > 0)) continue;
    Eigen::VectorXd column = Eigen::VectorXd::Zero(3 * nv), joint_column = Eigen::VectorXd::Zero(3 * kNumJoints);
    for (const int segment : {static_cast<int>(kSegmentPart[k]), mirror_part(kSegmentPart[k])}) {
      // Joint j starts part j + 1: the segment runs from its own joint to its child's.
      const Eigen::RowVector3d a = space->joint_mean.row(segment - 1), b = space->joint_mean.row(segment);
      const double length = (b - a).norm();
      const Eigen::RowVector3d u = (b - a) / length;
      for (int v = 0; v < nv; ++v) {
        double along = 0;  // how far the vertex moves, in units of the lengthening
        for (const auto& [p, w] : weights[static_cast<size_t>(v)]) {
          if (p == segment) along += w * std::clamp((space->mean.row(v) - a).dot(u) / length, 0.0, 1.0);
          else if (is_below(p, segment)) along += w;
        }
        column.segment<3>(3 * v) += spread[k] * along * u.transpose();
      }
      for (int j = 0; j < kNumJoints; ++j)
        if (is_below(j + 1, segment)) joint_column.segment<3>(3 * j) += spread[k] * u.transpose();
    }
    const Eigen::Index K = space->basis.cols();
    space->basis.conservativeResize(Eigen::NoChange, K + 1);
    space->basis.col(K) = column;
    space->joint_basis.conservativeResize(Eigen::NoChange, K + 1);
    space->joint_basis.col(K) = joint_column;
    space->variance_share.push_back(column.squaredNorm() / total);
    added_variance += column.squaredNorm();
    ++added;
  }
  // Shares of the space's whole variance, the added components' included.
  for (double& share : space->variance_share) share *= total / (total + added_variance);
  if (added > 0) space->population += "; " + std::to_string(added) + " limb segment length components";
}

}  // namespace posekit
