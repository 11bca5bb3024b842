#pragma once
// The body model fitted to any body (issue 44, part 2): a target of any topology or a scan (any
// density, holes, cut head or hands, noise), standing, kneeling, sitting or bending, in any axis
// convention. A global search over pose hypotheses (a pose library at every heading, each up
// direction the axes allow) picks the start; then articulated fitting (fit_pose, robust weights and
// joint limits) alternates with the shape coefficients' least squares. Parts, joints and pose are
// read off the fitted model, with a confidence and its reasons.
#include <Eigen/Core>
#include <array>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/deformation/dataset_training.h"
#include "posekit/fitting/body_model.h"

namespace posekit {

/// A named whole-body pose the search starts from (the pose library).
struct LibraryPose {
  std::string name;  ///< unique: the kind and its variant ("squat (120)")
  std::string kind;  ///< the search refines one variant of a kind, its best-scoring
  PartPose pose;
};
/// Standing (A, T, arms down and touching, hands on hips, arms crossed, forward, overhead), a raised
/// knee, a lunge and a stride, kneeling on one and both knees and sitting back on the heels, a half
/// and a full squat, sitting on a chair and on the floor, bending forward; either leg in front. Each
/// is said in anatomical angles (abduction and flexion of shoulders and hips, flexion of elbows, knees
/// and spine), made joint rotations for a body of these rest joint centres (#joints x 3, Y up,
/// facing +Z).
std::vector<LibraryPose> pose_library(const Eigen::MatrixXd& rest_joints);

/// Frames of motion capture (16-part poses at any heading, e.g. retarget_bvh's) made library poses:
/// each frame's heading is taken off (its pelvis's turn about the vertical), then the frames are
/// chosen farthest first from `library` and from each other, by the largest difference of a joint's
/// rotation or the pelvis's tilt, while that is at least `min_degrees` and at most `max_poses`.
/// Each keeps its frame's name as name and kind.
std::vector<LibraryPose> distinct_motion_poses(const std::vector<LibraryPose>& frames, const std::vector<LibraryPose>& library,
                                               int max_poses = 40, double min_degrees = 30);

class PointGrid;

/// The move that stands a body (its points X, Y up) on a cloud as the search stands its starts: its
/// lowest point on the cloud's floor (the 0.5% quantile of its heights) and, across, its median point
/// over the cloud's (each axis's median). A box's centre follows the limbs: a body with one arm half
/// raised and the other forward stood 25 cm beside a body with its arms hanging.
Eigen::RowVector3d stand_on_cloud(const Eigen::MatrixXd& X, const Eigen::MatrixXd& cloud);

/// Centres a body placed on a cloud: moves its points X by the median offset, on each axis, between
/// them and the cloud's within `cap` (m), both ways (each body point to its nearest cloud point, each
/// cloud point's nearest body point to it), again while it moves over a centimetre, `rounds` times at
/// most. Returns the whole move. Unlike the bounding boxes' centres, the limbs that differ do not
/// decide it. `cloud_grid`: the cloud's; `cell`: the body grid's.
Eigen::RowVector3d centre_on_cloud(const Eigen::MatrixXd& cloud, const PointGrid& cloud_grid, double cap, double cell, int rounds,
                                   Eigen::MatrixXd* X);

/// A pose as a shape space stores it (ShapeSpace::poses: pelvis rotation, then each joint's), and back.
Eigen::RowVectorXd pose_row(const PartPose& pose);
PartPose pose_from_row(const Eigen::RowVectorXd& row);

struct BodyFitOptions {
  /// The working cloud: the target's points averaged in cubic cells of this size (m), so that a 10M
  /// point scan and a 5k-vertex mesh cost and weigh alike; cells holding under a tenth of the median
  /// cell's points (stray returns) are left out.
  double working_cell = 0.012;
  /// Up directions tried (unit vectors in the target's frame); empty: +-X, +-Y, +-Z.
  std::vector<Eigen::Vector3d> up_candidates;
  int headings = 8;  ///< headings tried about the up direction for every library pose
  /// The search scores every start on a sparse sample first, then these best again on a denser one.
  int starts_rescored = 300;
  int hypotheses_refined = 6;  ///< the best-scoring distinct starts that get a brief articulated fit
  /// When the fits from the library's starts are poor, the search again with the legs searched (both
  /// together, then each on its own) on this many of the best pairs of up direction and heading (0: not).
  int legs_searched = 8;
  /// Rounds of the shape's and pose's least squares together, each followed by a brief articulated
  /// refit with the joints' priors. (With the shape's least squares moving the body only, the two
  /// crawled in turns: 8 rounds left a 1.54 m woman's shoulders 25 mm from the rig's, 20 rounds 3 mm;
  /// together 4 rounds leave 2 mm.)
  int shape_rounds = 4;
  /// The shape prior: one standard deviation of a component costs as much as every pair sitting
  /// this much (m) further off the target.
  double shape_prior = 0.0005;
  /// Confidence: the fit is poor when less than `min_coverage` of the fitted body lies within 2 cm
  /// of the target, when a twentieth of the target lies over `max_target_p95` (m) from the fitted
  /// body, or when the shape lies outside the population (Mahalanobis distance over `max_shape_sigma`
  /// standard deviations of chi(K) from its mean).
  double min_coverage = 0.5, max_target_p95 = 0.03, max_shape_sigma = 6;
  /// ... or when less than this share of a trunk or limb part (not the head, hands or feet, which
  /// scans cut) lies within 3 cm of the target: that part was placed where the body is not.
  double min_part_coverage = 0.3;
  /// ... or when less than `min_limb_explained` of the target's points nearest an upper arm, forearm,
  /// thigh or shank lie within `limb_close_distance` (m) of the fitted surface: the limb lies along
  /// the target's but bent or turned elsewhere (an elbow 8 cm behind the real one left 68-74% of the
  /// target's arm within 25 mm; the good fits of the robustness set explain 98-100%, booth scans
  /// with the arms at the torso included).
  double min_limb_explained = 0.9, limb_close_distance = 0.025;
  /// Threads for the global search and the brief fits of its best starts (0: the hardware's); the
  /// result does not depend on it.
  int threads = 0;
  /// Called (on the calling thread) as soon as the up direction is chosen, with what will be
  /// BodyFit::to_fit_frame, so that work needing the body upright can start while the fit goes on.
  /// Called again when the fit is redone from another start (its frame may differ).
  std::function<void(const Eigen::Matrix3d& to_fit_frame)> frame_chosen;
};

struct BodyFit {
  Eigen::VectorXd coefficients;                                ///< K shape coefficients (standard deviations)
  PartPose pose;                                               ///< in the fit frame: the target turned by `to_fit_frame`
  Eigen::Matrix3d to_fit_frame = Eigen::Matrix3d::Identity();  ///< target frame -> fit frame (up: +Y)
  Eigen::Vector3d up = Eigen::Vector3d::UnitY();               ///< the target's up direction found
  std::string start;                                           ///< the library pose the fit started from
  Eigen::MatrixXd V;                                           ///< the fitted body in the target's frame (#V x 3, template topology)
  Eigen::MatrixXd joints;                                      ///< joint centres in the target's frame (#joints x 3)
  /// Joints whose part the target does not show (a scanner's cut hands, an arm hidden): the fit
  /// guessed them from the priors and the parts before them, and `warnings` says so.
  std::array<bool, kNumJoints> joint_guessed{};
  /// #T: the part of each target point (the nearest fitted vertex's); -1 for a point over 25 cm from
  /// the fitted body (an outlier, the floor).
  Eigen::VectorXi target_part;
  Eigen::VectorXd target_distance;         ///< #T: each target point's distance to the nearest fitted vertex (m; infinite beyond 25 cm)
  double coverage = 0;                     ///< of the fitted body's vertices within 2 cm of the target
  double target_mean = 0, target_p95 = 0;  ///< the working cloud to the fitted surface (m; 25 cm at most)
  double shape_mahalanobis = 0;            ///< |c|
  int working_points = 0;
  double seconds = 0;
  /// Seconds of each stage, in order: working cloud, search, brief fits, limbs, shape and pose, read-off.
  std::vector<std::pair<std::string, double>> stage_seconds;
  bool confident = false;
  std::vector<std::string> reasons;   ///< why the fit is poor (empty when confident)
  std::vector<std::string> warnings;  ///< from the articulated fit (a part unseen, a joint at its limit)
};

/// Fits the model to target points T (#T x 3, metres, any frame; a mesh's vertices, or a scan).
/// Throws InvalidInput for fewer than 100 finite points.
BodyFit fit_body_model(const BodyModel& model, const Eigen::MatrixXd& T, const BodyFitOptions& options = {});

/// The same for a mesh (V metres, F its triangles): its floating bits (a scan's straps and hair
/// clumps, under 5% of the body's area) and vertices no triangle uses are left out of the fit and
/// labelled -1; target_part and target_distance have a row per vertex of V.
BodyFit fit_body_model_to_mesh(const BodyModel& model, const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                               const BodyFitOptions& options = {});

/// Every vertex's part for a mesh the fit was made to (V its vertices): the fit's labels, and for the
/// vertices it left out (floating bits, far points) the nearest fitted vertex's part. #V.
Eigen::VectorXi parts_of_every_vertex(const BodyModel& model, const BodyFit& fit, const Eigen::MatrixXd& V);

/// Labels for train_on_dataset's rest example (deformation/dataset_training.h) from the body model
/// fitted to it: its parts (parts_of_every_vertex) and joints; an unconfident fit is a poor labelling
/// with the fit's reasons. Fitted with `options` (its threads, say). `model` must outlive the labeller.
RestLabeller body_model_labeller(const BodyModel& model, const BodyFitOptions& options = {});

}  // namespace posekit
