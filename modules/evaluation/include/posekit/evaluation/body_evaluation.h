#pragma once
// `posekit eval bodies`: body understanding on the robustness set (datasets/robustness.h). Each
// body goes through what a user's file goes through: unit and orientation detected, measured
// (features and girths), segmented into 16 parts (Eq. 2) with its skeleton embedded and checked;
// the results are compared with the rig's truth.
#include <functional>
#include <limits>
#include <map>
#include <string>
#include <vector>

namespace posekit {

class BodyModel;

/// ISO 20685-1 allowable errors of girths (m): bust/chest 15 mm, waist 12 mm, hip 12 mm.
double iso_allowable_girth_error(const std::string& girth);

struct BodyResult {
  std::string name, variation, shape, kind;  ///< kind: "mesh" or "scan"
  bool unit_right = false, orientation_right = false;
  std::string orientation;                                ///< as detected, e.g. "up +X (detected), facing +Z (detected)"
  bool measured = false;                                  ///< measure succeeded (some girths may still be not measured)
  std::string measure_error;                              ///< the named error when it did not
  bool segmented = false;                                 ///< segmentation and skeleton made and passed their checks
  std::string segment_error;                              ///< the named error or the failed checks
  std::vector<std::string> warnings;                      ///< orientation, feature, measurement and body-model fit warnings
  std::map<std::string, double> girth_error;              ///< measured minus truth (m), girths the rig defines
  std::map<std::string, std::string> girth_not_measured;  ///< girth -> the reason given
  double segmentation_agreement = std::numeric_limits<double>::quiet_NaN();  ///< of the truth-labelled area
  double border_roughness = std::numeric_limits<double>::quiet_NaN();        ///< ours (see border_roughness)
  double truth_border_roughness = std::numeric_limits<double>::quiet_NaN();  ///< the rig's labels'
  double joint_error_max = std::numeric_limits<double>::quiet_NaN();         ///< m
  double joint_error_mean = std::numeric_limits<double>::quiet_NaN();        ///< m
  std::string worst_joint;
  std::map<std::string, double> joint_error;  ///< joint name -> m
  /// Limb segment (its part's name, e.g. "left_forearm") -> its joint-to-joint length minus the rig's (m).
  std::map<std::string, double> segment_length_error;
  std::vector<std::string> guessed_joints;  ///< joints the body model's fit says it guessed (their part unseen)
  /// With a body model: the fit labelled and placed the joints (meshes and scans alike); the mean
  /// angle (radians) between each fitted joint rotation and the truth's, where the truth has a pose.
  bool by_body_model = false;
  double joint_angle_error_mean = std::numeric_limits<double>::quiet_NaN();
  std::map<std::string, double> joint_angle_error;                ///< joint name -> radians, where the truth has a pose
  std::string fit_start;                                          ///< the library pose the fit started from
  double fit_seconds = std::numeric_limits<double>::quiet_NaN();  ///< the body model fit's own time (s)
  double seconds = 0;                                             ///< the body's whole evaluation: reading, fit, measuring
  /// A result returned as good that is far from the truth (orientation, joints over 5 cm but those
  /// the fit says it guessed, agreement under 80%, a girth off by more than 5 cm): what a user would
  /// not notice. Filled by evaluate_bodies.
  std::vector<std::string> silent_nonsense;
};

struct BodyEvaluationOptions {
  std::string model_path;  ///< trained model whose segmentation prior labels the body; "" for none
  /// When set, the body model is fitted to every body (posekit segment --body-model) in place of the
  /// rule-based segmentation; labels, joints and pose are read off the fit.
  const BodyModel* body_model = nullptr;
  std::vector<std::string> only;  ///< only these variations (all when empty)
  std::function<void(int, int, const std::string&)> progress;
};

struct BodyEvaluation {
  std::vector<std::string> variations;  ///< in the set's order
  std::vector<BodyResult> bodies;
  double seconds = 0;
};

/// Fills result->silent_nonsense: what a user would take for good and is not (`unwarned`: the
/// orientation came without a warning). A joint the body model's fit says it guessed is not
/// counted: the fit said so.
void flag_silent_nonsense(bool unwarned, BodyResult* result);

/// Evaluates every body of a robustness set folder. Throws IoError for a folder that is not one.
BodyEvaluation evaluate_bodies(const std::string& dir, const BodyEvaluationOptions& options = {});

}  // namespace posekit
