#pragma once
// One function per `posekit` subcommand; argv excludes the program and subcommand names.
#include <memory>
#include <nlohmann/json_fwd.hpp>
#include <string>

#include "posekit/body/bvh_retarget.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/subjects.h"
#include "posekit/deformation/pose_sequence.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/registration/registration.h"
#include "posekit/registration/shape_space.h"
#include "posekit/viewers/viewer.h"

namespace posekit::cli {
class ArgParser;

int run_info(int argc, char** argv);
int run_convert(int argc, char** argv);
int run_bench(int argc, char** argv);
int bench_all(int argc, char** argv);       ///< posekit bench all
int bench_commands(int argc, char** argv);  ///< posekit bench commands
int run_body(int argc, char** argv);
int run_dataset(int argc, char** argv);
int run_measure(int argc, char** argv);
int run_register(int argc, char** argv);
int run_shape_space(int argc, char** argv);
int run_customize(int argc, char** argv);
int run_train(int argc, char** argv);
int run_pose(int argc, char** argv);
int run_retarget(int argc, char** argv);
int run_segment(int argc, char** argv);
int run_eval(int argc, char** argv);
int run_eval_fit(int argc, char** argv);
int run_dev(int argc, char** argv);
int run_fit(int argc, char** argv);
int run_eval_bodies(int argc, char** argv);
int run_compare(int argc, char** argv);
int run_view(int argc, char** argv);
int run_report(int argc, char** argv);
int run_batch(int argc, char** argv);

/// A registration's quality judged without ground truth (assess_registration), for --json and
/// summaries; its warnings too when `with_warnings`.
nlohmann::ordered_json registration_quality_json(const RegistrationQuality& quality, bool with_warnings);

/// --colours and --range of compare and view as a colour map; `default_kind` without --colours.
ColourMap colour_map_from(const ArgParser& args, ColourMapKind default_kind);
/// Heatmap colours of `values` by --colours and --range (default: heatmap_range, the 95th percentile).
RowMatrixX3u8 heatmap_from(const ArgParser& args, const Eigen::VectorXd& values, ColourMapKind default_kind);

/// load_pose_sequence (deformation/pose_sequence.h) with the CLI's options: `frames` "" or "A:B",
/// `joint_map` a JSON file ("" none), `root_motion` none, vertical or all (UsageError otherwise);
/// `parsed`: the BVH already read from `path`, or null (read here, its warnings printed).
using LoadedPoses = PoseSequence;
LoadedPoses load_poses(const std::string& path, const std::string& frames, const std::string& data_root, const Eigen::MatrixXd& rest_joints,
                       const std::string& joint_map, const std::string& root_motion, const BvhMotion* parsed = nullptr);

/// Sets a subject up for posing (segmentation, skeleton, correspondence); a body that cannot be set
/// up is an InvalidInput naming `path` and the likely cause (it does not stand in the standard pose).
/// `options` may carry the subject's parts and joints (from the body model's fit).
PoseSynthesizer set_up_subject(std::shared_ptr<const PoseModel> model, const TriangleMesh& subject, const std::string& path,
                               const SubjectSetupOptions& options = {});

/// What a shape-space population leaves out: none, men (gender over 0.5), obese (BMI 30 and over) or
/// local (the measure modifiers that give the subjects their local shape). Throws UsageError.
void set_population_leave_out(PopulationOptions& options, const std::string& what);
/// A shape space of MakeHuman bodies in the base topology (make_population_bodies, learn_shape_space),
/// with progress on stderr.
ShapeSpace make_makehuman_shape_space(const MakeHumanModel& model, PopulationOptions options, double variance_kept = 0.99999,
                                      int max_components = 60);
/// --shape-space: a count of digits is a MakeHuman population of that many bodies (0: none,
/// `leave_out` as set_population_leave_out), anything else a .pks file (posekit shape-space).
bool is_shape_space_file(const std::string& value);
std::shared_ptr<const ShapeSpace> shape_space_option(const std::string& value, const std::string& leave_out, const std::string& data_root);
/// posekit shape-space --survey: MakeHuman sliders fitted to every subject of an ANSUR II-style survey
/// (a folder of ANSUR II's two files or one CSV; "" finds ANSUR II), then the principal components of
/// those bodies, keeping the fewest that reconstruct every body within `max_rms_mm`. `subjects`: that
/// many spread through the survey (0: all). Prints the fit residuals unless `quiet`; writes them, with
/// each subject's sliders, to `residuals_path` (JSON) when not empty.
ShapeSpace survey_shape_space(const std::string& survey, const std::string& data_root, long subjects, double max_rms_mm, int max_components,
                              int threads, const std::string& residuals_path, bool quiet,
                              const std::vector<std::string>& leave_out_ids = {});
}  // namespace posekit::cli
