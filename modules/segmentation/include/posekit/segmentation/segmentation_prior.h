#pragma once
// Labels and skeletons for the representation chosen by body shape. Eq. 2a labels the
// representation's triangles once; where a part border does not follow the layers (the abdomen to
// pelvis border sits lower on heavy women than on men, relative to the waist and hip levels), one
// labelling cannot fit every body. A segmentation prior keeps several labelled bodies, each
// expressed in its own representation, and gives a new body the labels and joints of the bodies
// whose representations are most like its own, region by region.
#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

/// Regions of the representation compared separately: torso below / above its middle layer, head,
/// legs and arms.
constexpr int kShapeRegions = 7;

/// Shape of a representation per region: every 4th point of each layer, centred on the region's
/// mean and divided by its RMS radius, so that bodies compare by shape rather than size.
struct RepresentationShape {
  std::vector<Eigen::VectorXf> region;  ///< kShapeRegions descriptors
};

/// One labelled body in its own representation.
struct CalibrationBody {
  RepresentationShape shape;
  Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 1> labels;  ///< #rep triangles, 16-part labels (Eq. 2a)
  SkeletonPrior skeleton;                                 ///< its joint centres (ct-FFD parameters)
};

struct SegmentationPrior {
  std::vector<CalibrationBody> bodies;
  int neighbours = 9;  ///< bodies voting per region, weighted by inverse shape distance
};

RepresentationShape representation_shape(const LayeredRepresentation& rep);

/// A labelled body (its triangle labels and #joints x 3 joint centres) and its representation.
CalibrationBody make_calibration_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                      const Eigen::MatrixXd& joint_centres, const LayeredRepresentation& rep);

/// Representation labels for a body (input of segment_body): each region's triangles take the
/// inverse-distance-weighted vote of the prior's `neighbours` bodies nearest in that region's shape.
/// Throws InvalidInput for an empty prior or a representation of another topology.
Eigen::VectorXi representation_labels_from_prior(const SegmentationPrior& prior, const LayeredRepresentation& rep);

/// Joint centres of a body (#joints x 3, m): per joint, the inverse-distance-weighted mean of the
/// skeletons of the prior's `neighbours` bodies nearest in shape, each embedded by embed_skeleton.
/// The arms' regions count only for the arms' joints: arms held closer or straighter moved the
/// robustness set's upper-back joint by up to 4 cm when they chose the torso's neighbours.
Eigen::MatrixXd embed_skeleton(const SegmentationPrior& prior, const LayeredRepresentation& rep);

}  // namespace posekit
