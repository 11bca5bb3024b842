#pragma once
// Anatomical features of a standing body (A-pose, Y up, facing +Z, metres) found from its geometry
// alone: horizontal sections, their loops, girths and centroids. Works for any topology.
#include <Eigen/Core>
#include <array>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "posekit/core/mesh_slice.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// Horizontal sections of a mesh every `step` metres from just above the soles to just below the
/// top of the head: the raw material of features, measurements and the layered representation.
struct SectionStack {
  double floor_y = 0, top_y = 0, step = 0;
  std::vector<double> y;                        ///< level heights (m)
  std::vector<std::vector<SectionLoop>> loops;  ///< loops at each level
};
constexpr double kSectionStep = 0.005;  ///< m between the levels features are found on
/// On `threads` threads (0: the hardware's) the same sections as on one.
SectionStack horizontal_sections(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double step = kSectionStep, int threads = 1);

enum Side : int { kLeft = 0, kRight = 1 };  ///< the subject's left is +X

/// A point not found (the joints of an arm that could not be followed): NaN, written as null.
inline Eigen::Vector3d unset_point() { return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN()); }

struct BodyFeatures {
  double floor_y = 0, top_y = 0;  ///< soles, top of the surface (m)
  /// A cut top (no crown: an anonymised scan's head, or no head at all). The stature and the crown
  /// are then estimated from the level where the arms separate (kStatureFromArmsSeparate).
  bool head_cut = false;
  double crown_y = 0, stature = 0;  ///< top of the head (top_y unless head_cut), crown minus soles (m)
  double axis_x = 0;                ///< x of the body's sagittal plane
  double crotch_y = 0, hip_y = 0, waist_y = 0, underbust_y = 0, bust_y = 0, neck_y = 0;  ///< levels (m)
  Eigen::Vector3d crotch = Eigen::Vector3d::Zero();              ///< on the axis, at the lowest torso section's centre
  double crotch_axis_z = 0;                                      ///< z of the axis point the crotch's sections enclose
  Eigen::Vector3d neck_base = Eigen::Vector3d::Zero();           ///< centre of the neck's lowest section
  Eigen::Vector3d neck_top = Eigen::Vector3d::Zero();            ///< centre of the neck's narrowest section
  Eigen::Vector3d neck_joint = Eigen::Vector3d::Zero();          ///< neck joint centre (regressed on the neck's levels)
  Eigen::Vector3d head_joint = Eigen::Vector3d::Zero();          ///< head joint centre, inside the lower head
  Eigen::Vector3d armpit[2] = {unset_point(), unset_point()};    ///< armpit surface points
  Eigen::Vector3d shoulder[2] = {unset_point(), unset_point()};  ///< shoulder joint centres
  double arms_separate_y = 0;                                    ///< highest level at which both arms stand 5 mm clear
                                                                 ///< of the torso (between 1 mm sections on meshes,
                                                                 ///< 5 mm on clouds)
  Eigen::Vector3d elbow[2] = {unset_point(), unset_point()};     ///< joint centres (inside the limb)
  Eigen::Vector3d wrist[2] = {unset_point(), unset_point()};
  Eigen::Vector3d knee[2] = {unset_point(), unset_point()};
  Eigen::Vector3d ankle[2] = {unset_point(), unset_point()};
  Eigen::Vector3d hip[2] = {unset_point(), unset_point()};       ///< hip joint centres: the femoral heads, above the crotch
  Eigen::Vector3d hand_tip[2] = {unset_point(), unset_point()};  ///< farthest point of each hand from the shoulder
  std::vector<Eigen::Vector3d> arm_axis[2];                      ///< centroids of the arm's horizontal sections, armpit down
  bool arm_touches_torso[2] = {false, false};                    ///< nowhere clear of the torso just below the armpit
  bool hand_cut[2] = {false, false};                             ///< the arm ends in an opening: wrist = the cut's centre
  bool arm_found[2] = {true, true};                              ///< false: that arm could not be followed (shoulder,
                                                                 ///< elbow, wrist, hand tip are then not valid)
  bool torso_levels_doubtful = false;                            ///< the torso is fuller below the bust band (a belly, or a
                                                                 ///< scan's arms merged with it): bust, underbust and waist
                                                                 ///< levels are not trusted
  std::vector<std::string> warnings;                             ///< features found with doubt
};

/// The surface features are found on: the mesh without floating bits (find_floating_bits: pieces
/// under 5% of the body's area, e.g. a scan's strap or hair clump) and vertices no face uses, with
/// every hole up to kMaxFilledHole round (a scan's gaps, cut wrists, a cut head, open soles) closed
/// by a fan from its centre, so that sections across it are closed. A tape bridges such a gap too.
/// `note` (optional) receives what was left out and filled, or stays empty; `vertex_map` and
/// `face_map` (optional) the index in V and F of each vertex and face of the result (-1 for the
/// fill's); `input_boundary` (optional) the boundary loops of (V, F) itself, in its vertex indices
/// (found on the way when nothing was left out; on a second thread beside the rest unless `threads`
/// is 1, 0 meaning the hardware's). The same result on any count.
constexpr double kMaxFilledHole = 0.8;  ///< m of boundary length
TriangleMesh body_surface(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, std::string* note = nullptr,
                          std::vector<int>* vertex_map = nullptr, std::vector<int>* face_map = nullptr,
                          std::vector<std::vector<int>>* input_boundary = nullptr, int threads = 1);

