// posekit view: meshes with error fields in VTK's viewer, or off-screen PNG panels.
#include <iostream>
#include <string>
#include <vector>

#include "cli.h"
#include "commands.h"
#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/io/mesh_io.h"
#include "posekit/viewers/viewer.h"
#include "posekit/viewers/web_viewer.h"

namespace posekit::cli {

int run_view(int argc, char** argv) {
  ArgParser args("view",
                 "Shows meshes coloured by a vertex scalar (e.g. signed_distance_mm from posekit compare) in a VTK\n"
                 "window: drag to rotate, wheel to zoom, click a vertex to print its value, 's' toggles the scan,\n"
                 "'c' cycles front/side/back. With --png renders off-screen instead (no display needed: a private\n"
                 "Xvfb is started when DISPLAY is unset). With --html writes an interactive page instead (three.js,\n"
                 "WebGL: opens offline in any browser, from file://, its scripts beside it). Several meshes are\n"
                 "shown side by side.");
  args.positional("mesh", "mesh(es) to show; separate several with commas")
      .option("scalar", "NAME", "vertex scalar to colour by (default: none, plain skin)")
      .option("scan", "FILE", "a point cloud to overlay (PCD/PLY/XYZ)")
      .option("scan-unit", "U", "unit of the scan", "mm")
      .option("unit", "U", "unit of the meshes", "m")
      .option("camera", "C", "front, side or back", "front")
      .output("png", "FILE", "render off-screen to this PNG and exit")
      .output("html", "FILE", "write an interactive web page (three.js) and exit; three.min.js and the data go beside it")
      .option("size", "WxH", "size of each panel in pixels", "480x720")
      .option("range", "MIN:MAX", "colour range (default: automatic)")
      .option("colours", "KIND", "diverging, sequential or categorical (labels; default for the scalar 'part')")
      .option("title", "TEXT", "colour bar title (default: the scalar's name, with its unit)")
      .example("posekit view f01_errors.ply --scalar signed_distance_mm --colours diverging --png f01.png")
      .example("posekit view parts.ply --scalar part --png parts.png")
      .example("posekit view f01_errors.ply --scalar signed_distance_mm --colours diverging --html f01/errors.html");
  if (!args.parse(argc, argv)) return 0;
  ViewOptions v;
  const std::string scalar = args.has("scalar") ? args.get("scalar") : "";
  v.colour_map = colour_map_from(args, scalar == "part" ? ColourMapKind::kCategorical : ColourMapKind::kSequential);
  if (v.colour_map.kind == ColourMapKind::kCategorical) {
    if (scalar != "part") throw UsageError("--colours categorical: only the scalar 'part' (0..15, posekit segment) has named categories");
    for (int i = 0; i < kNumParts; ++i) v.colour_map.categories.push_back(part_name(i));
  }
  // "signed_distance_mm" -> "signed distance (mm)"
  std::string title = scalar;
  const bool in_mm = title.size() > 3 && title.compare(title.size() - 3, 3, "_mm") == 0;
  if (in_mm) title.resize(title.size() - 3);
  std::replace(title.begin(), title.end(), '_', ' ');
  v.colour_map.title = args.has("title") ? args.get("title") : title + (in_mm ? " (mm)" : "");
  const auto [w, h] = parse_number_pair(args.get("size"), 'x', "--size");
  v.panel_width = static_cast<int>(w);
  v.panel_height = static_cast<int>(h);
  if (v.panel_width < 64 || v.panel_height < 64 || v.panel_width > 4000 || v.panel_height > 4000)
    throw UsageError("--size: each side must be 64 to 4000 pixels");
  PointCloud overlay;
  if (args.has("scan")) {
    const BodyInput in = read_body_input(args.get("scan"), parse_unit(args.get("scan-unit")));
    if (in.is_cloud) overlay = in.cloud;
    else overlay.P = in.mesh.V;
  }
  std::vector<ViewPanel> panels;
  std::string list = args.positionals()[0];
  size_t start = 0;
  while (start <= list.size()) {
    const size_t comma = list.find(',', start);
    const std::string path = list.substr(start, comma == std::string::npos ? std::string::npos : comma - start);
    if (!path.empty()) {
      ViewPanel p;
      p.mesh = read_mesh(path, {parse_unit(args.get("unit"))});
      p.scalar = args.has("scalar") ? args.get("scalar") : "";
      p.camera = parse_camera_preset(args.get("camera"));
      p.overlay = overlay;
      p.caption = path.substr(path.find_last_of('/') == std::string::npos ? 0 : path.find_last_of('/') + 1);
      panels.push_back(std::move(p));
    }
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  if (args.has("html")) {
    v.title = args.has("title") ? args.get("title") : panels.front().caption;
    write_web_page(args.get("html"), panels, v);
    std::cout << "wrote " << args.get("html") << " (open it in a browser; its scripts are beside it)\n";
    if (!args.has("png")) return 0;
  }
  if (args.has("png")) {
    render_panels_png(panels, v, args.get("png"));
    std::cout << "wrote " << args.get("png") << "\n";
    return 0;
  }
  show_panels(panels, v);
  return 0;
}

}  // namespace posekit::cli
