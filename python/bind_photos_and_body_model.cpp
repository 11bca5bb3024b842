// Python: customize() from two photos (paper or model method) and BodyModel (posekit's body model
// fitted to any body), through the library functions `posekit customize` and `--body-model` call.
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <filesystem>
#include <memory>
#include <optional>
#include <string>

#include "binding_helpers.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/data_root.h"
#include "posekit/core/parallel.h"
#include "posekit/customization/model_silhouette_fit.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/customization/silhouette.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/fitting/body_model.h"
#include "posekit/population/ansur.h"
#include "posekit/population/survey_plausibility.h"
#include "posekit/registration/shape_space.h"

namespace posekit::python {
namespace {

std::optional<std::string> optional_path(const py::object& path) {
  if (path.is_none()) return std::nullopt;
  return py::str(py::module_::import("os").attr("fspath")(path)).cast<std::string>();
}

/// The survey the model method judges plausibility against (ANSUR II beside the data root), or none.
std::unique_ptr<SurveyDistribution> default_survey(const std::string& data_root) {
  try {
    const std::string path = find_ansur_root("", find_data_root(data_root));
    return std::make_unique<SurveyDistribution>(survey_distribution(read_survey(path), path));
  } catch (const Error&) {
    return nullptr;  // plausibility is a warning only: without the survey there is none
  }
}

py::dict body_fit_dict(const BodyModel& model, const BodyFit& fit, const BodyFrame& frame, const Eigen::MatrixXd& points) {
  py::dict out;
  out["V"] = rows(fit.V / frame.metres_per_unit);
  out["F"] = Faces(model.faces());
  out["joints"] = rows(fit.joints / frame.metres_per_unit);
  out["vertex_part"] = Eigen::VectorXi(model.vertex_parts());
  out["target_part"] = Eigen::VectorXi(parts_of_every_vertex(model, fit, points));
  out["target_distance_mm"] = Eigen::VectorXd(1000 * fit.target_distance);
  out["coefficients"] = Eigen::VectorXd(fit.coefficients);
  out["pose"] = pose_dict(fit.pose);
  out["to_fit_frame"] = Eigen::Matrix3d(fit.to_fit_frame);
  out["up"] = Eigen::Vector3d(fit.up);
  out["start"] = fit.start;
  out["coverage"] = fit.coverage;
  out["target_to_body_mm"] = py::dict(py::arg("mean") = 1000 * fit.target_mean, py::arg("p95") = 1000 * fit.target_p95);
  out["shape_mahalanobis"] = fit.shape_mahalanobis;
  out["confident"] = fit.confident;
  out["reasons"] = fit.reasons;
  out["warnings"] = fit.warnings;
  out["guessed_joints"] = joint_names_where(fit.joint_guessed);
  out["seconds"] = fit.seconds;
  out["frame"] = frame_dict(frame);
  return out;
}

py::dict fit_body(const BodyModel& model, const Eigen::Ref<const Vertices>& V, const py::object& faces, const std::string& unit,
                  const std::string& up, bool accept_poor) {
  Eigen::MatrixXd points = V;
  const bool is_mesh = !faces.is_none();
  const Eigen::MatrixXi F = is_mesh ? Eigen::MatrixXi(mesh_of(V, faces.cast<Faces>()).F) : Eigen::MatrixXi();
  BodyFit fit;
  BodyFrame frame;
  {
    py::gil_scoped_release release;
    frame = scale_body_to_metres(&points, unit);
    BodyFitOptions o;  // an up axis given is the only one tried; auto: every axis direction
    if (up != "auto") o.up_candidates = {parse_axis(up)};
    fit = is_mesh ? fit_body_model_to_mesh(model, points, F, o) : fit_body_model(model, points, o);
  }
  const py::object warn = py::module_::import("warnings").attr("warn");
  for (const auto& w : fit.warnings) warn("posekit.BodyModel.fit: " + w);
  if (!fit.confident) {
    std::string why;
    for (const auto& r : fit.reasons) why += (why.empty() ? "" : "; ") + r;
    if (!accept_poor) throw BelowConfidence("the body model's fit is poor (" + why + "); accept_poor=True gives it anyway, marked as poor");
    warn("posekit.BodyModel.fit: the fit is poor (" + why + "); given as asked");
  }
  return body_fit_dict(model, fit, frame, points);
}

Silhouette read_view(const py::object& image, bool mask, const py::object& background, const char* what) {
  const std::string path = *optional_path(image);
  if (mask) return read_silhouette_mask(path, std::string(what) + " mask");
  SilhouetteOptions o;
  if (const auto b = optional_path(background)) o.background_photo = *b;
  return silhouette_from_photo(path, std::string(what) + " photo", o);
}

py::dict customize(const py::object& front, const py::object& side, const py::object& camera, double height, const std::string& method,
                   const py::object& model, bool masks, const py::object& front_background, const py::object& side_background,
                   double distance, double focal, bool accept_poor, const std::string& data_root) {
  if (method != "paper" && method != "model") throw InvalidInput("customize: method is 'paper' or 'model', not '" + method + "'");
  if (camera.is_none() && height <= 0) throw InvalidInput("customize needs camera (a camera file) or height (m): the scale");
  if (model.is_none())
    throw InvalidInput(method == "model" ? "customize(method='model') needs model=BodyModel(...) (a .pks of posekit shape-space --ansur)"
                                         : "customize(method='paper') needs model= a .pkc file (posekit customize train)");
  if (masks && (!front_background.is_none() || !side_background.is_none()))
    throw InvalidInput("customize: the empty scene's photos go with photos, not masks");
  const std::shared_ptr<BodyModel> body_model = method == "model" ? model.cast<std::shared_ptr<BodyModel>>() : nullptr;
  const std::optional<std::string> camera_path = optional_path(camera);
  const std::string paper_model = method == "paper" ? *optional_path(model) : std::string();
  CustomizedBody body;
  PhotoCameras cams;
  Silhouette f, s;
  {
    py::gil_scoped_release release;
    const std::unique_ptr<SurveyDistribution> survey = body_model ? default_survey(data_root) : nullptr;
    const CustomizationModel photo_model = body_model ? CustomizationModel{} : load_customization_model(paper_model);
    {
      py::gil_scoped_acquire acquire;
      f = read_view(front, masks, front_background, "front");
      s = read_view(side, masks, side_background, "side");
    }
    cams = camera_path ? read_photo_cameras(*camera_path) : cameras_from_stature(f, s, height, distance, focal);
    body = body_model ? customize_by_body_model(*body_model, f, s, cams, height, accept_poor, {}, survey.get())
                      : customize_from_silhouettes(f, s, cams, photo_model, height, accept_poor);
  }
  const py::object warn = py::module_::import("warnings").attr("warn");
  for (const auto& w : body.warnings) warn("posekit.customize: " + w);
  py::dict out;
  out["V"] = rows(body.mesh.V);
  out["F"] = Faces(body.mesh.F);
  out["photo_agreement"] = body.photo_agreement;
  out["scale"] = body.scale;
  out["assumed"] = cams.assumed;
  out["warnings"] = body.warnings;
  out["method"] = method;
  return out;
}

}  // namespace

void bind_photos_and_body_model(py::module_& m) {
  py::class_<BodyModel, std::shared_ptr<BodyModel>>(
      m, "BodyModel",
      "posekit's body model: a shape space of real proportions (posekit shape-space --ansur) on the MakeHuman "
      "template with its 16 parts and skeleton, posed by skinning; fitted to any body, it gives the parts, joints "
      "and pose (the CLI's --body-model).")
      .def(py::init([](const py::object& path, const std::string& data_root) {
             const std::string file = *optional_path(path);
             py::gil_scoped_release release;
             const auto makehuman = load_makehuman_model(find_data_root(data_root), MakeHumanParts::kSkin);
             return std::make_shared<BodyModel>(read_shape_space(file), *makehuman);
           }),
           py::arg("path"), py::arg("data_root") = "",
           "Reads a .pks body model (version 2, with joints) and the MakeHuman rig it is posed by (data_root: "
           "$POSEKIT_DATA, else ../shared/datasets/makehuman).")
      .def_property_readonly("components", &BodyModel::components, "Shape components (standard deviations).")
      .def("fit", &fit_body, py::arg("V"), py::arg("F") = py::none(), py::arg("unit") = "auto", py::arg("up") = "auto",
           py::arg("accept_poor") = false,
           "Fits the body model to a body: a mesh (V, F) or a scan's points (V), in any unit, any axes (up: an "
           "axis such as '+Z' to try only it), any pose. Returns {'V', 'F' (the fitted body, template topology, "
           "in the input's unit and axes), 'joints' (15 x 3), 'vertex_part' (the template's), 'target_part' (the "
           "part of each input point, -1 far from the body), 'target_distance_mm', 'coefficients', 'pose' (in the "
           "fit frame: the input turned by 'to_fit_frame'), 'up', 'start', 'coverage', 'target_to_body_mm', "
           "'shape_mahalanobis', 'confident', 'reasons', 'warnings', 'guessed_joints' (their parts unseen: cut off or "
           "hidden), 'seconds', 'frame'}. A poor fit raises "
           "BelowConfidence with its reasons unless accept_poor.");
  m.def("customize", &customize, py::arg("front"), py::arg("side"), py::arg("camera") = py::none(), py::arg("height") = 0.0,
        py::arg("method") = "paper", py::arg("model") = py::none(), py::arg("masks") = false, py::arg("front_background") = py::none(),
        py::arg("side_background") = py::none(), py::arg("distance") = 3.0, py::arg("focal") = 0.0, py::arg("accept_poor") = false,
        py::arg("data_root") = "",
        "A body from a front and a side photo (posekit customize): front, side: photo paths (PNG/JPEG), or "
        "silhouettes with masks=True; camera: the camera file, or height (m) with distance (m) and focal (px, 0: "
        "from the height); method 'paper' (model: a .pkc of posekit customize train) or 'model' (model: a "
        "BodyModel; plausibility judged against ANSUR II when found beside the data root); "
        "front_background/side_background: photos of the empty scene. Returns {'V', 'F' (metres, Y up, facing "
        "+Z), 'photo_agreement', 'scale', 'assumed', 'warnings', 'method'}. A result unlike the photos raises "
        "BelowConfidence unless accept_poor.");
}

}  // namespace posekit::python
