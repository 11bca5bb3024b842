#pragma once
// Which way a body file's axes point: brings any standing body or scan to posekit's frame
// (Y up, facing +Z, the subject's left +X) and back.
#include <Eigen/Core>
#include <string>
#include <vector>

namespace posekit {

/// A body's orientation in its file: p_posekit = rotation * p_file. The rows of `rotation` are the
/// subject's left, up and forward directions written in the file's axes. A proper rotation.
struct BodyOrientation {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  bool up_detected = false, forward_detected = false;  ///< found from the body's shape, not given
  std::vector<std::string> warnings;                   ///< weak or contradicting cues, said plainly

  Eigen::Vector3d up() const { return rotation.row(1).transpose(); }
  Eigen::Vector3d forward() const { return rotation.row(2).transpose(); }
  bool is_identity() const { return rotation.isIdentity(1e-12); }
  /// e.g. "up +X (detected), facing -Z (given)".
  std::string describe() const;
};

/// Parses an axis as "+X", "-y", "z" (sign optional, + by default) into a unit vector.
/// Throws InvalidInput naming the accepted spellings.
Eigen::Vector3d parse_axis(const std::string& text);

/// "+X", "-Z", or "(0.100, 0.995, 0.000)" for a direction that is no coordinate axis.
std::string axis_name(const Eigen::Vector3d& direction);

/// The orientation of a file whose body points `up` and faces `forward` (file axes; need not be
/// unit length). Throws InvalidInput when they are not perpendicular (within 1 degree).
BodyOrientation orientation_from_axes(const Eigen::Vector3d& up, const Eigen::Vector3d& forward);

struct OrientationOptions {
  /// Detected directions within these angles of a coordinate axis become that axis exactly: files
  /// are written in axis conventions, and a scanner's vertical is exact. The vertical's tolerance is
  /// wider: a posed body's long axis leans (arms reaching forward: 11.5 degrees on m05).
  double up_snap_degrees = 30, forward_snap_degrees = 10;
  /// Directions the user gave (file axes, zero = detect). A given up is kept; a given forward is
  /// kept too, and must then be perpendicular to the up.
  Eigen::Vector3d up = Eigen::Vector3d::Zero(), forward = Eigen::Vector3d::Zero();
};

/// Finds how a standing human body lies in its file from the spread of its surface. Up: the axis
/// of largest spread (even arms spread sideways carry little of the surface), pointing from the
/// feet, which hold much surface in the lowest slab (soles, insteps), to the crown, with the
/// surface's centre above mid-height as a second cue. Left-right: the wider direction of the
/// chest band. Forward: the way the feet point from the shanks. Cues that are weak or disagree
/// give a warning; without feet the front is taken nearest the file's +Z, with a warning.
///  P        #P x 3 surface samples (a scan's points, or a mesh's face centroids), any unit
///  weights  #P surface area per sample (empty: equal weights)
/// Over 200,000 samples it looks at an evenly spread 200,000 of them.
/// Throws InvalidInput when the body has no clear long axis (not a standing body, or a blob).
BodyOrientation detect_body_orientation(const Eigen::MatrixXd& P, const Eigen::VectorXd& weights = {},
                                        const OrientationOptions& options = {});

/// The same for a mesh: its face centroids weighted by area.
BodyOrientation detect_mesh_orientation(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const OrientationOptions& options = {});

/// How a body's points were brought into posekit's frame (metres, Y up, facing +Z).
struct BodyFrame {
  double metres_per_unit = 1;
  std::string unit = "m";      ///< m, dm, cm or mm
  bool unit_detected = false;  ///< from the largest extent, not given
  double extent = 0;           ///< when detected: the largest extent (stray points aside) in the file's numbers
  BodyOrientation orientation;
  /// e.g. "unit mm (detected from the body's largest extent, 1712); up +Z (detected), facing -Y (detected)".
  std::string describe() const;
};

/// The one rule the CLI and the Python module read bodies by. Scales `points` (a mesh's vertices or
/// a scan's points) to metres, `unit` m, dm, cm, mm or "auto" (the largest extent, stray points
/// aside, of a standing body or a torso, 0.5 to 3 m, tells which), then turns them, and `normals`
/// when given, into posekit's frame: `up` and `forward` are axes ("+Z", "-y", ...) or "auto"
/// (detected; from the faces when given). Throws InvalidInput when no unit explains the extent or
/// the orientation cannot be found.
BodyFrame bring_to_posekit_frame(Eigen::MatrixXd* points, const Eigen::MatrixXi* faces, Eigen::MatrixXd* normals,
                                 const std::string& unit = "auto", const std::string& up = "auto", const std::string& forward = "auto");
/// Its two steps: the unit (fills the unit fields of the result), then the axes: the orientation is
/// detected from `points` (which may be one of `turned`), then every matrix in `turned` is turned.
BodyFrame scale_body_to_metres(Eigen::MatrixXd* points, const std::string& unit);
BodyOrientation turn_body_to_posekit_frame(std::vector<Eigen::MatrixXd*> turned, const Eigen::MatrixXd& points,
                                           const Eigen::MatrixXi* faces, const std::string& up, const std::string& forward);

}  // namespace posekit
