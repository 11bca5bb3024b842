#pragma once
// The paper's Table 1 measured here: the template registered to every subject of a dataset by
// ct-FFD (as published, and refined), rigid ICP (1 and 6 iterations) and optimal-step non-rigid
// ICP, timed, with correspondence accuracy against the dataset's ground truth.
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace posekit {

struct PoseModel;
struct ShapeSpace;
struct MakeHumanModel;
struct PopulationOptions;

struct RegistrationTableOptions {
  int runs = 5;           ///< timed runs per method and subject
  int nicp_runs = 1;      ///< timed runs of non-rigid ICP (0: leave it out)
  int subjects = 0;       ///< first N subjects (0: all)
  int nicp_subjects = 0;  ///< non-rigid ICP on the first N subjects only (0: all)
  /// Also register to each subject remeshed to ~6,900 vertices, and to a ~50,000-vertex scan-like
  /// remesh with 25 holes of 2-6 cm (RegistrationTable::other_targets).
  bool other_topologies = false;
  /// With a trained model: each correspondence's pose-transfer error (section 3.3.3) on the
  /// subjects' posed ground truth, learned method.
  std::shared_ptr<const PoseModel> model;
  /// A shape space of bodies in the template's topology: adds the row "ct-FFD + shape space"
  /// (template prepared once, then fit_shape_space).
  std::shared_ptr<const ShapeSpace> shape_space;
  /// Over 1: the ct-FFD rows (whole, template prepared, + shape space) again on this many threads
  /// (RegistrationOptions::threads). Every other row runs on one.
  int ctffd_threads = 1;
  std::function<void(int, int)> progress;
};

struct RegistrationTableRow {
  std::string method;
  std::vector<double> seconds;  ///< every timed run
  double median_s = 0, min_s = 0, max_s = 0;
  /// Point correspondence error: each subject vertex's closest point on the registered template,
  /// taken back to the template at rest, against its true point (mm; mean, p95 and max averaged
  /// over subjects).
  double point_mean_mm = 0, point_p95_mm = 0, point_max_mm = 0;
  double worst_subject_point_mean_mm = 0;
  std::vector<double> subject_point_mean_mm;  ///< per subject, dataset order
  /// Triangle match error of Eq. 2b: the distance on the template between the centroid of each
  /// subject triangle's matched template triangle and the true point of its centroid (mm).
  double mean_error_mm = 0, p95_error_mm = 0;  ///< averaged over subjects
  double worst_subject_mean_error_mm = 0;
  std::vector<double> subject_mean_error_mm;  ///< per subject, dataset order
  /// options.model: mean vertex error (mm) of the subjects posed by the learned method with this
  /// correspondence against their posed ground truth, averaged over subjects (-1: not measured).
  double pose_transfer_mm = -1;
  int subjects = 0;
};

struct RegistrationTable {
  std::string targets = "the dataset's subjects";  ///< what the template was registered to
  long template_vertices = 0, template_triangles = 0;
  long mean_subject_vertices = 0, mean_subject_triangles = 0;
  std::vector<std::string> subject_ids;
  /// Triangle match error of the true correspondence (each subject triangle matched to the template
  /// triangle holding its centroid's true point): the floor no registration goes below.
  double triangle_floor_mean_mm = 0, triangle_floor_p95_mm = 0;
  /// options.model: the pose-transfer error with the true correspondence (-1: not measured).
  double pose_transfer_true_mm = -1;
  /// Making ct-FFD's template side once (features, representation, parametrisation; CtffdSource).
  double ctffd_template_seconds = 0;
  std::vector<RegistrationTableRow> rows;
  std::vector<RegistrationTable> other_targets;  ///< options.other_topologies: the same per target kind
};

/// Errors against the dataset's correspondence.csv (subject vertex -> template surface point).
RegistrationTable measure_registration_table(const std::string& dataset_dir, const RegistrationTableOptions& options);

}  // namespace posekit
