#include "posekit/viewers/web_viewer.h"

#include <unistd.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>

#include "posekit/core/colour_map.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace fs = std::filesystem;

namespace posekit {
namespace {

// The viewer: every figure a page's data scripts pushed onto window.posekitFigures is drawn into
// its element when the page has loaded; the mouse turns it (drag) and zooms (wheel). What went
// wrong is written onto the page (body's data-posekit-errors), and data-posekit-viewers says how
// many figures were drawn, for a headless browser to read.
constexpr const char* kViewerScript = R"JS((function () {
  'use strict';
  const errors = [];
  function note(message) {
    errors.push(String(message));
    if (document.body) document.body.dataset.posekitErrors = errors.join(' | ');
  }
  window.addEventListener('error', e => note(e.message));
  const consoleError = console.error;
  console.error = function () { note(Array.from(arguments).join(' ')); consoleError.apply(console, arguments); };
  function bytes(base64) {
    const s = atob(base64), a = new Uint8Array(s.length);
    for (let i = 0; i < s.length; ++i) a[i] = s.charCodeAt(i);
    return a;
  }
  const floats = base64 => new Float32Array(bytes(base64).buffer);
  function show(figure, holder) {
    const canvas = holder.querySelector('canvas');
    const renderer = new THREE.WebGLRenderer({canvas: canvas, antialias: true, preserveDrawingBuffer: true});
    const width = holder.clientWidth || 900, height = Math.round(width * figure.aspect);
    renderer.setPixelRatio(window.devicePixelRatio || 1);
    renderer.setSize(width, height, false);
    renderer.setClearColor(0xffffff);
    const scene = new THREE.Scene(), group = new THREE.Group(), geometries = [];
    scene.add(group);
    for (const p of figure.panels) {
      if (p.points) {  // light and fine over a body, darker alone (a scan)
        const pg = new THREE.BufferGeometry();
        pg.setAttribute('position', new THREE.BufferAttribute(floats(p.points), 3));
        group.add(new THREE.Points(pg, new THREE.PointsMaterial(p.positions ? {color: 0x737888, size: 0.0025, transparent: true, opacity: 0.5}
                                                                              : {color: 0x333a4c, size: 0.003})));
      }
      for (const line of p.lines || []) {  // closed polylines (tape paths), dark red
        const lg = new THREE.BufferGeometry();
        lg.setAttribute('position', new THREE.BufferAttribute(floats(line), 3));
        group.add(new THREE.LineLoop(lg, new THREE.LineBasicMaterial({color: 0xa60d1a})));
      }
      if (!p.positions) { geometries.push(null); continue; }
      const g = new THREE.BufferGeometry();
      g.setAttribute('position', new THREE.BufferAttribute(floats(p.positions), 3));
      g.setAttribute('color', new THREE.BufferAttribute(bytes(p.colours), 3, true));
      // Triangles as 16- or 32-bit indices, or those of an earlier panel of the same topology.
      g.setIndex(p.indices === undefined ? geometries[p.indicesOf].index
                                         : new THREE.BufferAttribute(p.wide ? new Uint32Array(bytes(p.indices).buffer)
                                                                             : new Uint16Array(bytes(p.indices).buffer), 1));
      geometries.push(g);
      g.computeVertexNormals();
      group.add(new THREE.Mesh(g, new THREE.MeshLambertMaterial({vertexColors: true, side: THREE.DoubleSide})));
    }
    scene.add(new THREE.HemisphereLight(0xffffff, 0x707070, 0.55));
    const key = new THREE.DirectionalLight(0xffffff, 0.6), fill = new THREE.DirectionalLight(0xffffff, 0.2);
    fill.position.set(-1, 0.3, -1);
    scene.add(key, fill);
    const box = new THREE.Box3().setFromObject(group), size = box.getSize(new THREE.Vector3());
    group.position.sub(box.getCenter(new THREE.Vector3()));
    const camera = new THREE.PerspectiveCamera(30, width / height, 0.01, 100);
    let distance = 1.08 * Math.max(size.y, size.x * height / width) / (2 * Math.tan(Math.PI / 12)) + size.z / 2;
    let yaw = 0, pitch = 0, drag = null;
    function draw() {
      camera.position.set(distance * Math.sin(yaw) * Math.cos(pitch), distance * Math.sin(pitch), distance * Math.cos(yaw) * Math.cos(pitch));
      camera.lookAt(0, 0, 0);
      key.position.copy(camera.position).add(new THREE.Vector3(0, distance / 2, 0));
      renderer.render(scene, camera);
    }
    canvas.addEventListener('pointerdown', e => { drag = {x: e.clientX, y: e.clientY, yaw: yaw, pitch: pitch}; canvas.setPointerCapture(e.pointerId); });
    canvas.addEventListener('pointermove', e => {
      if (!drag) return;
      yaw = drag.yaw - (e.clientX - drag.x) * 0.01;
      pitch = Math.max(-1.4, Math.min(1.4, drag.pitch + (e.clientY - drag.y) * 0.01));
      draw();
    });
    canvas.addEventListener('pointerup', () => { drag = null; });
    canvas.addEventListener('wheel', e => { e.preventDefault(); distance *= Math.exp(e.deltaY * 0.001); draw(); }, {passive: false});
    draw();
  }
  window.addEventListener('load', () => {
    let shown = 0;
    if (typeof THREE === 'undefined') note('three.min.js did not load');
    for (const figure of window.posekitFigures || []) {
      const holder = document.querySelector('[data-posekit-figure="' + figure.id + '"]');
      if (!holder) { note('no element for figure ' + figure.id); continue; }
      try { show(figure, holder); ++shown; } catch (e) { note(figure.id + ': ' + e); }
    }
    document.body.dataset.posekitViewers = 'ok ' + shown;
  });
})();
)JS";

