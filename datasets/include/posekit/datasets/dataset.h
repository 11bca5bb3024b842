#pragma once
// The evaluation dataset on disk: generated from the MakeHuman model (`make_dataset`), or a user's
// own data in the same layout (`load_pose_dataset`, `load_subject_mesh`, ...).
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/core/point_cloud.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct DatasetOptions {
  std::string data_root;  ///< MakeHuman assets
  unsigned seed = 1;
  bool small = false;  ///< a third of the poses, 2 subjects
  int subjects = 16;   ///< ignored when small
  int subject_vertices = 12400;
  double scan_noise_sigma = 0.0015;  ///< m
  double scan_outlier_fraction = 0.001;
  /// How a 16-part pose drives the rig for the ground truth: "rig" (each joint on the bone that
  /// starts its part, dual quaternion skinning), "anatomical" or "anatomical-alternative"
  /// (anatomical_driving.h: girdle, spine, neck and limb twist spread over their bones; the second
  /// with other fractions and linear blend skinning, for a cross-generator test). The anatomical
  /// ones also pose every subject in 8 held-out poses (walk, reach, squat, sit, torso, single joints).
  std::string driving = "rig";
  bool force = false;  ///< replace an existing output folder
  /// Progress callback: (done, total, what).
  std::function<void(int, int, const std::string&)> progress;
};

/// Summary of what make_dataset wrote.
struct DatasetSummary {
  int poses = 0, test_poses = 0, subjects = 0, scans = 0, photos = 0;
  long files = 0;
  double seconds = 0;
};

/// Writes the whole dataset into `out_dir` (see README "Dataset layout") through a temporary
/// sibling folder renamed at the end: a failure leaves nothing behind. Throws IoError when out_dir
/// exists (unless options.force) or is not writable.
DatasetSummary make_dataset(const std::string& out_dir, const DatasetOptions& options);

/// Several people of one topology in the pose set, for `posekit eval pose --people` (each person
/// posed by a model trained on the others, section 3.3.3): one folder per person of MakeHuman's skin
/// mesh (13,380 vertices, m) at rest and in every pose of the pose set, with the 16-part pose of
/// each from that person's rest. The bodies are the evaluation subjects' of `seed`. The last
/// `natural_rest` people stand in natural_rest_pose (arms closer, elbows bent) instead of the
/// template's A-pose, and their poses are taken from that rest (pose_from_rest).
struct PeopleSetOptions {
  std::string data_root;
  unsigned seed = 1;
  int people = 5;
  int natural_rest = 1;
  bool small = false;           ///< a third of the poses
  std::string driving = "rig";  ///< as DatasetOptions::driving
  bool force = false;           ///< replace an existing output folder
  std::function<void(int, int, const std::string&)> progress;
};
/// Through a temporary folder renamed at the end (write_folder_atomically). Returns poses = meshes
/// per person (rest included) and subjects = people.
DatasetSummary make_people_set(const std::string& out_dir, const PeopleSetOptions& options);

/// A subject's mesh: any closed body mesh (PLY/OBJ/OFF/STL).
TriangleMesh load_subject_mesh(const std::string& path, Unit unit = Unit::kMetre);

/// Ground-truth correspondence of a subject (subjects/<id>/correspondence.csv): each subject vertex
/// as a template triangle + barycentric coordinates. Throws IoError naming the file and line.
struct SurfacePoints;
SurfacePoints load_correspondence(const std::string& path);

/// A scan: any point cloud (PCD/PLY/XYZ); posekit's simulated scans are in millimetres.
PointCloud load_scan(const std::string& path, Unit unit = Unit::kMillimetre);

}  // namespace posekit
