#pragma once
// Planar cross-sections of a mesh and their perimeters (girths, ISO 8559-1 style).
#include <Eigen/Core>
#include <vector>

namespace posekit {

/// Cross-section of a triangle mesh with the plane {x : normal . x = offset}: each loop is
/// #points x 3, in order along the section; `closed` tells whether the loop returned to its start
/// (an open chain means the mesh has a hole there). normal need not be unit length.
struct SectionLoop {
  Eigen::MatrixXd points;
  bool closed = false;
};
std::vector<SectionLoop> slice_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& normal, double offset);

/// Sections at many parallel planes {normal . x = offsets[i]} in one pass over the faces (each face
/// only visits the planes its extent spans): result[i] are the loops at offsets[i]. On `threads`
/// threads (0: the hardware's) for a large mesh, with the same loops to the last bit.
std::vector<std::vector<SectionLoop>> slice_mesh_stack(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& normal,
                                                       const std::vector<double>& offsets, int threads = 1);

/// The section of the smooth surface through the mesh's vertices (Phong tessellation with shape
/// factor 1/2 and the unit vertex normals N): each cut point moved onto that surface, and the
/// surface's point halfway across each face cut in between. A flat section lies inside a smooth
/// body by the chords' sagitta (about 1 mm of girth round a thigh with 1.2 cm edges), which
/// depends on the tessellation; this one hardly does. Points lie within a fraction of a mm of
/// the plane.
std::vector<SectionLoop> slice_smooth_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N,
                                           const Eigen::Vector3d& normal, double offset);

/// slice_smooth_mesh at many parallel planes in one pass, as slice_mesh_stack.
std::vector<std::vector<SectionLoop>> slice_smooth_mesh_stack(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N,
                                                              const Eigen::Vector3d& normal, const std::vector<double>& offsets);

/// Length of a polyline (#P x 3), including the closing segment when `closed`.
double polyline_length(const Eigen::MatrixXd& points, bool closed);

/// Perimeter of the convex hull of points lying in a plane with the given normal: a tape measure
/// stretched around the section (#P x 3 points, m).
double convex_hull_perimeter(const Eigen::MatrixXd& points, const Eigen::Vector3d& normal);
/// That hull itself, the tape's path: its corners in order round the section (#K x 3, not repeated at
/// the end), in the points' plane.
Eigen::MatrixXd convex_hull_loop(const Eigen::MatrixXd& points, const Eigen::Vector3d& normal);

/// Distance between two loops of a section (the nearest points of their polylines, closing
/// segments included for closed loops): e.g. the gap between an arm and the torso. Throws
/// InvalidInput for an empty loop.
double loop_distance(const SectionLoop& a, const SectionLoop& b);

/// Index of the loop whose centroid is nearest to `point` (-1 when there are none).
int nearest_loop(const std::vector<SectionLoop>& loops, const Eigen::Vector3d& point);

}  // namespace posekit
