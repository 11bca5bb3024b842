#pragma once
// Sanity checks on a segmentation and its skeleton (section 3.3.1 of Zhu & Mok), so that a wrong
// result (a hip on the other side, a thigh swallowed by the pelvis) is never returned silently.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace posekit {

struct SkeletonCheckOptions {
  /// Left and right limb segments (shoulder-elbow, elbow-wrist, hip-knee, knee-ankle) may differ by
  /// this fraction of their mean. Real people differ by 1-3%.
  double limb_length_tolerance = 0.15;
  /// Left and right parts (arms, legs) may differ in area by this factor.
  double part_area_ratio = 1.6;
  /// A joint may lie this many times the mean radius of its parts' border away from the border's
  /// centre (a hip inside the pelvis, above its oblique thigh border, included).
  double border_radii = 2.5;
  /// Parts the scan cut off (a hand cut at the wrist): they may have no triangles, and their joint
  /// is not checked against a border.
  std::vector<int> cut_off_parts;
};

/// What check_skeleton found: one sentence per problem, naming the joint or part and the reason.
struct SkeletonCheck {
  std::vector<std::string> problems;
  bool ok() const { return problems.empty(); }
  /// The problems joined by "; ".
  std::string summary() const;
};

/// Checks a standing body's 16-part segmentation and 15 joint centres (posekit's frame: Y up,
/// facing +Z, the subject's left +X):
/// - each left joint and part lies left of the body's midline (the torso parts' centroid), each
///   right one right of it;
/// - every part is present (but options.cut_off_parts) and one edge-connected piece; each pair of left and right limb parts
///   has similar areas (no part swallowing its neighbour);
/// - each joint lies within options.border_radii border radii of the centre of the border between
///   its two parts, and those parts touch;
/// - left and right limb segments have similar lengths.
///  V  #V x 3 vertices (m), F  #F x 3 triangles, triangle_part  #F labels in [0, 16),
///  joints  #joints x 3 joint centres (m). Throws InvalidInput on mismatched sizes.
SkeletonCheck check_skeleton(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                             const Eigen::MatrixXd& joints, const SkeletonCheckOptions& options = {});

}  // namespace posekit
