#pragma once
// The feature-aligned layered shape representation (section 3.2 of Zhu & Mok): the body as chains
// of cross-sections (torso, head, legs, arms) at levels that follow its features, each resampled to
// the same number of points by angle, so every body gives the same topology. Its triangles carry
// the 16 part labels once and for all (Eq. 2a).
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"
#include "posekit/shape/body_features.h"

namespace posekit {

struct RepresentationLayer {
  int chain = 0;                ///< index into LayeredRepresentation::chain_names
  Eigen::Vector3d centre;       ///< area centroid of the section (m)
  Eigen::Vector3d normal;       ///< plane normal, along the chain
  Eigen::Vector3d front, side;  ///< in-plane axes: angle 0 along front, 90 degrees along side
  int part = 0;                 ///< 16-part label of the band above this layer
};

struct LayeredRepresentation {
  int points_per_layer = 0;
  std::vector<std::string> chain_names;  ///< torso, head, left_leg, right_leg, left_arm, right_arm
  std::vector<RepresentationLayer> layers;
  /// Representation mesh: vertex layer * points_per_layer + k is point k of a layer; quads between
  /// consecutive layers of a chain, split in two triangles. The same F for every body.
  TriangleMesh mesh;
  Eigen::VectorXi triangle_part;   ///< #F, 16-part labels
  Eigen::VectorXi triangle_layer;  ///< #F, the lower layer of the band the triangle is in
};

/// Layers per chain segment (see README); together with points_per_layer they fix the topology.
int representation_layer_count();

/// Builds the representation of a standing body mesh from its features, on the same surface the
/// features are found on (body_surface: floating bits left out, holes up to kMaxFilledHole closed).
/// Throws InvalidInput when a section cannot be found.
LayeredRepresentation build_layered_representation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const BodyFeatures& features,
                                                   int points_per_layer = 32);

/// The same from the surface find_body_features gave with the features (its body_surface, not
/// made again: 7 ms of a 50k-vertex scan), its horizontal layers sliced on `threads` threads (0:
/// the hardware's). The same representation to the last bit.
LayeredRepresentation build_layered_representation_on_surface(const TriangleMesh& surface, const BodyFeatures& features,
                                                              int points_per_layer = 32, int threads = 1);

/// The layers' planes that build_layered_representation would cut for these features (chain, part,
/// normal, in-plane axes, and as centre the point the plane is placed through), with the topology's
/// mesh.F, triangle_part and triangle_layer; every point of a layer is its centre. For bodies known
/// by their features only (photos): the caller fills the points.
LayeredRepresentation plan_layered_representation(const BodyFeatures& features, int points_per_layer = 32);

}  // namespace posekit
