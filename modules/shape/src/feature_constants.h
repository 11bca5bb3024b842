#pragma once
// Internal to posekit_shape: the constants of find_body_features fitted to a population of
// MakeHuman calibration bodies (body/subjects.h), which `posekit dev calibrate` refits
// (feature_calibration.h) and a test checks against a quick refit. Lengths in metres; (lateral,
// up, forward) offsets with lateral toward the side's own outside.

namespace posekit {
namespace shape_detail {
namespace fitted {

/// Neck joint height above the level b where the neck's girth reaches 1.25 times its narrowest
/// (placed between sections): a linear regression on (1, narrowest neck level - b, crown - b,
/// b - crotch), in metres. A constant offset above b was 7.8 mm SD and biased by sex (the women's
/// joints too high, the men's too low), since the shoulders' slope into the neck differs.
/// Least squares on 100 calibration bodies (make_calibration_specs(20131122, 100), remeshed; not
/// the test subjects): residual 4.1 mm SD, 8.8 mm at most; on the 16 subjects 4.2 mm RMS.
constexpr double kNeckJointFromBase[4] = {-0.0813, -0.1808, 0.6473, -0.1134};
/// Neck joint depth = neck base centroid + kNeckJointForward; head joint at kHeadJointFraction of
/// the way from the neck base up to the crown, kHeadJointForward from the head section's centroid
/// there: medians over 100 calibration bodies (remeshed; not the test subjects), SD 4.4 mm (neck
/// depth) and 4.6 and 4.2 mm (head height and depth).
constexpr double kNeckJointForward = -0.0079;
constexpr double kHeadJointFraction = 0.4164, kHeadJointForward = -0.0176;

/// Joint centre minus the section centroid that locates it, as (lateral, up, forward) in metres:
/// medians over 80 MakeHuman calibration bodies (make_calibration_specs(20131122, 80), not the test
/// subjects), remeshed. The elbow and knee joints lie behind the limb's centre line, the wrist in
/// front of it, the ankle behind and inside the narrowest shank section. The elbow's is from the
/// parabola's vertex on the 99 left arms found of make_calibration_specs(20131122, 100), remeshed.
constexpr double kElbowOffset[3] = {-0.0098, 0.0119, -0.0224};
constexpr double kWristOffset[3] = {0.008, -0.005, 0.013};

/// refine_wrists: the joint lies this far (m) beyond the centre of the narrowest perpendicular
/// forearm section (median over the 148 arms found of 80 calibration bodies,
/// make_calibration_specs(20131122, 80), remeshed, with 5 mm steps; the other components median
/// under 1 mm). 1 cm steps and the parabola keep the 16 subjects' wrists within 0.83 cm.
constexpr double kWristBeyondNarrowestSection = 0.005;

/// refine_elbows: where the elbow lies without a kink to tell, as the fraction shoulder-elbow /
/// (shoulder-elbow + elbow-wrist) of the joint distances (kElbowPriorWeight, in body_features.cpp,
/// is what one metre away from there costs). 0.52 is the mean of the MakeHuman rig on 10 varied shapes (0.48 to 0.555; on
/// make_calibration_specs(20131122, 120), `posekit dev calibrate`: 0.510); Winter's segment lengths
/// (upper arm 0.186, forearm 0.146 of the stature) give 0.56 for real adults, so it stays a prior
/// between the two, not refitted to MakeHuman.
constexpr double kElbowPathFraction = 0.52;

/// Shoulder joint centre from the torso section 1.5 arm radii above the armpit: a linear regression
/// on (1, lateral width of the section beyond the armpit, arm radius at the armpit, front-to-back
/// depth of that lateral part, the arm's top centroid lateral of the armpit and forward of the
/// part's mid-depth), all in metres. Gives the joint lateral of the armpit, above it, and forward of
/// the mid-depth. Least squares on the 224 arms of 112 MakeHuman calibration bodies
/// (make_calibration_specs(20131122, 120), remeshed; not the test subjects): median error 4.4 mm.
struct ShoulderRegression {
  double lateral[6], up[6], forward[6];
};
constexpr ShoulderRegression kShoulderFromSection = {{0.0124, 0.7672, 0.0876, -0.3498, -0.3895, -0.5959},
                                                     {-0.0153, 0.0250, 0.4774, 0.2500, 0.5850, -0.1005},
                                                     {-0.0141, 0.0955, 0.4973, 0.0592, -0.3034, 0.7831}};

/// Knee height = fraction estimate + kKneeTowardHollow (popliteal hollow - fraction estimate) +
/// kKneeShift (crotch - ankle): least squares on the 240 legs of 120 MakeHuman calibration bodies
/// (make_calibration_specs(20131122, 120), remeshed): residual 8.4 mm SD, 14 mm before.
constexpr double kKneeTowardHollow = 0.6459;
constexpr double kKneeShift = -0.0336;

/// Knee and ankle joints minus the points that locate them (the leg axis at the knee's level, the
/// narrowest shank section's centroid), (lateral, up, forward): medians over 80 MakeHuman calibration
/// bodies (make_calibration_specs(20131122, 80), remeshed).
constexpr double kKneeOffset[3] = {0.002, 0.0, 0.006};
constexpr double kAnkleOffset[3] = {-0.004, -0.002, -0.009};

/// Hip joint centre (the femoral head; 7-10 cm above the crotch in adults) relative to the crotch,
/// in the pelvis's frame (lateral along the line between the thighs' centres kHipProbe of the
/// stature below the crotch, forward, up): each a linear regression on (1, stature, front, back), the
/// last two the forward extent of the torso section at kHipLevel of the stature above the crotch,
/// from the crotch. Least squares on the upperleg01 heads (MakeHuman's femoral heads) of
/// make_calibration_specs(7, 200), not the test subjects; on make_calibration_specs(99, 150) the
/// error is 2.8 (up), 2.9 (lateral) and 3.3 mm (forward) RMS, against 4.8, 9.1 and 5.1 mm for a
/// constant offset (biased by sex, as the pelvis is). The thighs' own pose does not enter.
constexpr double kHipProbe = 0.06, kHipLevel = 0.046;
constexpr double kHipUp[4] = {0.0210, 0.0259, -0.1390, -0.2188};
constexpr double kHipLateral[4] = {0.0257, 0.0369, 0.2421, 0.0750};
constexpr double kHipForward[4] = {-0.0036, -0.0145, -0.1536, -0.1877};

}  // namespace fitted
}  // namespace shape_detail
}  // namespace posekit
