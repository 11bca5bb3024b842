#pragma once
// A shape space of MakeHuman bodies (the population sampler's, body/subjects.h) in its base topology.
#include "posekit/body/makehuman_model.h"
#include "posekit/body/subjects.h"
#include "posekit/registration/shape_space.h"

namespace posekit {

/// The shape space of a MakeHuman population in its base topology (make_population_bodies, then
/// learn_shape_space), recording the base triangles: what `--shape-space N` builds.
ShapeSpace makehuman_shape_space(const MakeHumanModel& model, const PopulationOptions& population, double variance_kept = 0.99999,
                                 int max_components = 60);

}  // namespace posekit
