#pragma once
// The robustness set: MakeHuman bodies across shapes in the standing variations real registrations
// and scans come in (other rest poses, touching thighs, other axis conventions, units and
// resolutions, cut heads and hands, holes, noise, floating bits, booth scans), each with its
// ground truth from the rig. Read by `posekit eval bodies`.
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/body_spec.h"

namespace posekit {

/// One kind of body in the set, e.g. {"arms_close", "arms hanging 10-15 degrees from the torso"}.
struct RobustnessVariation {
  std::string name, description;
};
/// Every variation, in the order they are written.
const std::vector<RobustnessVariation>& robustness_variations();

struct RobustnessOptions {
  std::string data_root;  ///< MakeHuman assets
  unsigned seed = 1;
  int shapes = 10;  ///< body shapes; each is written in every variation
  /// The shapes' body specs (e.g. MakeHuman fitted to survey subjects, population/survey_fit.h); when
  /// given, `shapes` is their count. Empty: random MakeHuman sliders (make_calibration_specs).
  std::vector<BodySpec> shape_specs;
  std::string shapes_source;  ///< what shape_specs are, for the manifest
  /// Only these variations (names from robustness_variations()); all when empty.
  std::vector<std::string> only;
  bool force = false;                                          ///< replace an existing output folder
  std::function<void(int, int, const std::string&)> progress;  ///< (done, total, what)
};

struct RobustnessSummary {
  int bodies = 0, shapes = 0, variations = 0;
  double seconds = 0;
};

/// Writes the set into `out_dir` through a temporary sibling folder renamed at the end:
/// manifest.json lists every body (file, variation, shape) with its truth file, which holds the
/// file's unit and axes, the rig's 15 joint centres and girths (posekit's frame, m), and the
/// rig's part label of every triangle of the file (-1 for added floating bits). Throws IoError
/// when out_dir exists (unless force), InvalidInput for an unknown variation name.
RobustnessSummary make_robustness_set(const std::string& out_dir, const RobustnessOptions& options);

}  // namespace posekit
