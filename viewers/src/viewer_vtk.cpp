// The VTK half of the viewers (the "render" plugin, see posekit/core/plugin.h): off-screen figures and
// interactive windows.
#include "posekit/viewers/viewer.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <vtkActor.h>
#include <vtkCallbackCommand.h>
#include <vtkCamera.h>
#include <vtkCellArray.h>
#include <vtkCellPicker.h>
#include <vtkColorTransferFunction.h>
#include <vtkCommand.h>
#include <vtkFloatArray.h>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkLightKit.h>
#include <vtkLookupTable.h>
#include <vtkNew.h>
#include <vtkObjectFactory.h>
#include <vtkPNGWriter.h>
#include <vtkPointData.h>
#include <vtkPoints.h>
#include <vtkPolyData.h>
#include <vtkPolyDataMapper.h>
#include <vtkPolyDataNormals.h>
#include <vtkProperty.h>
#include <vtkRenderWindow.h>
#include <vtkRenderWindowInteractor.h>
#include <vtkRenderer.h>
#include <vtkScalarBarActor.h>
#include <vtkSmartPointer.h>
#include <vtkTextActor.h>
#include <vtkTextProperty.h>
#include <vtkUnsignedCharArray.h>
#include <vtkVariant.h>
#include <vtkWindowToImageFilter.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/plugin.h"
#include "posekit/core/sanitizer.h"
#include "posekit/io/atomic_file.h"

#if POSEKIT_ADDRESS_SANITIZER
#include <sanitizer/lsan_interface.h>
#endif

namespace posekit {
namespace {

/// The OpenGL driver (Mesa) keeps allocations it frees only when it is unloaded, where
/// LeakSanitizer cannot name it: allocations made while rendering are left out of leak checks.
struct RenderingLeakScope {
#if POSEKIT_ADDRESS_SANITIZER
  RenderingLeakScope() { __lsan_disable(); }
  ~RenderingLeakScope() { __lsan_enable(); }
#endif
};

}  // namespace

namespace {

/// A display for VTK's X render window: the user's DISPLAY, or a private Xvfb started once.
class Display {
 public:
  static void require(bool allow_virtual) {
    static Display instance;
    if (const char* d = std::getenv("DISPLAY"); d && *d) return;
    if (!allow_virtual) throw IoError("no display (DISPLAY is unset): the interactive viewer needs one; use --png for off-screen images");
    instance.start();
  }
  ~Display() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      ::waitpid(pid_, nullptr, 0);
    }
  }

 private:
  void start() {
    if (pid_ > 0) return;
    int fds[2];
    if (::pipe(fds) != 0) throw IoError("cannot start Xvfb: pipe failed");
    const pid_t pid = ::fork();
    if (pid < 0) throw IoError("cannot start Xvfb: fork failed");
    if (pid == 0) {
      ::close(fds[0]);
      const int devnull = ::open("/dev/null", O_WRONLY);
      if (devnull >= 0) {
        ::dup2(devnull, 1);
        ::dup2(devnull, 2);
      }
      const std::string fd = std::to_string(fds[1]);
      // -noreset: by default the server resets when its last client disconnects, and a render that
      // connects during the reset fails (VTK then aborts).
      ::execlp("Xvfb", "Xvfb", "-displayfd", fd.c_str(), "-screen", "0", "3000x2000x24", "-nolisten", "tcp", "-noreset",
               static_cast<char*>(nullptr));
      ::_exit(127);
    }
    ::close(fds[1]);
    std::string number;
    char c;
    while (::read(fds[0], &c, 1) == 1 && c != '\n') number += c;
    ::close(fds[0]);
    if (number.empty()) {
      ::waitpid(pid, nullptr, 0);
      throw IoError(
          "no display (DISPLAY is unset) and Xvfb could not be started: install xvfb (apt-get install xvfb) "
          "or run under xvfb-run");
    }
    pid_ = pid;
    ::setenv("DISPLAY", (":" + number).c_str(), 1);
  }
  pid_t pid_ = -1;
};

vtkSmartPointer<vtkColorTransferFunction> make_colours(ColourMapKind kind, double lo, double hi) {
  auto f = vtkSmartPointer<vtkColorTransferFunction>::New();
  f->SetColorSpaceToRGB();
  for (const ColourStop& stop : colour_map_stops(kind)) f->AddRGBPoint(lo + stop.at * (hi - lo), stop.rgb.x(), stop.rgb.y(), stop.rgb.z());
  return f;
}