std::string base64(const void* data, size_t size) {
  static const char* kDigits = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  const auto* b = static_cast<const unsigned char*>(data);
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  for (size_t i = 0; i < size; i += 3) {
    const std::uint32_t v =
        (std::uint32_t(b[i]) << 16) | (i + 1 < size ? std::uint32_t(b[i + 1]) << 8 : 0u) | (i + 2 < size ? b[i + 2] : 0u);
    out += kDigits[(v >> 18) & 63];
    out += kDigits[(v >> 12) & 63];
    out += i + 1 < size ? kDigits[(v >> 6) & 63] : '=';
    out += i + 2 < size ? kDigits[v & 63] : '=';
  }
  return out;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\', out += c;
    else if (c == '\n') out += "\\n";
    else if (c == '<') out += "\\u003c";  // never "</script>" inside a script
    else if (static_cast<unsigned char>(c) >= 0x20) out += c;
  }
  return out + "\"";
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) out += c == '<' ? "&lt;" : c == '>' ? "&gt;" : c == '&' ? "&amp;" : c == '"' ? "&quot;" : std::string(1, c);
  return out;
}

/// The turn that shows a camera on +Z what the preset shows (the PNG figures: side = the body seen from its right, facing right).
Eigen::Matrix3d preset_turn(CameraPreset preset) {
  const double angle = preset == CameraPreset::kBack ? M_PI : preset == CameraPreset::kSide ? M_PI / 2 : 0.0;
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
}

std::string float_rows(const Eigen::MatrixXd& P, const Eigen::Matrix3d& R, const Eigen::Vector3d& offset, Eigen::Index step) {
  std::vector<float> v;
  v.reserve(static_cast<size_t>(3 * (P.rows() / step + 1)));
  for (Eigen::Index i = 0; i < P.rows(); i += step) {
    const Eigen::Vector3d p = R * P.row(i).transpose() + offset;
    for (int k = 0; k < 3; ++k) v.push_back(static_cast<float>(p[k]));
  }
  return base64(v.data(), v.size() * sizeof(float));
}

/// A panel's triangles: "indicesOf" an earlier panel of the same topology (a figure's bodies mostly
/// share the template's), or its own indices, 16-bit where the vertices allow.
std::string triangles_json(const std::vector<ViewPanel>& panels, size_t i) {
  const Eigen::MatrixXi& F = panels[i].mesh.F;
  for (size_t j = 0; j < i; ++j)
    if (panels[j].mesh.F.rows() == F.rows() && panels[j].mesh.F == F) return "\"indicesOf\": " + std::to_string(j);
  const bool wide = panels[i].mesh.V.rows() > 65535;
  std::vector<std::uint16_t> narrow;
  std::vector<std::uint32_t> full;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      if (wide) full.push_back(static_cast<std::uint32_t>(F(f, k)));
      else narrow.push_back(static_cast<std::uint16_t>(F(f, k)));
    }
  return std::string("\"wide\": ") + (wide ? "true" : "false") + ", \"indices\": \"" +
         (wide ? base64(full.data(), full.size() * 4) : base64(narrow.data(), narrow.size() * 2)) + "\"";
}

/// The box a panel's body takes (of its points alone, without their outliers, when it has no mesh).
std::pair<Eigen::Vector3d, Eigen::Vector3d> panel_box(const ViewPanel& p) {
  if (p.mesh.F.rows() > 0) return {p.mesh.V.colwise().minCoeff().transpose(), p.mesh.V.colwise().maxCoeff().transpose()};
  return robust_box(p.overlay.P);
}

