#pragma once
// Posing a body of any topology (section 3.3.3 of Zhu & Mok): its own segmentation and skeleton
// give T^R, the template's learned T^Q is carried over through the ct-FFD correspondence, and one
// prefactorised solve (Eq. 5-6) per pose recovers the vertices. Each triangle's T^Q turns with the
// part it was learned in (its template triangle's), so that the subject's own borders move T^R and
// the placement only. The two baselines users compare with run in the same code path.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/rigid_pose.h"

namespace posekit {

enum class PoseMethod {
  kLearned,  ///< T^R T^Q (Eq. 1), the paper's method
  kRigid,    ///< T^R only: each vertex moved rigidly with its part (exactly rigid: open seams at the joints)
  kLbs       ///< linear blend skinning, 16-part weights diffused from the segmentation
};
PoseMethod parse_pose_method(const std::string& name);  ///< "learned", "rigid" or "lbs"
const char* pose_method_name(PoseMethod method);

enum class PosePlacement { kParts, kPelvis };

struct SubjectSetupOptions {
  bool is_template = false;  ///< the subject is the model's own template: identity correspondence
  /// Where the learned method puts the parts: Eq. 6 gives the surface up to a translation, and a
  /// surface integrated from the pelvis carries every error of the learned T^Q out to the hands and
  /// feet. kParts (default): each part is then moved so that the mean of its rigid core goes where
  /// its rigid motion T^R takes it, the moves blended across the joints by the LBS weights. A
  /// vertex's core weight is its area times exp(-(s / m)^2), s the largest twist-coefficient norm of
  /// its triangles (how much the pose changes its T^Q) and m its part's median s: relative to the
  /// model itself, so that scaling the learned coefficients (noisy training meshes) changes nothing.
  /// kPelvis: the paper's setting, Eq. 6 alone, placed by the pelvis.
  PosePlacement placement = PosePlacement::kParts;
  int lbs_smoothing_iterations = 0;  ///< 0: chosen from the mean edge length (about 3 cm of blending)
  /// A segmentation (#F) and joint centres (#joints x 3) the user already has; empty: computed.
  Eigen::VectorXi triangle_part;
  Eigen::MatrixXd joint_centres;
  /// A correspondence subject triangle -> template triangle (#F); empty: ct-FFD (section 3.3.3).
  Eigen::VectorXi template_triangle;
  /// Eq. 6 as a weighted least squares (eq6_triangle_weights): the triangles whose T^Q the
  /// regression predicts well keep their shape, the mismatch between the parts goes where T^Q is
  /// least certain. false, or a model without per-triangle residuals: area weights alone (the paper).
  bool weight_by_residuals = true;
};

/// Per template triangle, the factor on its area in Eq. 6's least squares: s^2 / (r_k^2 + s^2), r_k
/// its RMS training residual of Eq. 5 (PoseModel::triangle_rms) and s^2 the mean of r_k^2 over the
/// template. An inverse-variance weight whose floor is the model's own pooled variance, so that
/// nothing is tuned and scaling every residual changes nothing. Empty when the model has no
/// residuals (a model file of an older posekit).
Eigen::VectorXd eq6_triangle_weights(const PoseModel& model);

/// What set-up found out about a subject, for reports.
struct SubjectSetupInfo {
  double seconds_representation = 0, seconds_segmentation = 0, seconds_correspondence = 0, seconds_factorisation = 0;
  int normal_failures = 0;
  Eigen::VectorXi triangle_part;      ///< #F
  Eigen::MatrixXd joint_centres;      ///< #joints x 3
  Eigen::VectorXi template_triangle;  ///< #F, the corresponding template triangle
  /// What check_skeleton found wrong with the subject's segmentation and joints (empty: none, or
  /// the template itself). Posing goes on; callers show these as warnings.
  std::vector<std::string> skeleton_problems;
};

/// A subject prepared for posing: build once (segmentation, skeleton, correspondence,
/// factorisation), then pose() is a pure function of the pose.
class PoseSynthesizer {
 public:
  /// Throws InvalidInput when the subject is not a single closed body mesh or its features cannot be
  /// found, and when `is_template` is set but the mesh is not the model's template.
  PoseSynthesizer(std::shared_ptr<const PoseModel> model, const TriangleMesh& subject, const SubjectSetupOptions& options = {});
  ~PoseSynthesizer();
  PoseSynthesizer(const PoseSynthesizer&) = delete;
  PoseSynthesizer& operator=(const PoseSynthesizer&) = delete;

  /// The posed subject, #V x 3. Throws InvalidInput on a NaN or unknown pose.
  Eigen::MatrixXd pose(const PartPose& pose, PoseMethod method = PoseMethod::kLearned) const;
  /// The same into `X` (resized when needed): posing a motion this way allocates nothing per frame.
  /// Safe to call from several threads at once.
  void pose(const PartPose& pose, PoseMethod method, Eigen::MatrixXd* X) const;

  /// The learned method with other joint offsets than the model's (#joints x 27, or empty for none):
  /// how training decides which offsets earn their place.
  void pose_with_joint_offsets(const PartPose& pose, const Eigen::MatrixXd& joint_offsets, Eigen::MatrixXd* X) const;

  /// The rigid part motions T^R that `method` poses with (the learned one with the model's joint
  /// offsets, scaled to the subject).
  PartTransforms part_motions(const PartPose& pose, PoseMethod method) const;
  /// Where each joint effectively turns (#joints x 3, at rest in the parent's frame): its centre, or
  /// with the learned method's joint offsets the pivot of their linear part (rigid_pose.h).
  Eigen::MatrixXd joint_pivots(PoseMethod method) const;

  const SubjectSetupInfo& info() const;
  const Eigen::MatrixXd& rest_vertices() const;  ///< the subject at rest, #V x 3
  const Eigen::MatrixXi& faces() const;          ///< #F x 3
  const Eigen::VectorXi& vertex_parts() const;   ///< #V, the part each vertex moves with

 private:
  void pose_with(const PartPose& pose, PoseMethod method, const Eigen::MatrixXd& joint_offsets, Eigen::MatrixXd* X) const;
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace posekit
