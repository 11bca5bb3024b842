#pragma once
// What the posing commands read (pose, fit, batch pose): the subject, and how it is set up.
#include <string>

#include "cli.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::cli {

/// The subject of pose or fit (--subject, --unit, --up, --forward): read, turned into posekit's
/// frame, and checked to be one closed body.
TriangleMesh read_posing_subject(const ArgParser& args, const std::string& command, BodyOrientation* orientation, BodyUnit* unit);

/// With --body-model, the subject's parts and joints from the body model's fit; else computed by set-up.
SubjectSetupOptions subject_setup(const ArgParser& args, const TriangleMesh& subject);

}  // namespace posekit::cli
