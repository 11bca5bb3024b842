#pragma once
// Builds the segmentation prior (posekit/segmentation/segmentation_prior.h) from MakeHuman bodies:
// their part labels and joints come from the rig, so every body is labelled without hand work.
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/body_spec.h"

#include "posekit/segmentation/segmentation_prior.h"

namespace posekit {

struct MakeHumanModel;
struct PoseModel;

struct CalibrationOptions {
  int bodies = 128;  ///< random bodies besides the default one (make_calibration_specs)
  /// The bodies besides the default one when not empty (e.g. MakeHuman fitted to survey subjects,
  /// population/survey_fit.h); `bodies` and `seed` are then not used.
  std::vector<BodySpec> specs;
  unsigned seed = 20131122;                ///< not the dataset's subject seed, so no test subject is a calibration body
  int threads = 0;                         ///< 0: all cores
  std::function<void(int, int)> progress;  ///< (bodies done, total), from any thread, serialised
};

/// The default MakeHuman body and `options.bodies` random ones, each with its rig labels and joints
/// in its own representation. Bodies whose features cannot be found are left out and counted in
/// `skipped`.
SegmentationPrior calibrate_segmentation(const MakeHumanModel& model, const CalibrationOptions& options = {}, int* skipped = nullptr);

struct PriorReport {
  int bodies = 0, skipped = 0;
  double seconds = 0;
  std::string not_made;  ///< why the model keeps the template alone; empty when the prior was made
};

/// Gives a trained model its segmentation prior when its template is the MakeHuman base mesh, from
/// the data root `data_root` (empty: POSEKIT_DATA or the default). When no data root is found and
/// none was named, or the template is another mesh, the model is left as it is and the report says
/// why; a named data root that cannot be read throws IoError.
PriorReport add_segmentation_prior(PoseModel* model, const std::string& data_root = "", const CalibrationOptions& options = {});

}  // namespace posekit
