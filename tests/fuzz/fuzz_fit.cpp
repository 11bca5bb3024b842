// libFuzzer target: fitting the body model's pose to a target (posekit fit): the target a small body
// cloud as a PLY or XYZ (the first byte chooses), fitted with a trained model ($POSEKIT_FUZZ_MODEL)
// to a small subject ($POSEKIT_FUZZ_SUBJECT, a body of about 600 vertices; the model's 12k-vertex
// template otherwise), with few samples and iterations, so that a run takes a fraction of a second.
// scripts/fuzz.sh trains the model on the small dataset and takes the subject from the seeds; seeds:
// clouds of small MakeHuman bodies (Measurements.WritesFuzzSeeds...).
#include <cstdlib>
#include <memory>

#include "fuzz_input.h"
#include "posekit/core/units.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"

namespace {

const posekit::PoseSynthesizer& synthesizer() {
  static const std::unique_ptr<posekit::PoseSynthesizer> synth = [] {
    const char* path = std::getenv("POSEKIT_FUZZ_MODEL");
    if (!path || !*path) {
      std::fprintf(stderr, "fuzz_fit: set POSEKIT_FUZZ_MODEL to a trained .pkm (scripts/fuzz.sh does)\n");
      std::abort();
    }
    auto model = std::make_shared<const posekit::PoseModel>(posekit::read_pose_model(path));
    posekit::TriangleMesh subject;
    const char* subject_path = std::getenv("POSEKIT_FUZZ_SUBJECT");
    if (subject_path && *subject_path) {
      subject = posekit::read_mesh(subject_path);
    } else {
      subject.V = model->template_V;
      subject.F = model->template_F;
    }
    return std::make_unique<posekit::PoseSynthesizer>(model, subject);
  }();
  return *synth;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  (void)synthesizer();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const std::string path = posekit::fuzz::write_input(data + 1, size - 1, data[0] % 2 ? ".xyz" : ".ply");
  posekit::fuzz::expect_clean([&] {
    posekit::PointCloud target = posekit::read_point_cloud(path);
    posekit::Unit unit;
    if (posekit::guess_body_unit(posekit::robust_largest_extent(target.P), &unit)) target.P *= posekit::metres_per_unit(unit);
    posekit::PoseFitOptions o;
    o.iterations = 3;
    o.search_iterations = 1;
    o.model_samples = 200;
    o.refinement_model_samples = 200;
    o.method = data[0] & 2 ? posekit::PoseMethod::kLbs : posekit::PoseMethod::kLearned;
    (void)posekit::fit_pose(synthesizer(), target.P, o);
  });
  return 0;
}
