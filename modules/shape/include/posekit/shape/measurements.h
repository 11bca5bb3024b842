#pragma once
// Stature and girths of a standing body (mesh or scan), defined in the README after ISO 8559-1:
// tape girths are convex-hull perimeters of the cross-section at the feature levels.
#include <Eigen/Core>
#include <string>
#include <vector>

#include "posekit/shape/body_features.h"

namespace posekit {

struct Girth {
  std::string name;  ///< bust, underbust, waist, hip, thigh, knee, calf, ankle, upper_arm, wrist, neck
  double value = 0;  ///< m (valid when measured)
  bool measured = false;
  std::string note;                                   ///< why it was not measured (e.g. a hole in the scan)
  Eigen::Vector3d point = Eigen::Vector3d::Zero();    ///< where the tape goes round
  Eigen::Vector3d normal = Eigen::Vector3d::UnitY();  ///< the tape's plane normal
  /// The tape's path where measured: the section's convex hull, a closed polyline (#K x 3, m, the
  /// first corner not repeated); empty otherwise.
  Eigen::MatrixXd tape;
};

/// The girths' names in the order measurements give them: bust, underbust, waist, hip, thigh, knee,
/// calf, ankle, upper_arm, wrist, neck.
const std::vector<std::string>& girth_names();

struct BodyMeasurements {
  double stature = 0;            ///< m
  bool stature_measured = true;  ///< false when the head is cut: stature is then an estimate
  std::string stature_note;      ///< why it is not measured
  std::vector<Girth> girths;
  /// As find_body_features found them, with the bust and underbust levels found again on 1 mm
  /// sections (and, on a mesh, the crotch on the smooth surface) where the girths are measured.
  BodyFeatures features;
  const Girth* find(const std::string& name) const;
};

/// Sanity checks on measured girths, applied by measure_body and measure_point_cloud: a limb or
/// neck girth over 0.6 of the stature, a torso girth over 1.5 times it, or a girth not smaller than
/// the one anatomy puts above it (neck < bust and hip, wrist < upper arm, ankle < calf, knee and calf
/// < thigh), or a bust over 1.35 times the hip (a section that took in the arms) is marked not
/// measured, its note saying why.
void reject_implausible_girths(BodyMeasurements* m);

/// Measures a standing body mesh. Throws InvalidInput as find_body_features does.
BodyMeasurements measure_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F);

/// Measures a standing body scan (#P x 3 points, m): sections are slabs of points; a girth whose
/// section has an angular gap over 40 degrees is reported as not measured, with the reason.
BodyMeasurements measure_point_cloud(const Eigen::MatrixXd& P);

/// Horizontal "sections" of a point cloud (isolated outliers dropped first): points within half a
/// step of each level, clustered
/// (2 cm), each cluster ordered by angle about its centroid; closed when no angular gap exceeds
/// `max_gap_deg`.
SectionStack horizontal_sections_of_points(const Eigen::MatrixXd& P, double step = 0.005, double max_gap_deg = 40);

/// A scan's section from its points in one slab, projected into the plane (normal n): the median
/// radius about their centroid in each angular sector (which also removes the scanner's noise);
/// closed when no run of empty sectors spans more than `max_gap_deg`.
SectionLoop section_from_planar_points(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal, double max_gap_deg = 40);
/// The slab thickness (m) that cuts whole sections from a scan whose points are `spacing` (m) apart.
double section_slab_thickness(double spacing);

}  // namespace posekit
