#pragma once
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit {

/// What is wrong (or right) with a mesh; counts only, nothing is modified.
struct MeshReport {
  long num_vertices = 0;
  long num_faces = 0;
  long out_of_range_indices = 0;   ///< face indices < 0 or >= #V
  long non_finite_vertices = 0;    ///< vertices with a NaN or Inf coordinate
  long degenerate_faces = 0;       ///< repeated vertex index or zero area
  long duplicate_faces = 0;        ///< same vertex set as an earlier face
  long unreferenced_vertices = 0;  ///< used by no face
  long boundary_edges = 0;
  long non_manifold_edges = 0;  ///< shared by more than two faces
  long boundary_loops = 0;
  long components = 0;
  bool watertight = false;     ///< no boundary and no non-manifold edge
  double surface_area = 0.0;   ///< m^2
  double signed_volume = 0.0;  ///< m^3, meaningful when watertight

  /// True when the mesh can be used at all: indices in range and coordinates finite.
  bool usable() const { return out_of_range_indices == 0 && non_finite_vertices == 0; }
};

/// Counts the defects of a mesh (Deliver 3 of the foundation issue).
MeshReport validate_mesh(const TriangleMesh& mesh);

/// Throws InvalidInput naming `what` and the first bad element when indices are out of range or
/// a coordinate is not finite. Used at every I/O and API boundary.
void require_usable_mesh(const TriangleMesh& mesh, const std::string& what);

/// Small pieces apart from a scanned body (a strap, a clump of hair, a bit of the booth): the
/// connected components (faces joined through shared vertices) whose area is under
/// `min_area_fraction` of the largest one's. Their faces are false in the result, #F. Unreferenced
/// vertices are no faces and need no removal.
struct FloatingBits {
  std::vector<bool> keep_face;   ///< #F: false for the faces of floating bits
  int bits = 0;                  ///< components dropped
  double area = 0;               ///< their total area (m^2 when V is in metres)
  std::string describe() const;  ///< "dropped 4 floating pieces (0.012 m^2) apart from the body"
};
FloatingBits find_floating_bits(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double min_area_fraction = 0.05);

}  // namespace posekit
