#include "posekit/datasets/calibration_bodies.h"

#include <mutex>

#include "posekit/body/parts.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"
#include "posekit/datasets/remesh.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

std::vector<FeatureCalibrationSample> make_feature_calibration_samples(const MakeHumanModel& model, const CalibrationBodiesOptions& o,
                                                                       std::vector<std::string>* skipped) {
  if (o.count < 1) throw InvalidInput("calibration bodies: the count must be at least 1");
  const std::vector<BodySpec> specs = make_calibration_specs(o.seed, o.count);
  std::vector<FeatureCalibrationSample> samples(specs.size());
  std::vector<std::string> why(specs.size());
  std::mutex progress_mutex;
  int done = 0;
  parallel_for_each(static_cast<long>(specs.size()), o.threads, [&](long i) {
    const auto k = static_cast<size_t>(i);
    const Body body = build_body(model, specs[k]);
    FeatureCalibrationSample& s = samples[k];
    s.joints = joint_centres(model.rig, body);
    s.head = body.bone_heads.row(model.rig.find_bone("head")).transpose();
    try {
      const TriangleMesh mesh = o.remesh_vertices > 0 ? remesh_body(body.mesh, o.remesh_vertices) : body.mesh;
      const BodyFeatures features = find_body_features(mesh.V, mesh.F, nullptr, 1, &s.regressors);
      const LayeredRepresentation rep = build_layered_representation(mesh.V, mesh.F, features);
      for (const RepresentationLayer& layer : rep.layers) {
        if (layer.chain != 0) continue;  // the torso
        if (!s.torso) s.torso_low = layer.centre.y();
        s.torso_high = layer.centre.y(), s.torso = true;
      }
    } catch (const InvalidInput& e) {
      why[k] = "body " + std::to_string(k) + " of make_calibration_specs(" + std::to_string(o.seed) + ", " + std::to_string(o.count) +
               "): " + e.what();
    }
    if (o.progress) {
      const std::lock_guard<std::mutex> lock(progress_mutex);
      o.progress(++done, static_cast<int>(specs.size()));
    }
  });
  std::vector<FeatureCalibrationSample> kept;
  for (size_t k = 0; k < specs.size(); ++k) {
    if (why[k].empty()) kept.push_back(std::move(samples[k]));
    else if (skipped) skipped->push_back(why[k]);
  }
  return kept;
}

}  // namespace posekit
