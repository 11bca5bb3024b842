#pragma once
// Internal to posekit_customization: what its sources share beyond the public headers.
#include <Eigen/Core>
#include <vector>

#include "posekit/customization/photo_customization.h"
#include "posekit/customization/photo_evaluation.h"
#include "posekit/customization/silhouette.h"

namespace posekit {

/// The entries of PhotoLandmarks::descriptor read off one arm (kLeft or kRight): its armpit level
/// and its profile.
std::vector<int> descriptor_arm_entries(int side);
/// A result whose photo_agreement is under kMinPhotoAgreement: BelowConfidence naming it, or with
/// accept_poor a warning.
void check_photo_agreement(CustomizedBody* body, bool accept_poor);
/// stated > 0: scales the body (mesh and representation) to that stature about its soles below
/// axis_xz (x, z), noting a camera file that disagrees by over 2 cm.
void scale_to_stated_stature(CustomizedBody* body, const PhotoCameras& cameras, double stated, const Eigen::Vector2d& axis_xz);
/// Fills an evaluation's counts and means from its subjects' results.
void summarise_photo_evaluation(PhotoEvaluation* evaluation);

}  // namespace posekit