vtkSmartPointer<vtkLookupTable> make_lookup(const ColourMap& map, double lo, double hi) {
  auto table = vtkSmartPointer<vtkLookupTable>::New();
  if (map.kind == ColourMapKind::kCategorical) {
    table->IndexedLookupOn();
    table->SetNumberOfTableValues(static_cast<vtkIdType>(map.categories.size()));
    for (size_t i = 0; i < map.categories.size(); ++i) {
      const Eigen::Vector3d c = category_colour(i);
      table->SetTableValue(static_cast<vtkIdType>(i), c.x(), c.y(), c.z(), 1.0);
      table->SetAnnotation(vtkVariant(static_cast<double>(i)), map.categories[i]);
    }
    table->SetNanColor(0.6, 0.6, 0.6, 1.0);
    table->Build();
    return table;
  }
  const auto colours = make_colours(map.kind, lo, hi);
  table->SetNumberOfTableValues(256);
  table->SetRange(lo, hi);
  for (int i = 0; i < 256; ++i) {
    double rgb[3];
    colours->GetColor(lo + (hi - lo) * i / 255.0, rgb);
    table->SetTableValue(i, rgb[0], rgb[1], rgb[2], 1.0);
  }
  table->SetNanColor(0.6, 0.6, 0.6, 1.0);
  table->UseAboveRangeColorOn();
  table->SetAboveRangeColor(0.55, 0.0, 0.0, 1.0);
  table->UseBelowRangeColorOn();
  double below[3];
  colours->GetColor(lo, below);
  table->SetBelowRangeColor(below[0], below[1], below[2], 1.0);
  table->Build();
  return table;
}

vtkSmartPointer<vtkPolyData> to_polydata(const TriangleMesh& mesh, const std::string& scalar) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  points->SetNumberOfPoints(mesh.V.rows());
  for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) points->SetPoint(i, mesh.V(i, 0), mesh.V(i, 1), mesh.V(i, 2));
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const vtkIdType ids[3] = {mesh.F(f, 0), mesh.F(f, 1), mesh.F(f, 2)};
    cells->InsertNextCell(3, ids);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetPolys(cells);
  if (!scalar.empty()) {
    const Eigen::VectorXd& s = mesh.vertex_scalars.at(scalar);
    auto array = vtkSmartPointer<vtkFloatArray>::New();
    array->SetName(scalar.c_str());
    array->SetNumberOfValues(s.size());
    for (Eigen::Index i = 0; i < s.size(); ++i) array->SetValue(i, static_cast<float>(s[i]));
    poly->GetPointData()->SetScalars(array);
  }
  return poly;
}

