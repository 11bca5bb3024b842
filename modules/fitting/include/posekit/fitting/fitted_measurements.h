#pragma once
// Measuring any body through the fitted body model (issue 44, part 3): the landmark levels come
// from the fitted body (the rules of find_body_features on its rest pose, where they were made for),
// carried to the target's pose by the fitted model; the girths are taken on the target's own surface
// in those planes, from the target's points the fit labelled as the girth's parts (an arm resting on
// the chest is not in the bust).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/fitting/body_fit.h"
#include "posekit/shape/measurements.h"

namespace posekit {

struct Landmark {
  std::string name;  ///< neck_base, left_armpit, right_armpit, bust, underbust, waist, hip, crotch, knee, ankle
  Eigen::Vector3d point = Eigen::Vector3d::Zero();  ///< in the target's frame
};

struct FittedMeasurements {
  /// Girths of the target standing: each taken on the target's surface, less the change the pose
  /// makes to the fitted body's section there (posed, against in the girths' posture: a standing
  /// body's own stance with the arms at rest; the rest pose for a body kneeling, sitting, bending or
  /// with a knee raised). Points and normals in the
  /// target's frame; stature of the fitted body standing; `features` the fitted body's at rest
  /// (posekit's frame).
  BodyMeasurements target;
  /// Per girth of `target`: as the target's surface has it in its pose (m; NaN when not measured).
  std::vector<double> as_posed;
  /// The fitted body at rest, measured by the rules (measure_body): what the model says.
  BodyMeasurements fitted;
  std::vector<Landmark> landmarks;
};

/// Measures the target the fit was made to: T its points (#T x 3, the fit's target frame: a mesh's
/// vertices or a scan), F its triangles (empty for a scan). fit.target_part must have a row per
/// point of T. Throws InvalidInput when the fitted body cannot be measured at rest.
FittedMeasurements measure_by_body_fit(const BodyModel& model, const BodyFit& fit, const Eigen::MatrixXd& T, const Eigen::MatrixXi& F);

}  // namespace posekit
