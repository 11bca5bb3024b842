#include "posekit/deformation/segmentation_calibration.h"

#include <mutex>
#include <optional>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/subjects.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/shape/body_features.h"

namespace posekit {

SegmentationPrior calibrate_segmentation(const MakeHumanModel& model, const CalibrationOptions& options, int* skipped) {
  if (options.bodies < 0) throw InvalidInput("calibrate_segmentation: the body count must not be negative");
  std::vector<BodySpec> specs{BodySpec{}};
  const std::vector<BodySpec> others = options.specs.empty() ? make_calibration_specs(options.seed, options.bodies) : options.specs;
  specs.insert(specs.end(), others.begin(), others.end());
  const Eigen::VectorXi template_labels = triangle_part_labels(model.body_F, vertex_part_labels(model));
  std::vector<std::optional<CalibrationBody>> bodies(specs.size());
  std::mutex progress_mutex;
  int done = 0;
  parallel_for_ranges(
      static_cast<long>(specs.size()), options.threads,
      [&](long begin, long end) {
        for (long i = begin; i < end; ++i) {
          const Body body = build_body(model, specs[static_cast<size_t>(i)]);
          try {
            const LayeredRepresentation rep =
                build_layered_representation(body.mesh.V, body.mesh.F, find_body_features(body.mesh.V, body.mesh.F));
            bodies[static_cast<size_t>(i)] =
                make_calibration_body(body.mesh.V, body.mesh.F, template_labels, joint_centres(model.rig, body), rep);
          } catch (const InvalidInput&) {
            // An extreme random body whose features fail: it is left out.
          }
          if (options.progress) {
            const std::lock_guard<std::mutex> lock(progress_mutex);
            options.progress(++done, static_cast<int>(specs.size()));
          }
        }
      },
      1);
  if (!bodies[0]) throw InvalidInput("calibrate_segmentation: the features of the default MakeHuman body were not found");
  SegmentationPrior prior;
  for (auto& b : bodies)
    if (b) prior.bodies.push_back(std::move(*b));
  if (skipped) *skipped = static_cast<int>(specs.size() - prior.bodies.size());
  return prior;
}

PriorReport add_segmentation_prior(PoseModel* model, const std::string& data_root, const CalibrationOptions& options) {
  PriorReport report;
  std::shared_ptr<const MakeHumanModel> mh;
  try {
    mh = load_makehuman_model(find_data_root(data_root));
  } catch (const Error& e) {
    if (!data_root.empty()) throw;
    report.not_made = std::string("no MakeHuman data root (") + e.what() + ")";
    return report;
  }
  if (model->template_V.rows() != mh->num_body_vertices || model->template_F != mh->body_F) {
    report.not_made = "the template is not the MakeHuman base mesh";
    return report;
  }
  const Stopwatch t0;
  model->segmentation_prior = calibrate_segmentation(*mh, options, &report.skipped);
  report.seconds = t0.seconds();
  report.bodies = static_cast<int>(model->segmentation_prior.bodies.size());
  return report;
}

}  // namespace posekit
