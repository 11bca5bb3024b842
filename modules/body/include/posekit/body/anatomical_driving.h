#pragma once
// A 16-part pose realised on MakeHuman's 163-bone rig the way a body moves, not one bone per part:
// each joint's rotation is spread over the bones of its chain, so the parts bend and twist inside.
// The pose keeps its meaning: the last bone of every chain ends where the 16-part pose puts it.
//
// What is spread, and the anatomy it follows:
// - Shoulder girdle: about a third of every arm swing is taken by the clavicle and the scapula
//   (MakeHuman's clavicle and shoulder01), the rest by the glenohumeral joint: the 2:1 ratio of
//   the scapulohumeral rhythm (Inman, Saunders & Abbott 1944, J Bone Joint Surg 26:1-30; the
//   clavicle rises about 4 degrees per 10 degrees of elevation).
// - Spine: lower-back flexion and side bend over the lumbar bones (spine05-03), most of its twist in
//   the upper ones; upper-back rotation over the thoracic bones (spine02-01). Lumbar segments flex
//   12-20 degrees each but turn about 2 degrees; thoracic segments turn far more (White & Panjabi,
//   Clinical Biomechanics of the Spine, 2nd ed. 1990, ch. 2).
// - Neck: swing over neck01-03 and the head bone; half the axial turn at the top (the atlanto-axial
//   joint gives about half of the cervical rotation, White & Panjabi 1990).
// - Twist along the limbs: the humerus's and femur's twist over both bones of the segment; the
//   forearm's pronation along the forearm (the radius turns about the ulna), so the distal forearm
//   twists with the hand.
// - Hips turn about the femoral heads (upperleg01), as the part rig already does.
#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/skinning.h"

namespace posekit {

/// Fractions of each joint's rotation per bone of its chain (each list sums to 1; the last bone takes
/// whatever makes the chain end exactly at the pose). "Swing" moves the segment's axis, "twist"
/// turns about it.
struct AnatomicalDriving {
  std::string name = "anatomical";
  double girdle_share = 1.0 / 3;                            ///< of the shoulder's swing, taken by clavicle + scapula
  double clavicle_share = 0.5;                              ///< of the girdle's part, the clavicle's (the rest: shoulder01)
  std::array<double, 3> lumbar_swing = {0.35, 0.35, 0.30};  ///< spine05, spine04, spine03
  std::array<double, 3> lumbar_twist = {0.2, 0.3, 0.5};
  std::array<double, 2> thoracic_swing = {0.5, 0.5};  ///< spine02, spine01
  std::array<double, 2> thoracic_twist = {0.5, 0.5};
  std::array<double, 4> neck_swing = {0.3, 0.3, 0.25, 0.15};  ///< neck01, neck02, neck03, head
  std::array<double, 4> neck_twist = {0.1, 0.1, 0.3, 0.5};
  double upper_arm_twist_proximal = 0.5;  ///< of the shoulder's twist, on upperarm01 (rest upperarm02)
  double thigh_twist_proximal = 0.5;      ///< of the hip's twist, on upperleg01 (rest upperleg02)
  double forearm_pronation = 0.6;         ///< of the wrist's twist, taken along the forearm (lowerarm02)
  bool dual_quaternion = true;            ///< skinning of the ground truth (else linear blend)

  /// The second, differently built rule of the cross-generator test: other fractions, LBS.
  static AnatomicalDriving alternative();
};

/// The drivings' names, for messages: "rig, anatomical or anatomical-alternative".
extern const char* const kDrivingNames;

/// Whether anatomical_driving_by_name knows `name`.
bool is_driving_name(const std::string& name);

/// The driving of a name: "rig" (none: one bone per part), "anatomical" or "anatomical-alternative".
/// Throws InvalidInput naming `context` for any other name.
std::optional<AnatomicalDriving> anatomical_driving_by_name(const std::string& name, const std::string& context);

/// Bone rotations realising `pose` on a body (its rest bone heads and tails) by `driving`.
/// Throws InvalidInput when the rig lacks a bone the chains need.
BonePose anatomical_bone_pose(const Rig& rig, const Body& body, const PartPose& pose, const AnatomicalDriving& driving);

}  // namespace posekit