vtkSmartPointer<vtkPolyData> cloud_polydata(const PointCloud& cloud, size_t max_points) {
  const Eigen::Index n = cloud.P.rows();
  const Eigen::Index step = std::max<Eigen::Index>(1, n / static_cast<Eigen::Index>(std::max<size_t>(max_points, 1)));
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto verts = vtkSmartPointer<vtkCellArray>::New();
  for (Eigen::Index i = 0; i < n; i += step) {
    const vtkIdType id = points->InsertNextPoint(cloud.P(i, 0), cloud.P(i, 1), cloud.P(i, 2));
    verts->InsertNextCell(1, &id);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetVerts(verts);
  return poly;
}

/// The box of the points without their outliers (the 1st to 99th percentile on each axis).
void robust_bounds(const Eigen::MatrixXd& P, double bounds[6]) {
  const auto [lo, hi] = robust_box(P);
  for (int k = 0; k < 3; ++k) bounds[2 * k] = lo[k], bounds[2 * k + 1] = hi[k];
}

/// Frames the mesh (not the overlay, whose outliers may lie far away) from a preset direction; a
/// panel of points alone (a scan) by their box without outliers.
void place_camera(vtkRenderer* renderer, const ViewPanel& panel, vtkActor* mesh, CameraPreset preset, double aspect) {
  double bounds[6];
  if (mesh) mesh->GetBounds(bounds);
  else robust_bounds(panel.overlay.P, bounds);
  renderer->ResetCamera(bounds);
  vtkCamera* camera = renderer->GetActiveCamera();
  double focal[3];
  camera->GetFocalPoint(focal);
  const double distance = camera->GetDistance();
  double dir[3] = {0, 0, 1};  // the subject faces +Z
  if (preset == CameraPreset::kSide) dir[0] = 1, dir[2] = 0;
  if (preset == CameraPreset::kBack) dir[2] = -1;
  camera->SetPosition(focal[0] + distance * dir[0], focal[1] + distance * dir[1], focal[2] + distance * dir[2]);
  camera->SetViewUp(0, 1, 0);
  renderer->ResetCamera(bounds);
  // ResetCamera fits the bounding sphere vertically; narrow panels need less zoom to keep the arms.
  camera->Zoom(1.15 * std::min(1.0, aspect / 0.75));
}

/// Everything VTK needs for a figure; kept alive while the window lives.
struct Scene {
  vtkSmartPointer<vtkRenderWindow> window;
  std::vector<vtkSmartPointer<vtkRenderer>> renderers;
  std::vector<vtkSmartPointer<vtkActor>> mesh_actors, overlay_actors;
  std::vector<const ViewPanel*> panels;
  double aspect = 1;
};

/// A panel's mesh, coloured by its scalar through the lookup table or plain skin; null for a panel
/// of points alone.
vtkSmartPointer<vtkActor> mesh_actor(const ViewPanel& p, const ColourMap& map, vtkLookupTable* lookup, double lo, double hi) {
  if (p.mesh.F.rows() == 0) return nullptr;
  vtkNew<vtkPolyDataNormals> normals;
  normals->SetInputData(to_polydata(p.mesh, p.scalar));
  normals->SplittingOff();
  normals->ConsistencyOff();
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputConnection(normals->GetOutputPort());
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  if (p.scalar.empty()) {
    mapper->ScalarVisibilityOff();
    actor->GetProperty()->SetColor(0.87, 0.74, 0.64);
  } else {
    mapper->SetLookupTable(lookup);
    mapper->SetScalarRange(lo, hi);
    mapper->SetScalarModeToUsePointData();
    mapper->ScalarVisibilityOn();
    // Labels are not interpolated (half-way between two parts is no part).
    mapper->SetInterpolateScalarsBeforeMapping(map.kind != ColourMapKind::kCategorical);
    mapper->SetColorModeToMapScalars();
  }
  actor->GetProperty()->SetSpecular(0.15);
  return actor;
}

/// Closed polylines (tape paths), dark red, over the surface.
vtkSmartPointer<vtkActor> lines_actor(const std::vector<Eigen::MatrixXd>& lines) {
  auto points = vtkSmartPointer<vtkPoints>::New();
  auto cells = vtkSmartPointer<vtkCellArray>::New();
  for (const Eigen::MatrixXd& line : lines) {
    if (line.rows() < 2) continue;
    cells->InsertNextCell(static_cast<int>(line.rows()) + 1);
    const vtkIdType first = points->GetNumberOfPoints();
    for (Eigen::Index k = 0; k < line.rows(); ++k) cells->InsertCellPoint(points->InsertNextPoint(line(k, 0), line(k, 1), line(k, 2)));
    cells->InsertCellPoint(first);
  }
  auto poly = vtkSmartPointer<vtkPolyData>::New();
  poly->SetPoints(points);
  poly->SetLines(cells);
  auto mapper = vtkSmartPointer<vtkPolyDataMapper>::New();
  mapper->SetInputData(poly);
  auto actor = vtkSmartPointer<vtkActor>::New();
  actor->SetMapper(mapper);
  actor->GetProperty()->SetColor(0.65, 0.05, 0.1);
  actor->GetProperty()->SetLineWidth(2.5);
  actor->GetProperty()->LightingOff();
  return actor;
}

Scene build_scene(const std::vector<ViewPanel>& panels, const ViewOptions& o) {
  if (panels.empty()) throw InvalidInput("viewer: nothing to show");
  std::vector<const Eigen::VectorXd*> values;
  for (const auto& p : panels) {
    if ((p.mesh.V.rows() == 0 || p.mesh.F.rows() == 0) && p.overlay.size() == 0)
      throw InvalidInput("viewer: panel '" + p.caption + "' has neither a mesh nor points");
    if (!p.mesh.V.allFinite()) throw InvalidInput("viewer: panel '" + p.caption + "' has a non-finite vertex");
    if (p.scalar.empty()) continue;
    const auto it = p.mesh.vertex_scalars.find(p.scalar);
    if (it == p.mesh.vertex_scalars.end()) {
      std::string names;
      for (const auto& [name, v] : p.mesh.vertex_scalars) names += (names.empty() ? "" : ", ") + name;
      throw InvalidInput("viewer: the mesh has no vertex scalar '" + p.scalar + "' (it has: " + (names.empty() ? "none" : names) + ")");
    }
    values.push_back(&it->second);
  }
  const auto [lo, hi] = colour_range(o.colour_map, values);
  const auto lookup = make_lookup(o.colour_map, lo, hi);
  const bool bar = o.colour_bar && !values.empty();
  const int bar_width = bar ? 200 : 0;
  const int width = o.panel_width * static_cast<int>(panels.size()) + bar_width;

  Scene scene;
  scene.aspect = static_cast<double>(o.panel_width) / o.panel_height;
  scene.window = vtkSmartPointer<vtkRenderWindow>::New();
  scene.window->SetSize(width, o.panel_height);
  scene.window->SetWindowName(o.title.empty() ? "posekit" : o.title.c_str());
  for (size_t i = 0; i < panels.size(); ++i) {
    const ViewPanel& p = panels[i];
    auto renderer = vtkSmartPointer<vtkRenderer>::New();
    renderer->SetBackground(1, 1, 1);
    // A key light above and in front, fill, back and head lights (vtkLightKit) instead of VTK's one
    // headlight, under which every surface facing up or down (thighs in a squat, forearms and feet
    // towards the camera) came out dark.
    vtkNew<vtkLightKit> lights;
    lights->SetKeyLightIntensity(0.95);
    lights->AddLightsToRenderer(renderer);
    const double x0 = static_cast<double>(i) * o.panel_width / width, x1 = static_cast<double>(i + 1) * o.panel_width / width;
    renderer->SetViewport(x0, 0, x1, 1);
    const vtkSmartPointer<vtkActor> actor = mesh_actor(p, o.colour_map, lookup, lo, hi);  // none for points alone
    if (actor) renderer->AddActor(actor);
    scene.mesh_actors.push_back(actor);
    if (p.overlay.size() > 0) {
      auto cmapper = vtkSmartPointer<vtkPolyDataMapper>::New();
      cmapper->SetInputData(cloud_polydata(p.overlay, 80000));
      auto cactor = vtkSmartPointer<vtkActor>::New();
      cactor->SetMapper(cmapper);
      // Over a body, light and fine, so that the body stays readable; alone, darker.
      if (actor) cactor->GetProperty()->SetColor(0.45, 0.47, 0.55);
      else cactor->GetProperty()->SetColor(0.2, 0.22, 0.3);
      cactor->GetProperty()->SetPointSize(static_cast<float>(o.point_size));
      renderer->AddActor(cactor);
      scene.overlay_actors.push_back(cactor);
    } else {
      scene.overlay_actors.push_back(nullptr);
    }
    if (!p.lines.empty()) renderer->AddActor(lines_actor(p.lines));
    if (!p.caption.empty()) {
      auto text = vtkSmartPointer<vtkTextActor>::New();
      text->SetInput(p.caption.c_str());
      text->GetTextProperty()->SetFontSize(std::clamp(o.panel_width / 11, 10, 18));  // narrow panels: smaller captions
      text->GetTextProperty()->SetColor(0.1, 0.1, 0.1);
      text->GetTextProperty()->SetJustificationToCentered();
      text->GetTextProperty()->SetVerticalJustificationToTop();
      text->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
      text->GetPositionCoordinate()->SetValue(0.5, 0.97);
      renderer->AddActor2D(text);
    }
    place_camera(renderer, p, actor, p.camera, static_cast<double>(o.panel_width) / o.panel_height);
    scene.window->AddRenderer(renderer);
    scene.renderers.push_back(renderer);
    scene.panels.push_back(&p);
  }
  if (bar) {
    auto renderer = vtkSmartPointer<vtkRenderer>::New();
    renderer->SetBackground(1, 1, 1);
    renderer->SetViewport(static_cast<double>(width - bar_width) / width, 0, 1, 1);
    auto scalar_bar = vtkSmartPointer<vtkScalarBarActor>::New();
    scalar_bar->SetLookupTable(lookup);
    scalar_bar->SetTitle(o.colour_map.title.c_str());
    scalar_bar->SetNumberOfLabels(5);
    scalar_bar->SetLabelFormat("%.1f");
    scalar_bar->GetTitleTextProperty()->SetColor(0.1, 0.1, 0.1);
    scalar_bar->GetTitleTextProperty()->SetFontSize(15);
    scalar_bar->GetTitleTextProperty()->ItalicOff();
    scalar_bar->GetTitleTextProperty()->ShadowOff();
    scalar_bar->GetLabelTextProperty()->ItalicOff();
    scalar_bar->GetLabelTextProperty()->ShadowOff();
    scalar_bar->GetLabelTextProperty()->SetColor(0.1, 0.1, 0.1);
    scalar_bar->GetLabelTextProperty()->SetFontSize(14);
    scalar_bar->UnconstrainedFontSizeOn();
    scalar_bar->GetPositionCoordinate()->SetCoordinateSystemToNormalizedViewport();
    scalar_bar->GetPositionCoordinate()->SetValue(0.08, 0.1);
    scalar_bar->SetWidth(0.84);
    scalar_bar->SetHeight(0.8);
    scalar_bar->SetBarRatio(0.3);
    if (o.colour_map.kind == ColourMapKind::kCategorical) {  // a legend: a swatch and a name per value
      scalar_bar->DrawAnnotationsOn();
      scalar_bar->SetTextPositionToPrecedeScalarBar();  // the names go on the other side: right of the swatches
      scalar_bar->GetPositionCoordinate()->SetValue(0.04, 0.06);
      scalar_bar->SetWidth(0.36);
      scalar_bar->SetHeight(0.86);
      scalar_bar->SetBarRatio(0.5);
      scalar_bar->SetAnnotationLeaderPadding(4);
      scalar_bar->GetAnnotationTextProperty()->SetColor(0.1, 0.1, 0.1);
      scalar_bar->GetAnnotationTextProperty()->SetFontSize(13);
      scalar_bar->GetAnnotationTextProperty()->ItalicOff();
      scalar_bar->GetAnnotationTextProperty()->ShadowOff();
    }
    renderer->AddActor2D(scalar_bar);
    scene.window->AddRenderer(renderer);
  }
  return scene;
}

/// Click to read a vertex's value, 's' toggles overlays, 'c' cycles the camera presets.
class PickingStyle : public vtkInteractorStyleTrackballCamera {
 public:
  static PickingStyle* New();
  vtkTypeMacro(PickingStyle, vtkInteractorStyleTrackballCamera);
  Scene* scene = nullptr;
  int preset = 0;
  ViewerState* state = nullptr;

  void OnLeftButtonDown() override {
    int* pos = this->Interactor->GetEventPosition();
    // The surface the ray meets first, then that triangle's corner nearest the hit: a point picker
    // takes any vertex near the ray, the back of the body as readily as the front.
    for (size_t i = 0; i < scene->renderers.size(); ++i) {
      vtkNew<vtkCellPicker> picker;
      picker->SetTolerance(0.0005);
      picker->PickFromListOn();
      if (!scene->mesh_actors[i]) continue;  // points alone
      picker->AddPickList(scene->mesh_actors[i]);
      if (!picker->Pick(pos[0], pos[1], 0, scene->renderers[i]) || picker->GetPointId() < 0) continue;
      const ViewPanel& p = *scene->panels[i];
      const vtkIdType id = picker->GetPointId();
      if (id >= p.mesh.V.rows()) break;
      std::ostringstream line;
      line << "panel " << i << (p.caption.empty() ? "" : " (" + p.caption + ")") << " vertex " << id << " at (" << p.mesh.V(id, 0) << ", "
           << p.mesh.V(id, 1) << ", " << p.mesh.V(id, 2) << ") m";
      if (!p.scalar.empty()) line << ": " << p.scalar << " = " << p.mesh.vertex_scalars.at(p.scalar)[id];
      std::cout << line.str() << std::endl;
      state->picks.push_back(line.str());
      break;
    }
    vtkInteractorStyleTrackballCamera::OnLeftButtonDown();
  }
  void OnChar() override {
    const char key = this->Interactor->GetKeyCode();
    if (key == 's') {
      state->overlays_visible = !state->overlays_visible;
      for (auto& a : scene->overlay_actors)
        if (a) a->SetVisibility(state->overlays_visible);
      this->Interactor->Render();
      return;
    }
    if (key == 'c') {
      preset = (preset + 1) % 3;
      state->camera = static_cast<CameraPreset>(preset);
      for (size_t i = 0; i < scene->renderers.size(); ++i)
        place_camera(scene->renderers[i], *scene->panels[i], scene->mesh_actors[i], static_cast<CameraPreset>(preset), scene->aspect);
      this->Interactor->Render();
      return;
    }
    vtkInteractorStyleTrackballCamera::OnChar();
  }
};
vtkStandardNewMacro(PickingStyle);

}  // namespace

