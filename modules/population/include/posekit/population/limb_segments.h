#pragma once
// How a limb divides into its segments, which the 12 fitted measurements leave open: the survey's
// spread of each segment's length among people of the same measurements, and shape-space
// components that lengthen one segment by that spread.
#include <array>
#include <vector>

#include "posekit/body/makehuman_model.h"
#include "posekit/population/ansur.h"
#include "posekit/registration/shape_space.h"

namespace posekit {

/// Each limb segment's spread among people of the same 12 measurements and sex: the residual
/// standard deviation (m) of its least-squares regression on them and on sex, over the subjects
/// with the segment measured. NaN for a segment measured on fewer than 10 subjects per regressor.
std::array<double, kLimbSegmentCount> limb_segment_spread(const std::vector<SurveySubject>& subjects);

/// Appends to `space` (the template's topology, with joints) one component per segment of finite
/// spread: both sides' segment lengthened by its spread (c = 1 is one standard deviation). The limb
/// beyond the segment moves along the segment's bone of the mean body, the segment's own skin
/// stretches along it, each vertex by the rig's part weights; the joints beyond move with it.
/// Throws InvalidInput for a space of another topology or without joints.
void add_limb_segment_components(const MakeHumanModel& model, const std::array<double, kLimbSegmentCount>& spread, ShapeSpace* space);

}  // namespace posekit
