#pragma once
// A registered pose dataset on disk (Sec. 4's training data): the pose_dataset folder of a posekit
// dataset, or any folder of meshes sharing one topology, and its template's annotations.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/core/units.h"

namespace posekit {

/// A registered pose dataset: meshes sharing one topology, with optional 16-part poses.
struct PoseDataset {
  std::vector<std::string> names;
  std::vector<Eigen::MatrixXd> V;  ///< each #V x 3 (m)
  Eigen::MatrixXi F;               ///< the shared triangles
  std::vector<bool> has_pose;
  std::vector<PartPose> poses;
  std::vector<bool> test;  ///< held out (from the manifest; all false without one)
  std::string rest_name;   ///< the rest-pose example (template), if known
  /// Several people of one topology: per example, the index of its own person's rest example, from
  /// which its deformation is measured (empty: every example is the template's person).
  std::vector<int> rest_of;
};

/// The template of a pose dataset: the example named rest_name, else the first one whose 16-part
/// pose is all zero; -1 when there is none.
int find_rest_example(const PoseDataset& data);

/// Loads `dir/pose_dataset` of a posekit dataset (split from its manifest), or any folder of
/// registered meshes (OBJ/PLY/OFF, each optionally with a same-named .json 16-part pose). Meshes must
/// share the topology: the first one that does not is named in the InvalidInput thrown.
PoseDataset load_pose_dataset(const std::string& dir, Unit unit = Unit::kMetre);

/// Part labels and joint centres of a dataset's template (template/parts.json, template/joints.json).
struct TemplateAnnotations {
  Eigen::VectorXi triangle_part;  ///< #F of the pose dataset
  Eigen::MatrixXd joint_centres;  ///< #joints x 3 (m)
};
/// Reads them from a posekit dataset folder; `found` (optional) is false, and the result empty,
/// when the dataset has no such files. Malformed files throw IoError naming the file.
TemplateAnnotations load_template_annotations(const std::string& dir, bool* found = nullptr);

/// 15 joint centres from a joints.json ({"units": "m", "joints": {"lower_back": [x, y, z], ...}}).
Eigen::MatrixXd read_joint_centres(const std::string& path);

}  // namespace posekit
