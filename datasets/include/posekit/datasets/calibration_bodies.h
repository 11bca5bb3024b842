#pragma once
// The calibration bodies of find_body_features' fitted constants (shape/feature_calibration.h): a
// population of MakeHuman bodies (make_calibration_specs, not the test subjects) with the rig's joints.
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/makehuman_model.h"
#include "posekit/shape/feature_calibration.h"

namespace posekit {

struct CalibrationBodiesOptions {
  unsigned seed = 20131122;
  int count = 120;
  int remesh_vertices = 12400;             ///< each body remeshed to about this many vertices (0: MakeHuman's own mesh)
  int threads = 0;                         ///< 0: the hardware's
  std::function<void(int, int)> progress;  ///< (bodies done, total), serialised
};

/// make_calibration_specs(seed, count) at rest, each remeshed, with what find_body_features'
/// regressions saw on it and its rig's joints. A body whose features cannot be found is left out and
/// named, with why, in `skipped` (optional).
std::vector<FeatureCalibrationSample> make_feature_calibration_samples(const MakeHumanModel& model, const CalibrationBodiesOptions& options,
                                                                       std::vector<std::string>* skipped = nullptr);

}  // namespace posekit
