#pragma once
// Automatic part segmentation of any body mesh (section 3.3.1 of Zhu & Mok, Eq. 2a-2c): each
// triangle takes the part label of the nearest labelled triangle of the body's layered
// representation, among those facing the same way.
#include <Eigen/Core>

#include "posekit/shape/layered_representation.h"

namespace posekit {

struct SegmentationOptions {
  int candidates = 16;              ///< nearest representation triangles tried for the normal test (Eq. 2c)
  bool clean = true;                ///< keep one connected region per part (see clean_part_labels)
  double border_smoothing = 0.025;  ///< m: smooth_part_borders radius (0: the Eq. 2 labels as they are)
};

struct Segmentation {
  Eigen::VectorXi triangle_part;  ///< #F, labels in [0, 16)
  Eigen::VectorXi vertex_part;    ///< #V, the label most of a vertex's triangles carry (by area)
  int normal_failures = 0;        ///< triangles with no representation triangle facing the same way
  int relabelled = 0;             ///< triangles moved by the clean-up
};

/// Eq. 2a-2c: labels every triangle of (V, F) from the representation `rep` of the same body, whose
/// triangles carry `representation_labels` (#rep triangles; rep.triangle_part when empty).
Segmentation segment_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const LayeredRepresentation& rep,
                          const Eigen::VectorXi& representation_labels = {}, const SegmentationOptions& options = {});

/// Labels the representation's triangles once from a labelled body (the template): each takes the
/// area-majority label of the body triangles whose Eq. 2 match it is; triangles no body triangle
/// matches keep the layer's own label. The result applies to every body's representation, since
/// they share the topology.
Eigen::VectorXi representation_labels_from_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                                const LayeredRepresentation& rep);

/// Keeps the largest edge-connected region of each part; smaller islands take the label of the
/// neighbour they share most boundary with. Returns the number of triangles relabelled.
int clean_part_labels(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::VectorXi* triangle_part);

/// Per-vertex labels from per-triangle labels: the label with the largest incident area.
Eigen::VectorXi vertex_labels_from_triangles(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part);

/// Smooths the borders between parts: each vertex starts wholly in its triangles' majority part,
/// and these part shares are diffused over about `radius` metres of edges (near the borders only), and each triangle takes the part with
/// the largest share at its corners. A border that zigzags across triangle rows (each triangle labelled by its own nearest representation
/// triangle) becomes the level line of the diffused shares, smooth at the scale of the radius. Throws InvalidInput on a label count other
/// than F.rows().
void smooth_part_borders(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double radius, Eigen::VectorXi* triangle_part);

/// How far part borders zigzag: for each joint's border (child part against its parent), the
/// length of its edges over the perimeter of the convex hull of their midpoints in the border's
/// best-fit plane; the median over the borders. About 1.05-1.15 for a clean ring round a limb
/// (the hull of a ring is its length), more where the border runs up and down triangle rows. NaN
/// when no border has 6 edges.
double border_roughness(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part);

/// Fraction of the surface area on which two labellings of the same mesh agree.
double label_agreement(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& a, const Eigen::VectorXi& b);

}  // namespace posekit
