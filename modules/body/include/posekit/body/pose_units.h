#pragma once
// MakeHuman pose units: named bone-space rotations for the left side of the body (arm up, elbow
// bend, knee bend, ...), mirrored for the right side, combined with weights.
#include <Eigen/Geometry>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/skinning.h"

namespace posekit {

/// unit name -> bone name -> rotation relative to the rest pose, in the bone's rest frame.
struct PoseUnits {
  std::map<std::string, std::map<std::string, Eigen::Quaterniond>> units;
};

/// Reads poseunits/body-poseunits.json (quaternions stored w first). Throws IoError naming the file.
PoseUnits read_pose_units(const std::string& path);

/// Bone rotations of a weighted combination of units, e.g. {{"UpperArmForwardLeft", 1.0},
/// {"LowerArmBend1Right1", 0.5}}. A name whose "Left" is replaced by "Right" mirrors the left unit
/// across the sagittal plane. Weights in [0, 1] scale the rotation angle. Bones the rig does not
/// have are skipped and listed in `skipped_bones` (optional). Unknown units throw InvalidInput.
BonePose bone_pose_from_pose_units(const Rig& rig, const Body& body, const PoseUnits& units,
                                   const std::vector<std::pair<std::string, double>>& weighted_units,
                                   std::vector<std::string>* skipped_bones = nullptr);

}  // namespace posekit
