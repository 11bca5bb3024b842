#pragma once
// Skeleton embedding (section 3.3.1 of Zhu & Mok): the 15 joint centres of the 16-part tree of a
// body, from its layered representation and its segmentation.
#include <Eigen/Core>

#include "posekit/registration/ctffd.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/feature_calibration.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

/// A reference skeleton: the joint centres of a template body expressed in its representation.
struct SkeletonPrior {
  CtffdParametrization joints;  ///< the 15 joint centres, parametrised as ct-FFD points
  /// Heights of the lower-back, upper-back and neck joints as fractions of the torso chain, from
  /// the crotch (0) to the neck base (1): on MakeHuman bodies of either sex and any weight these
  /// vary by under 2.5 cm, far less than their position between the waist and hip levels does.
  Eigen::Vector3d torso_fraction = Eigen::Vector3d::Zero();
};

/// Parametrises a template's joint centres (#joints x 3) in its representation.
SkeletonPrior make_skeleton_prior(const Eigen::MatrixXd& template_joints, const LayeredRepresentation& template_rep);

/// The joint centres of another body (#joints x 3, m): the prior's points re-evaluated in the body's
/// representation, so they follow its layers (ct-FFD); the three torso joints then take their
/// heights from the torso fractions.
Eigen::MatrixXd embed_skeleton(const SkeletonPrior& prior, const LayeredRepresentation& rep);

/// Joint centres without a prior, from the body's own features (modules/shape) where they are joints
/// (shoulders, elbows, wrists, hips, knees, ankles), the torso joints at typical fractions of the
/// crotch to neck-base span on the torso axis; a joint of an arm not found at its parts' border.
Eigen::MatrixXd joint_centres_from_features(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                            const LayeredRepresentation& rep, const BodyFeatures& features);

/// A prior's skeleton (embed_skeleton) follows the limbs as its labelled bodies held them (the
/// A-pose). Where this body's limb is held otherwise (feet together, elbows bent or straight) or
/// cut (a hand), a limb joint of the prior's lies away from the joint the body's own sections give
/// (BodyFeatures: elbows, wrists, knees, ankles). Each such joint more than `tolerance` (m) from the
/// feature's is replaced by it. A cut hand's elbow and wrist are always the body's (the arm's
/// chain is shorter, and the prior's joints slide up it). The hips are always the body's (BodyFeatures::hip, the femoral heads
/// regressed on the pelvis's section: on the robustness set 5.3 mm median and 13 mm at most, where
/// the prior's layers gave 9.9 and 44 mm, the worst with the legs together or the arms bent).
/// `replaced` (optional) receives one line per joint over `tolerance` from the prior's.
Eigen::MatrixXd reconcile_limb_joints(const Eigen::MatrixXd& joints, const BodyFeatures& features, double tolerance = 0.03,
                                      std::vector<std::string>* replaced = nullptr);

/// Typical torso joint heights as fractions of the crotch (0) to neck-base (1) span: lower back,
/// upper back, neck: the MakeHuman rig's medians over make_calibration_specs(20131122, 120), remeshed
/// (`posekit dev calibrate`; the first values, from 17 bodies, 0.262, 0.495 and 1.004, placed the
/// joints 12.4 mm RMS off against 10.6).
Eigen::Vector3d typical_torso_fractions();
/// typical_torso_fractions refitted (medians) from calibration bodies' rig joints and torso spans
/// (shape/feature_calibration.h), with the RMS error of the joint heights they place.
RefitConstant refit_typical_torso_fractions(const std::vector<FeatureCalibrationSample>& samples);

/// Joint centres without a prior, from the segmentation alone: the centroid of the boundary edges
/// between each part and its parent (#joints x 3). A joint whose parts share no edge throws
/// InvalidInput naming it.
Eigen::MatrixXd joint_centres_from_segmentation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part);

}  // namespace posekit
