#pragma once
// VTK viewers for meshes with error fields: an interactive window and off-screen PNG rendering,
// several meshes side by side, a labelled colour bar in mm. VTK stays inside src/.
#include <Eigen/Core>
#include <string>
#include <utility>
#include <vector>

#include "posekit/core/colour_map.h"
#include "posekit/core/point_cloud.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit {

struct ColourMap {
  ColourMapKind kind = ColourMapKind::kSequential;
  bool automatic = true;     ///< range from the data (heatmap_range: its 95th percentile)
  double min = 0, max = 10;  ///< fixed range when not automatic
  std::string title = "error (mm)";
  std::vector<std::string> categories;  ///< kCategorical: the name of each value 0..n-1
};

enum class CameraPreset { kFront, kSide, kBack };
CameraPreset parse_camera_preset(const std::string& name);  ///< "front", "side" or "back"

/// One panel of a figure: a mesh (optionally coloured by one of its vertex scalars), optionally a
/// point cloud overlaid, and a caption.
struct ViewPanel {
  TriangleMesh mesh;
  std::string scalar;                  ///< vertex scalar to colour by; empty: plain skin colour
  PointCloud overlay;                  ///< drawn as points when not empty
  std::vector<Eigen::MatrixXd> lines;  ///< closed polylines (#K x 3 each) drawn over the mesh, e.g. girths' tape paths
  std::string caption;
  CameraPreset camera = CameraPreset::kFront;
};

/// The box of a panel's points without their outliers (a scan's strays): each axis from its 1st to its
/// 99th percentile. Both viewers frame a panel of points alone by it. Throws InvalidInput when P is empty.
std::pair<Eigen::Vector3d, Eigen::Vector3d> robust_box(const Eigen::MatrixXd& P);

struct ViewOptions {
  ColourMap colour_map;
  int panel_width = 480, panel_height = 720;
  bool colour_bar = true;  ///< shown when any panel has a scalar
  double point_size = 1.0;
  std::string title;  ///< window title / figure title
};

/// Renders the panels side by side off-screen and writes a PNG (atomically). Needs an X display;
/// without one it starts a private Xvfb for the duration. Throws InvalidInput on an unknown scalar
/// or empty mesh, IoError when the PNG cannot be written or no display can be had.
void render_panels_png(const std::vector<ViewPanel>& panels, const ViewOptions& options, const std::string& png_path);

/// One synthetic input event for a scripted viewer session: a left click, or a key typed, at a
/// point given as fractions of the window (0,0 bottom left; 1,1 top right).
struct ViewerEvent {
  enum class Kind { kClick, kKey } kind = Kind::kClick;
  double x = 0.5, y = 0.5;
  char key = 0;
};

/// What a session ended with: the overlays' visibility, the camera preset, one line per picked
/// vertex ("panel 0 vertex 12 at (x, y, z) m: scalar = v").
struct ViewerState {
  bool overlays_visible = true;
  CameraPreset camera = CameraPreset::kFront;
  std::vector<std::string> picks;
};

/// Opens an interactive window (rotate, zoom; click a vertex to print its scalar; 's' toggles the
/// overlays; 'c' cycles front/side/back). Returns when the window is closed. Throws IoError when no
/// display is available. With `script`, its events are played through VTK's interactor instead
/// of waiting for the user (a private Xvfb is started when there is no display) and the window
/// closes after the last one.
ViewerState show_panels(const std::vector<ViewPanel>& panels, const ViewOptions& options, const std::vector<ViewerEvent>* script = nullptr);

/// The range a colour map will use for these values (NaNs ignored): fixed, or heatmap_range's.
std::pair<double, double> colour_range(const ColourMap& map, const std::vector<const Eigen::VectorXd*>& values);

}  // namespace posekit