/// What the fitted regressions of find_body_features saw on one body (side kLeft, kRight): each
/// regression's inputs and the point each offset is added to, to refit those constants against a
/// rig's joints (feature_calibration.h, `posekit dev calibrate`). What was not found is not recorded.
struct FeatureRegressors {
  bool neck = false;
  std::array<double, 4> neck_inputs{};  ///< (1, narrowest neck level - b, crown - b, b - crotch)
  double neck_widening_y = 0;           ///< b: where the neck's girth reaches 1.25 times its narrowest
  Eigen::Vector3d neck_base = Eigen::Vector3d::Zero();
  bool head = false;
  double crown_y = 0;
  Eigen::Vector3d head_centre = Eigen::Vector3d::Zero();  ///< the head section's centroid at the head joint's level
  bool arm[2] = {false, false};
  /// The elbow's parabola vertex on the arm's axis and the wrist's point beyond the narrowest
  /// horizontal section, before their offsets.
  Eigen::Vector3d elbow_point[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d wrist_point[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  bool forearm[2] = {false, false};
  /// refine_wrists: the narrowest perpendicular forearm section's centre (between sections) and the
  /// forearm's direction there.
  Eigen::Vector3d narrowest_forearm[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d forearm_direction[2] = {Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitX()};
  bool shoulder[2] = {false, false};
  std::array<double, 6> shoulder_inputs[2] = {};  ///< the section above the armpit (kShoulderFromSection's inputs)
  /// (armpit x, armpit y, the section's mid-depth z): the regression's lateral, up and forward start here.
  Eigen::Vector3d shoulder_origin[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  bool leg[2] = {false, false};
  double knee_fraction_y[2] = {0, 0}, knee_hollow_y[2] = {0, 0}, leg_length[2] = {0, 0};
  Eigen::Vector3d knee_point[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};   ///< before its offset
  Eigen::Vector3d ankle_point[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};  ///< before its offset
  bool hips = false;
  std::array<double, 4> hip_inputs{};  ///< (1, stature, front, back)
  Eigen::Vector3d crotch = Eigen::Vector3d::Zero(), hip_lateral = Eigen::Vector3d::UnitX(), hip_forward = Eigen::Vector3d::UnitZ();
};

/// Finds the features of a standing human body mesh (its body_surface; what it left out is a warning). Throws InvalidInput naming what
/// failed for a mesh that is not a standing human (lying, upside-down, arms touching the torso, too small); an arm that cannot be followed
/// to the hand (a hole in a scan) is flagged in arm_found and warnings.
BodyFeatures find_body_features(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);
/// The same, also giving the body_surface the features were found on (build_layered_representation
/// takes it), on `threads` threads (0: the hardware's) for the sections, the torso's girths and the
/// two forearms, with the same result as on one.
/// `regressors` (optional) receives what the fitted regressions saw.
BodyFeatures find_body_features(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, TriangleMesh* surface, int threads = 1,
                                FeatureRegressors* regressors = nullptr);

/// Horizontal sections at the given heights (one loop list per height), for finer levels than a stack's.
using HorizontalSectionsAt = std::function<std::vector<std::vector<SectionLoop>>(const std::vector<double>& heights)>;

/// The same from precomputed sections (`horizontal_sections`), without refine_wrists. With
/// `sections_at`, the level where the arms separate is refined between the stack's sections.
/// `top_is_cut`: the caller knows the top is an opening (a mesh's boundary there), which the
/// sections alone tell only when the cut is clean. `threads` (0: the hardware's) share the torso's
/// girths, with the same result as one.
BodyFeatures find_body_features(const SectionStack& stack, const HorizontalSectionsAt& sections_at = {}, bool top_is_cut = false,
                                int threads = 1, FeatureRegressors* regressors = nullptr);

/// A cross-section of the body through `point` with plane normal `normal` (the loop nearest the point).
using SectionAt = std::function<SectionLoop(const Eigen::Vector3d& point, const Eigen::Vector3d& normal)>;

/// Re-finds each found wrist with sections perpendicular to the forearm, followed from the elbow
/// by their centres: the narrowest before the palm (the first section 15% fuller than the narrowest
/// so far). Horizontal sections cannot do it when the forearm points forward. A wrist whose forearm
/// cannot be followed keeps its estimate from horizontal sections, with a warning. Then re-places
/// the elbows between the shoulders and the wrists found (refine_elbows). With `threads` other
/// than 1 the two forearms are followed at once (`section` is then called from two threads), with
/// the same result. `regressors` (optional) receives the narrowest sections.
void refine_wrists(const SectionAt& section, BodyFeatures* features, int threads = 1, FeatureRegressors* regressors = nullptr);

}  // namespace posekit
