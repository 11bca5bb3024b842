#pragma once
// A linear shape space of bodies in the source's topology (principal components of a registered
// population), and the fit of it to a target surface that refines ct-FFD's correspondence: where
// ct-FFD places a vertex by its layer proportions, the population says how that vertex moves
// between bodies (e.g. where on a thigh a given skin point lies on a heavier body).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct ShapeSpace {
  Eigen::MatrixXd mean;  ///< #V x 3, the population's mean body (m)
  /// 3#V x K: component k (rows x0 y0 z0 x1 ...), scaled by its standard deviation, so a body is
  /// mean + basis * c with c about unit normal.
  Eigen::MatrixXd basis;
  std::vector<double> variance_share;  ///< of each component in the population's total variance
  int bodies = 0;                      ///< how many bodies it was learned from
  std::string population;              ///< what they were (and what was left out)
  /// The bodies' triangles when known (#F x 3; empty: not recorded): a source of another
  /// connectivity with the same vertex count is refused by register_bodies.
  Eigen::MatrixXi faces;
  /// The body's 15 joint centres (see parts.h) when the space knows them (empty: it does not): the
  /// mean's (#joints x 3, m) and each component's displacement of them (3 #joints x K, rows x0 y0 z0
  /// x1 ...), so a body's joints are joint_mean + joint_basis * c exactly as its vertices are.
  Eigen::MatrixXd joint_mean, joint_basis;
  /// Poses people take, for a body-model fit's search (posekit shape-space --motions: frames of
  /// motion capture retargeted to the mean body and chosen far apart): a row each, the pelvis's
  /// rotation (heading removed) then every joint's relative to its parent, axis-angle (3 + 3 #joints);
  /// and their names. Empty: none.
  Eigen::MatrixXd poses;
  std::vector<std::string> pose_names;

  int components() const { return static_cast<int>(basis.cols()); }
  int vertices() const { return static_cast<int>(mean.rows()); }
  bool has_joints() const { return joint_mean.size() > 0; }
  /// The body of coefficients c (K; missing trailing ones are 0), #V x 3; and its joints.
  Eigen::MatrixXd body(const Eigen::VectorXd& c) const;
  Eigen::MatrixXd joints(const Eigen::VectorXd& c) const;
};

/// Principal components of `bodies` (each #V x 3, one topology, one frame: no alignment is done)
/// keeping `variance_kept` of the variance, at most `max_components`. Throws InvalidInput for fewer
/// than 2 bodies or bodies of different sizes.
ShapeSpace learn_shape_space(const std::vector<Eigen::MatrixXd>& bodies, double variance_kept = 0.99999, int max_components = 60,
                             std::string population = "");

/// Turns every body rigidly (rotation and translation, no scale) onto the bodies' mean, iterated
/// (generalised Procrustes): registered meshes from a user's own captures stand in different places
/// and directions, and a shape space must not spend components on that. In place; the mean ends in
/// the first body's frame. Throws InvalidInput for bodies of different sizes.
void align_bodies_rigidly(std::vector<Eigen::MatrixXd>& bodies, int rounds = 3);

/// A shape space file (.pks: header, population, triangles, mean, basis in doubles, joints when
/// known, CRC-32 trailer; format in docs/registration.md), written through a temporary file. Throws IoError.
void write_shape_space(const std::string& path, const ShapeSpace& space);
/// Reads a .pks file; a truncated, corrupt or other file gets an IoError naming it.
ShapeSpace read_shape_space(const std::string& path);

struct ShapeFitOptions {
  int iterations = 8;          ///< closest-point iterations against the target, at most
  double convergence = 0.01;   ///< stop when the coefficients move less (standard deviations)
  int vertex_stride = 4;       ///< every n-th source vertex takes part in the fit
  double max_distance = 0.03;  ///< m: pairs farther apart are rejected
  double max_normal_angle_deg = 60;
  /// Weight of the prior on the coefficients: each unit of standard deviation costs as much as one
  /// pair this far (m) off the target's plane.
  double prior_distance = 0.001;
  /// The fit is implausible (the target is not a body the space can say: another pose, a cut, a
  /// shape outside its population) when its vertices lie farther than this from the target (median, m).
  double max_median_distance = 0.003;
  /// ... or when, by over `max_extra_far_share`, more of its vertices lie farther than `far_distance`
  /// (m) from the target than of the start's, or more of the target lies that far from it: a part the
  /// space cannot place (arms held otherwise, a bent elbow, a twisted torso), however well the rest fits.
  double far_distance = 0.01, max_extra_far_share = 0.01;
  /// Threads for the closest-point searches (0: the hardware's): the same result to rounding whatever
  /// the count (a tie between two triangles may go either way), the same bits for the same count.
  int threads = 1;
};

struct ShapeFitResult {
  Eigen::MatrixXd V;             ///< #V x 3: the fitted body, posed rigidly on the target
  Eigen::VectorXd coefficients;  ///< K
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  int iterations = 0;
  double median_distance = 0;    ///< m, of the fitted body's sampled vertices from the target
  double accepted_fraction = 0;  ///< of the sampled vertices in the last iteration
  /// Shares of the sampled vertices farther than options.far_distance from the target: of the fit,
  /// and of the start (-1: not measured, the fit's being within options.max_extra_far_share).
  double far_share = 0, start_far_share = -1;
  /// Shares of the target's vertices (about 2,000 sampled) farther than options.far_distance from
  /// the fit, and from the start (-1 as above).
  double uncovered_share = 0, start_uncovered_share = -1;
  bool plausible = false;  ///< within options.max_median_distance and options.max_extra_far_share
};

/// A target surface made ready for fit_shape_space (its closest-point tree, vertex normals and hole
/// borders): made once when it is fitted to more than once, or made while other work runs. Refers
/// to `target`, which must outlive it.
class ShapeFitTarget {
 public:
  explicit ShapeFitTarget(const TriangleMesh& target);
  ~ShapeFitTarget();
  ShapeFitTarget(ShapeFitTarget&&) noexcept;
  ShapeFitTarget& operator=(ShapeFitTarget&&) noexcept;
  const TriangleMesh& mesh() const;

  struct Impl;
  const Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

/// Fits the shape space, with a rigid motion, to the target surface, starting from `start` (#V x 3:
/// the source already on the target, e.g. ct-FFD's result): the space's projection of the start,
/// then iterations of point-to-plane closest-point pairs (rejected when too far, facing away or on a
/// hole's border) against a Gaussian prior on the coefficients. Deterministic. Throws InvalidInput
/// when the sizes do not match.
ShapeFitResult fit_shape_space(const ShapeSpace& space, const Eigen::MatrixXi& F, const Eigen::MatrixXd& start, const TriangleMesh& target,
                               const ShapeFitOptions& options = {});
/// The same on a target made ready beforehand.
ShapeFitResult fit_shape_space(const ShapeSpace& space, const Eigen::MatrixXi& F, const Eigen::MatrixXd& start,
                               const ShapeFitTarget& target, const ShapeFitOptions& options = {});

}  // namespace posekit
