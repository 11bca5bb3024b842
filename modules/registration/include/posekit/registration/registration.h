#pragma once
// Registering a source body (e.g. the template) to a target body (a customized model) and the
// triangle correspondence that follows (section 3.3.3 of Zhu & Mok): ct-FFD, or the rigid ICP
// baseline of the paper's Table 1.
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"
#include "posekit/registration/nicp.h"
#include "posekit/registration/shape_space.h"

namespace posekit {

enum class RegistrationMethod { kCtffd, kIcp, kNicp };

struct RegistrationOptions {
  RegistrationMethod method = RegistrationMethod::kCtffd;
  int icp_iterations = 6;     ///< PCL IterativeClosestPoint iterations (kIcp)
  int points_per_layer = 32;  ///< layered representation resolution (kCtffd)
  /// kCtffd: refine ct-FFD's result by a few soft steps of non-rigid ICP (`refinement`) started from it.
  bool refine = false;
  NicpOptions nicp;  ///< kNicp: the full schedule, landmarks from the layered representations
  NicpOptions refinement = refinement_defaults();
  /// kCtffd: refine ct-FFD's result by fitting this shape space of bodies in the source's topology
  /// (fit_shape_space), before the non-rigid refinement if both are asked. Kept only when the fit
  /// lies closer to the target than ct-FFD's result; otherwise a warning says why.
  std::shared_ptr<const ShapeSpace> shape_space;
  ShapeFitOptions shape_fit;
  /// Landmarks for kNicp: every `landmark_layer_stride`-th layer of the representation, and on it
  /// every `landmark_point_stride`-th point.
  int landmark_layer_stride = 2, landmark_point_stride = 4;
  /// kCtffd: threads (0: the hardware's). With 2 or more the target's closest-point tree is built
  /// while its features are found, and the shape-space fit's and the nearest-centroid searches are
  /// split; the same result to rounding (a tie between two triangles may go either way).
  int threads = 1;

  static NicpOptions refinement_defaults();
};

struct RegistrationResult {
  Eigen::MatrixXd deformed_source;  ///< #Vs x 3: the source moved onto the target
  Eigen::VectorXi correspondence;   ///< #Ft: for each target triangle, its source triangle (Eq. 2b/2c)
  int normal_failures = 0;          ///< target triangles with no source triangle facing the same way
  double seconds = 0;               ///< wall time of the whole registration
  double ctffd_seconds = 0;         ///< of which ct-FFD (kCtffd)
  NicpResult nicp;                  ///< the non-rigid ICP's schedule and last pairs (kNicp, or refine)
  ShapeFitResult shape_fit;         ///< options.shape_space: the fit (its `better` says whether it was kept)
  double shape_fit_seconds = 0;
  /// kCtffd: the features' doubts on either body, and limbs whose length between the found joints is
  /// implausible against the source's (a hole or cut taken for a limb's end).
  std::vector<std::string> warnings;
};

/// Registers source to target and matches triangles by nearest centroid. Throws InvalidInput when a
/// body's features cannot be found (ct-FFD) or a mesh is unusable.
RegistrationResult register_bodies(const TriangleMesh& source, const TriangleMesh& target, const RegistrationOptions& options = {});

/// The source's side of ct-FFD (its features, layered representation and parametrisation), made
/// once when many targets are registered to one source: the template against a population.
class CtffdSource {
 public:
  /// Throws InvalidInput when the source is unusable, does not stand along +Y or its features cannot be found.
  explicit CtffdSource(const TriangleMesh& source, int points_per_layer = 32);
  const TriangleMesh& mesh() const;
  int points_per_layer() const;
  double seconds() const;  ///< what making it took
  struct Impl;
  const Impl& impl() const;

 private:
  std::shared_ptr<const Impl> impl_;
};

/// register_bodies from a prepared source: for ct-FFD only the target's side is made (its time is
/// `seconds`); other methods register source.mesh(). Throws InvalidInput when options ask for another
/// representation resolution than the source was prepared with.
RegistrationResult register_bodies(const CtffdSource& source, const TriangleMesh& target, const RegistrationOptions& options = {});

/// What can be judged of a registration without ground truth.
struct RegistrationQuality {
  double mean_distance_mm = 0, p95_distance_mm = 0;  ///< registered source vertices to the target surface
  double target_covered = 0;                         ///< share of target vertices within 10 mm of the registered source
  double normals_agree = 0;                          ///< share of registered source vertices facing within 60 degrees of the target there
  int folded_triangles = 0;                          ///< triangles turned over (facing against their own direction on the source)
  std::vector<std::string> warnings;                 ///< what is poor, said plainly
};

/// Distances, coverage, normal agreement and fold-overs of `deformed` (the source's vertices after
/// registration) against the target; warnings when the correspondence cannot be good.
RegistrationQuality assess_registration(const TriangleMesh& source, const Eigen::MatrixXd& deformed, const TriangleMesh& target);

RegistrationMethod parse_registration_method(const std::string& name);  ///< "ctffd", "icp" or "nicp"

}  // namespace posekit
