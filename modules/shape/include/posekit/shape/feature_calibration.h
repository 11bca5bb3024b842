#pragma once
// The constants of find_body_features fitted to a population (the neck, shoulder, knee and hip
// joints' regressions, the joints' offsets from the points that locate them, the head's and
// wrist's placements, the elbow's path fraction), refitted from bodies whose joints are known:
// what `posekit dev calibrate` prints and a test checks the shipped values against.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/shape/body_features.h"

namespace posekit {

/// One calibration body: what find_body_features' regressions saw on it, and its true joint centres
/// (#joints x 3 in posekit's joint order, body/parts.h: a rig's, for MakeHuman bodies).
struct FeatureCalibrationSample {
  FeatureRegressors regressors;
  Eigen::MatrixXd joints;
  Eigen::Vector3d head = Eigen::Vector3d::Zero();  ///< the head joint (MakeHuman's head bone), above the neck joint
  /// The heights of the first and last torso layers of its layered representation (crotch and neck
  /// base: what typical_torso_fractions, segmentation/skeleton_embedding.h, are fractions of).
  bool torso = false;
  double torso_low = 0, torso_high = 0;
};

/// A constant as shipped and as refitted: by least squares (a regression's coefficients), as the
/// median (an offset) or the mean (a proportion). The RMS errors are those of what it places (a joint coordinate, or the joint's
/// distance from its point plus the offset) over the samples, in millimetres.
struct RefitConstant {
  std::string name;  ///< the C++ constant, e.g. "kHipUp" or "kShoulderFromSection.lateral"
  std::string what;  ///< what it predicts
  std::vector<double> shipped, refit;
  double shipped_rms_mm = 0, refit_rms_mm = 0;
  int samples = 0;                    ///< rows of the fit (a side counts once per body)
  std::string fit = "least squares";  ///< or "median" (offsets), "mean" (a proportion of the rig)
};

/// Refits every constant from the samples (each one from the samples that recorded its part).
/// Throws InvalidInput when a constant has fewer samples than coefficients.
std::vector<RefitConstant> refit_feature_constants(const std::vector<FeatureCalibrationSample>& samples);

/// The refitted values as the C++ lines of modules/shape/src/feature_constants.h (4 decimals).
std::string refit_constants_as_cpp(const std::vector<RefitConstant>& constants);

}  // namespace posekit