/// The panel's vertex colours as the PNG figures have them.
RowMatrixX3u8 panel_colours(const ViewPanel& panel, const ColourMap& map, double lo, double hi) {
  const Eigen::Index n = panel.mesh.V.rows();
  if (panel.scalar.empty())
    return RowMatrixX3u8::NullaryExpr(n, 3, [](Eigen::Index, Eigen::Index k) { return std::uint8_t(k == 0 ? 222 : k == 1 ? 190 : 166); });
  const auto it = panel.mesh.vertex_scalars.find(panel.scalar);
  if (it == panel.mesh.vertex_scalars.end()) throw InvalidInput("web figure: the mesh has no vertex scalar '" + panel.scalar + "'");
  if (map.kind != ColourMapKind::kCategorical) return heatmap_colours(it->second, map.kind, lo, hi);
  RowMatrixX3u8 c(n, 3);
  for (Eigen::Index v = 0; v < n; ++v) {
    const double x = it->second[v];
    const Eigen::Vector3d rgb =
        std::isfinite(x) && x >= 0 ? category_colour(static_cast<size_t>(std::lround(x))) : Eigen::Vector3d(0.5, 0.5, 0.5);
    for (int k = 0; k < 3; ++k) c(v, k) = static_cast<std::uint8_t>(std::lround(255 * rgb[k]));
  }
  return c;
}

/// The colour bar (or legend) under a figure, in HTML.
std::string colour_bar_html(const ColourMap& map, double lo, double hi) {
  std::ostringstream h;
  if (map.kind == ColourMapKind::kCategorical) {
    h << "<div class=\"posekit-legend\">";
    for (size_t i = 0; i < map.categories.size(); ++i) {
      const Eigen::Vector3d c = category_colour(i);
      h << "<span><i style=\"background:rgb(" << std::lround(255 * c.x()) << "," << std::lround(255 * c.y()) << ","
        << std::lround(255 * c.z()) << ")\"></i>" << html_escape(map.categories[i]) << "</span> ";
    }
    return h.str() + "</div>";
  }
  h << "<div class=\"posekit-bar\"><span>" << std::setprecision(3) << lo << "</span><b style=\"background:linear-gradient(to right";
  for (const ColourStop& s : colour_map_stops(map.kind))
    h << ",rgb(" << std::lround(255 * s.rgb.x()) << "," << std::lround(255 * s.rgb.y()) << "," << std::lround(255 * s.rgb.z()) << ") "
      << 100 * s.at << "%";
  h << ")\"></b><span>" << hi << "</span> " << html_escape(map.title) << "</div>";
  return h.str();
}

}  // namespace

std::string web_viewer_head() {
  return "<style>.posekit-3d{margin:.5em 0}.posekit-3d canvas{width:100%;display:block;border:1px solid #ddd;cursor:grab}"
         ".posekit-captions{display:flex;justify-content:space-around;font-size:90%}"
         ".posekit-bar{display:flex;align-items:center;gap:.5em;font-size:90%;margin-top:.3em}"
         ".posekit-bar b{display:inline-block;width:240px;height:12px}.posekit-legend i{display:inline-block;width:10px;height:10px;"
         "margin-right:3px}</style>\n<script src=\"three.min.js\"></script><script src=\"posekit_viewer.js\"></script>\n";
}

std::string find_three_js() {
  std::vector<fs::path> places;
  if (const char* env = std::getenv("POSEKIT_THREE_JS")) places.emplace_back(env);
  places.emplace_back(fs::path(POSEKIT_BUILD_SHARE_DIR) / "three.min.js");
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) places.push_back(exe.parent_path().parent_path() / "share" / "posekit" / "three.min.js");
  places.emplace_back(fs::path(POSEKIT_INSTALL_SHARE_DIR) / "three.min.js");
  for (const fs::path& p : places)
    if (fs::is_regular_file(p, ec)) return p.string();
  return "";
}

void write_web_viewer_assets(const std::string& dir) {
  const std::string three = find_three_js();
  if (three.empty())
    throw IoError("interactive figures need three.min.js, fetched from npm when posekit is built (none in $POSEKIT_THREE_JS, " +
                  std::string(POSEKIT_BUILD_SHARE_DIR) + " or " + POSEKIT_INSTALL_SHARE_DIR + "): build posekit where npm works");
  fs::create_directories(dir);
  std::ifstream in(three, std::ios::binary);
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  write_file_atomically((fs::path(dir) / "three.min.js").string(), [&](std::ostream& out) { out << bytes; }, false);
  const fs::path licence = fs::path(three).parent_path() / "three.LICENSE";
  std::error_code ec;
  if (fs::is_regular_file(licence, ec)) {
    std::ifstream l(licence, std::ios::binary);
    const std::string text((std::istreambuf_iterator<char>(l)), std::istreambuf_iterator<char>());
    write_file_atomically((fs::path(dir) / "three.LICENSE").string(), [&](std::ostream& out) { out << text; }, false);
  }
  write_file_atomically((fs::path(dir) / "posekit_viewer.js").string(), [&](std::ostream& out) { out << kViewerScript; }, false);
}