void render_panels_png_vtk(const std::vector<ViewPanel>& panels, const ViewOptions& options, const std::string& png_path) {
  [[maybe_unused]] const RenderingLeakScope leak_scope;
  Display::require(true);
  Scene scene = build_scene(panels, options);
  scene.window->SetOffScreenRendering(1);
  scene.window->Render();
  vtkNew<vtkWindowToImageFilter> grab;
  grab->SetInput(scene.window);
  grab->SetInputBufferTypeToRGB();
  grab->ReadFrontBufferOff();
  grab->Update();
  vtkNew<vtkPNGWriter> writer;
  writer->SetInputConnection(grab->GetOutputPort());
  writer->WriteToMemoryOn();
  writer->Write();
  vtkUnsignedCharArray* bytes = writer->GetResult();
  if (!bytes || bytes->GetNumberOfTuples() == 0) throw IoError(png_path + ": VTK produced no image");
  const auto* data = reinterpret_cast<const char*>(bytes->GetPointer(0));
  const size_t size = static_cast<size_t>(bytes->GetNumberOfTuples() * bytes->GetNumberOfComponents());
  write_file_atomically(png_path, [&](std::ostream& out) { out.write(data, static_cast<std::streamsize>(size)); });
}

ViewerState show_panels_vtk(const std::vector<ViewPanel>& panels, const ViewOptions& options, const std::vector<ViewerEvent>* script) {
  [[maybe_unused]] const RenderingLeakScope leak_scope;
  Display::require(script != nullptr);
  Scene scene = build_scene(panels, options);
  ViewerState state;
  vtkNew<vtkRenderWindowInteractor> interactor;
  interactor->SetRenderWindow(scene.window);
  vtkNew<PickingStyle> style;
  style->scene = &scene;
  style->state = &state;
  interactor->SetInteractorStyle(style);
  if (!script) {
    std::cout << "posekit view: drag to rotate, wheel to zoom, click a vertex to read it, 's' scan on/off, "
                 "'c' front/side/back, 'q' quit"
              << std::endl;
    scene.window->Render();
    interactor->Start();
    return state;
  }
  interactor->Initialize();
  scene.window->Render();
  const int* size = scene.window->GetSize();
  for (const ViewerEvent& e : *script) {
    const int x = static_cast<int>(std::lround(e.x * (size[0] - 1))), y = static_cast<int>(std::lround(e.y * (size[1] - 1)));
    if (e.kind == ViewerEvent::Kind::kClick) {
      interactor->SetEventInformation(x, y, 0, 0, 0, 0, nullptr);
      interactor->InvokeEvent(vtkCommand::LeftButtonPressEvent, nullptr);
      interactor->InvokeEvent(vtkCommand::LeftButtonReleaseEvent, nullptr);
    } else {
      const char key[2] = {e.key, 0};
      interactor->SetEventInformation(x, y, 0, 0, e.key, 1, key);
      interactor->InvokeEvent(vtkCommand::KeyPressEvent, nullptr);
      interactor->InvokeEvent(vtkCommand::CharEvent, nullptr);
      interactor->InvokeEvent(vtkCommand::KeyReleaseEvent, nullptr);
    }
    scene.window->Render();
  }
  scene.window->Finalize();
  return state;
}

}  // namespace posekit

POSEKIT_PLUGIN_EXPORT void posekit_render_panels_png(const std::vector<posekit::ViewPanel>& panels, const posekit::ViewOptions& options,
                                                     const std::string& png_path) {
  posekit::render_panels_png_vtk(panels, options, png_path);
}

POSEKIT_PLUGIN_EXPORT void posekit_show_panels(const std::vector<posekit::ViewPanel>& panels, const posekit::ViewOptions& options,
                                               const std::vector<posekit::ViewerEvent>* script, posekit::ViewerState* state) {
  *state = posekit::show_panels_vtk(panels, options, script);
}
