#pragma once
// The second photo method (issue 46, part 5): the body model's shape space and pose fitted to the
// front and side silhouettes at once, instead of section 3.2's rules and regressions. Every level,
// joint and girth is then read off a body of real proportions, and arms held otherwise, a slight
// turn or a tilted camera are unknowns of the fit rather than rules' assumptions.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/customization/photo_customization.h"

namespace posekit {

class BodyModel;
struct SurveyDistribution;

struct SilhouetteFitOptions {
  /// Rows of the working images: the silhouettes are reduced by a whole factor to about this many
  /// rows and first fitted at a quarter of it (coarse to fine).
  int working_rows = 1000;
  int coarse_iterations = 15, fine_iterations = 6;
  /// Outline pairs farther apart than this (m, at the body) weigh less (Cauchy scale).
  double robust_distance = 0.02;
  /// Shape prior: one standard deviation of a component costs as much as every outline pair
  /// sitting this much (m) further off.
  double shape_prior = 0.0005;
  /// Pose prior on the joints' rotations away from the model's rest: one radian costs as much as
  /// every outline pair sitting this much (m) further off.
  double pose_prior = 0.03;
  /// Then the outline's detail the shape space cannot say: each vertex moved along its normal, the
  /// offsets smooth over the surface (`detail_smoothness`: weight of their uniform Laplacian's squared
  /// norm, summed over the vertices, in the data's units) and small (`detail_offset_prior`, m per m of
  /// offset). 0 iterations: the space's body as it is.
  int detail_iterations = 3;
  double detail_smoothness = 0.01, detail_offset_prior = 0.001;
  /// The fit is poor (the silhouettes are not of a body the model can take, or the two views
  /// disagree) when the shape and pose leave the outline farther off than this (RMS, m, either
  /// view), or when the detail needs an offset over `max_offset` (m).
  double max_shape_outline = 0.010, max_offset = 0.05;
  /// Threads: the two views' outlines and equations side by side (1: one after the other). The
  /// result is the same either way.
  int threads = 2;
  /// The fitted shape is outside the population beyond this many standard deviations of chi(K) from
  /// its mean (a warning: the silhouettes say a body the space cannot).
  double max_shape_sigma = 6;
};

struct SilhouetteFit {
  TriangleMesh mesh;             ///< the fitted body in the photos' world (template topology, m)
  Eigen::VectorXd coefficients;  ///< shape (standard deviations)
  PartPose pose;                 ///< relative to the model's rest, in the photos' world
  /// Front, side: the outline pairs' RMS distance at the body (robustly weighted), at the last iteration.
  double outline_rms_mm[2] = {0, 0};
  double shape_outline_rms_mm[2] = {0, 0};  ///< the same before the detail offsets
  double shape_mahalanobis = 0;             ///< |coefficients|
  double max_offset_mm = 0;                 ///< the largest detail offset
  /// The body's turn about the vertical from facing the front camera (degrees, positive: towards its
  /// left); 3 degrees or more is a warning.
  double yaw_degrees = 0;
  int iterations = 0;
  double seconds = 0;
  bool confident = false;
  std::vector<std::string> reasons;  ///< why the fit is poor (empty when confident)
  std::vector<std::string> warnings;
};

/// Fits the body model to the two silhouettes seen by `cameras`: Gauss-Newton on the model's
/// outline (its contour vertices' signed distance to the silhouette's edge) and the silhouette's
/// edge (its distance to the nearest contour vertex along its normal), in both views, over the shape
/// coefficients, the root's rotation and translation and the spine's, shoulders', elbows', hips' and
/// knees' rotations, with Gaussian priors on shape and pose. Starts from the mean body standing on
/// the floor the front silhouette's soles show, scaled to its stature. Deterministic.
SilhouetteFit fit_body_model_to_silhouettes(const BodyModel& model, const Silhouette& front, const Silhouette& side,
                                            const PhotoCameras& cameras, const SilhouetteFitOptions& options = {});

/// customize_from_silhouettes by the body model (`customize --method model`): the fit, checked against
/// the photos as that is (BelowConfidence under kMinPhotoAgreement, or when the fit is poor, unless
/// accept_poor: then a warning), scaled to a stated stature. The result has no representation or
/// landmarks; its features hold the levels read off the fitted body (crown, soles, stature).
/// `survey` (may be null): the result's measurements more unusual than 99.5% of the survey's adults
/// of its sex are a warning (the edge of the body model's population, where its shapes are few).
CustomizedBody customize_by_body_model(const BodyModel& model, const Silhouette& front, const Silhouette& side, const PhotoCameras& cameras,
                                       double stated_stature = 0, bool accept_poor = false, const SilhouetteFitOptions& options = {},
                                       const SurveyDistribution* survey = nullptr);

/// Debug image: the silhouette (light on dark) and the outline of `mesh` seen by `camera` (red), PNG.
void write_outline_png(const std::string& path, const Silhouette& silhouette, const PinholeCamera& camera, const TriangleMesh& mesh);

}  // namespace posekit
