#pragma once
// Biovision hierarchy (BVH) motion files: skeleton, offsets, channels in any order, all frames.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/core/units.h"

namespace posekit {

enum class BvhChannel { kXposition, kYposition, kZposition, kXrotation, kYrotation, kZrotation };

struct BvhJoint {
  std::string name;
  int parent = -1;                                   ///< index into BvhMotion::joints, -1 for a root
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();  ///< from the parent's origin (m)
  std::vector<BvhChannel> channels;                  ///< in file order
  int first_channel = 0;                             ///< column of channels[0] in frames
  bool has_end_site = false;
  Eigen::Vector3d end_offset = Eigen::Vector3d::Zero();
};

struct BvhMotion {
  std::vector<BvhJoint> joints;  ///< depth-first file order; parents precede children
  double frame_time = 0.0;       ///< seconds
  Eigen::MatrixXd frames;        ///< #frames x #channels; positions in metres, rotations in degrees

  int num_frames() const { return static_cast<int>(frames.rows()); }
  /// Index of the joint with this name, or -1.
  int find_joint(const std::string& name) const;
  /// Local rotation of `joint` at `frame`: the product of its rotation channels in file order
  /// (R = R_c1 * R_c2 * R_c3, the BVH convention). Identity for a joint without rotation channels.
  Eigen::Matrix3d local_rotation(int frame, int joint) const;
  /// Local translation: the OFFSET plus the position channels (added as displacements).
  Eigen::Vector3d local_translation(int frame, int joint) const;
  /// World positions of all joint origins at `frame` by forward kinematics, #joints x 3 (m).
  Eigen::MatrixXd joint_positions(int frame) const;
};

/// Reads a BVH file; offsets and position channels are converted from `unit` to metres. Each frame
/// is one line of exactly one value per channel. Frame lines beyond the header's `Frames:` count are
/// ignored and named in `warnings` (nullptr: not reported); fewer are an error.
/// Throws IoError naming the file, the line, and what was expected.
BvhMotion read_bvh(const std::string& path, Unit unit = Unit::kMetre, std::vector<std::string>* warnings = nullptr);

/// Writes a BVH file atomically (offsets and positions in `unit`).
void write_bvh(const std::string& path, const BvhMotion& motion, Unit unit = Unit::kMetre);

}  // namespace posekit