std::string write_web_figure(const std::string& dir, const std::string& id, const std::vector<ViewPanel>& panels,
                             const ViewOptions& options) {
  if (panels.empty()) throw InvalidInput("web figure " + id + ": no panels");
  std::vector<const Eigen::VectorXd*> values;
  for (const ViewPanel& p : panels) {
    if ((p.mesh.V.rows() == 0 || p.mesh.F.rows() == 0) && p.overlay.size() == 0)
      throw InvalidInput("web figure " + id + ": an empty panel");
    const auto it = p.mesh.vertex_scalars.find(p.scalar);
    if (!p.scalar.empty() && it != p.mesh.vertex_scalars.end()) values.push_back(&it->second);
  }
  const auto [lo, hi] = colour_range(options.colour_map, values);
  // Panels side by side, a body's width and a half apart, each turned to its preset's side.
  double spacing = 0;
  for (const ViewPanel& p : panels) {
    const auto [lo_corner, hi_corner] = panel_box(p);
    spacing = std::max(spacing, 1.5 * (hi_corner - lo_corner).maxCoeff() / 2);
  }
  std::ostringstream js;
  js << "(window.posekitFigures = window.posekitFigures || []).push({\"id\": " << json_string(id)
     << ", \"aspect\": " << static_cast<double>(options.panel_height) / (options.panel_width * static_cast<double>(panels.size()))
     << ", \"panels\": [";
  for (size_t i = 0; i < panels.size(); ++i) {
    const ViewPanel& p = panels[i];
    const Eigen::Matrix3d R = preset_turn(p.camera);
    const auto [lo_corner, hi_corner] = panel_box(p);
    const Eigen::Vector3d centre = 0.5 * (lo_corner + hi_corner);
    const Eigen::Vector3d offset = Eigen::Vector3d(spacing * static_cast<double>(i), 0, 0) - R * Eigen::Vector3d(centre.x(), 0, centre.z());
    js << (i ? ", " : "") << "{\"caption\": " << json_string(p.caption);
    if (p.mesh.F.rows() > 0) {
      const Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3, Eigen::RowMajor> rgb = panel_colours(p, options.colour_map, lo, hi);
      js << ", \"positions\": \"" << float_rows(p.mesh.V, R, offset, 1) << "\", \"colours\": \""
         << base64(rgb.data(), static_cast<size_t>(rgb.size())) << "\", " << triangles_json(panels, i);
    }
    if (!p.lines.empty()) {
      js << ", \"lines\": [";
      for (size_t k = 0; k < p.lines.size(); ++k) js << (k ? ", " : "") << "\"" << float_rows(p.lines[k], R, offset, 1) << "\"";
      js << "]";
    }
    if (p.overlay.size() > 0)
      js << ", \"points\": \"" << float_rows(p.overlay.P, R, offset, std::max<Eigen::Index>(1, (p.overlay.size() + 59999) / 60000)) << "\"";
    js << "}";
  }
  js << "]});\n";
  write_file_atomically((fs::path(dir) / (id + ".js")).string(), [&](std::ostream& out) { out << js.str(); }, false);
  std::ostringstream h;
  h << "<div class=\"posekit-3d\" data-posekit-figure=\"" << html_escape(id) << "\"><canvas></canvas><div class=\"posekit-captions\">";
  for (const ViewPanel& p : panels) h << "<span>" << html_escape(p.caption) << "</span>";
  h << "</div>";
  if (!values.empty() || options.colour_map.kind == ColourMapKind::kCategorical) h << colour_bar_html(options.colour_map, lo, hi);
  h << "</div>\n<script src=\"" << html_escape(id) << ".js\"></script>\n";
  return h.str();
}

void write_web_page(const std::string& html_path, const std::vector<ViewPanel>& panels, const ViewOptions& options) {
  const fs::path page(html_path);
  const std::string dir = page.parent_path().empty() ? "." : page.parent_path().string();
  write_web_viewer_assets(dir);
  const std::string figure = write_web_figure(dir, page.stem().string() + "_data", panels, options);
  write_file_atomically(html_path, [&](std::ostream& out) {
    out << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>"
        << html_escape(options.title.empty() ? "posekit" : options.title) << "</title>\n"
        << web_viewer_head() << "</head>\n<body>\n<h1>" << html_escape(options.title.empty() ? "posekit" : options.title)
        << "</h1>\n<p>Drag to turn, wheel to zoom.</p>\n"
        << figure << "</body></html>\n";
  });
}

}  // namespace posekit
