#pragma once
// The whole segmentation of one standing body, as `posekit segment`, `eval bodies` and pose
// synthesis run it: Eq. 2 labels from a segmentation prior (or the representation's own), the
// skeleton embedded and reconciled with the body's features, parts a scan cut off dropped, and
// the result checked.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/segmentation_prior.h"
#include "posekit/segmentation/skeleton_checks.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

struct BodySegmentation {
  Segmentation segmentation;
  Eigen::MatrixXd joints;          ///< #joints x 3 joint centres (m, posekit's frame)
  SkeletonCheck check;             ///< empty problems: the result passed every sanity check
  std::vector<std::string> notes;  ///< joints the body's own features replaced, parts cut off
};

/// Segments the body surface (V, F) whose representation is `rep` and whose features (found on the
/// file's mesh, so that they see its openings) are `features`.
/// - prior: labels (Eq. 2a) and joints come from it; nullptr: the representation's own layer
///   labels, joints from the part borders and the features.
/// - a hand the features report cut off (hand_cut) gets no triangles: the representation's hand
///   layers on that side are squeezed onto the stump, so they are labelled forearm; the wrist is
///   the cut's centre and the check allows the missing hand.
BodySegmentation segment_standing_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const LayeredRepresentation& rep,
                                       const BodyFeatures& features, const SegmentationPrior* prior);

}  // namespace posekit
