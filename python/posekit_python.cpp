// Python bindings (pybind11): numpy arrays in and out, posekit's errors as Python exceptions with
// the same messages, the GIL released in every long call. Metres, posekit's frame (Y up, facing +Z)
// unless a function says otherwise.
#include <pybind11/eigen.h>
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>
#include <pybind11/stl/filesystem.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <filesystem>
#include <memory>
#include <thread>

#include "binding_helpers.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/point_cloud.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_sequence.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/deformation/segmentation_calibration.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/evaluation/scan_comparison.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/registration/registration.h"
#include "posekit/registration/shape_space.h"
#include "posekit/segmentation/body_segmentation.h"
#include "posekit/segmentation/segmentation_prior.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/layered_representation.h"
#include "posekit/shape/measurements.h"
#include "posekit/version.h"

namespace py = pybind11;
using namespace posekit;
using namespace posekit::python;

namespace {

/// What the CLI prints as warnings, as Python warnings ("who: what").
void warn_each(const std::string& who, const std::vector<std::string>& warnings) {
  if (warnings.empty()) return;
  const py::object warn = py::module_::import("warnings").attr("warn");
  for (const auto& w : warnings) warn(who + ": " + w);
}

py::dict measurements_dict(const BodyMeasurements& m) {
  py::dict girths;
  for (const Girth& g : m.girths) {
    py::dict d;
    d["value"] = g.value;
    d["measured"] = g.measured;
    d["note"] = g.note;
    d["point"] = Eigen::Vector3d(g.point);
    d["tape"] = Vertices(g.tape.rows() ? Eigen::MatrixXd(g.tape) : Eigen::MatrixXd(0, 3));
    girths[py::str(g.name)] = d;
  }
  py::dict out;
  out["stature"] = m.stature;
  out["stature_measured"] = m.stature_measured;
  out["stature_note"] = m.stature_note;
  out["girths"] = girths;
  out["warnings"] = m.features.warnings;
  return out;
}

PartPose part_pose_of(const py::object& pose) {
  PartPose p;
  // A pose file's path (str or pathlib), or its JSON as loaded (with "joints" and the root's
  // rotation and translation): read as posekit reads pose files.
  const py::object path_like = py::module_::import("os").attr("PathLike");
  if (py::isinstance<py::str>(pose) || py::isinstance(pose, path_like))
    return read_part_pose(py::str(py::module_::import("os").attr("fspath")(pose)).cast<std::string>());
  if (py::isinstance<py::dict>(pose) && pose.cast<py::dict>().contains("joints")) {
    const std::string text = py::module_::import("json").attr("dumps")(pose).cast<std::string>();
    return part_pose_from_json(text, "the pose");
  }
  if (py::isinstance<py::dict>(pose)) {
    for (const auto& [key, value] : pose.cast<py::dict>()) {
      const std::string name = key.cast<std::string>();
      const int j = find_joint_index(name);
      if (j < 0) {
        std::string known;
        for (int k = 0; k < kNumJoints; ++k) known += (k ? ", " : "") + joint_name(k);
        throw InvalidInput("unknown joint '" + name + "' (the joints: " + known + ")");
      }
      p.joint(j) = value.cast<Eigen::Vector3d>();
    }
  } else {
    const Eigen::MatrixXd R = pose.cast<Eigen::MatrixXd>();
    if (R.rows() != kNumJoints || R.cols() != 3)
      throw InvalidInput("a pose is " + std::to_string(kNumJoints) + " x 3 joint rotations (axis-angle, radians), got " +
                         std::to_string(R.rows()) + " x " + std::to_string(R.cols()));
    for (int j = 0; j < kNumJoints; ++j) p.joint(j) = R.row(j).transpose();
  }
  for (const auto& r : p.joint_rotation)
    if (!r.allFinite()) throw InvalidInput("a pose holds a NaN or infinite rotation");
  return p;
}

/// Several poses: a k x 15 x 3 array of joint rotations, or a sequence of what part_pose_of takes.
std::vector<PartPose> part_poses_of(const py::object& poses) {
  std::vector<PartPose> list;
  if (py::isinstance<py::array>(poses)) {
    const auto a = poses.cast<py::array_t<double, py::array::c_style | py::array::forcecast>>();
    if (a.ndim() != 3 || a.shape(1) != kNumJoints || a.shape(2) != 3)
      throw InvalidInput("poses: expected a k x 15 x 3 array of joint rotations or a list of poses");
    auto r = a.unchecked<3>();
    list.resize(static_cast<size_t>(a.shape(0)));
    for (py::ssize_t i = 0; i < a.shape(0); ++i)
      for (int j = 0; j < kNumJoints; ++j) {
        list[static_cast<size_t>(i)].joint(j) = Eigen::Vector3d(r(i, j, 0), r(i, j, 1), r(i, j, 2));
        if (!list[static_cast<size_t>(i)].joint(j).allFinite())
          throw InvalidInput("pose " + std::to_string(i) + " holds a NaN or infinite rotation");
      }
    return list;
  }
  for (const py::handle& pose : poses) list.push_back(part_pose_of(py::reinterpret_borrow<py::object>(pose)));
  return list;
}

/// A customized body ready for posing (PoseSynthesizer): set-up once, then pose() per pose.
class Subject {
 public:
  /// `mesh` in posekit's frame; `frame` how the caller's copy was brought there (posed bodies go back).
  Subject(std::shared_ptr<const PoseModel> model, const TriangleMesh& mesh, const BodyFrame& frame)
      : faces_(mesh.F), frame_(frame), model_(model), rest_(mesh.V), synth_(std::make_unique<PoseSynthesizer>(std::move(model), mesh)) {}
  Vertices pose(const PartPose& p, PoseMethod method) const { return in_callers_frame(frame_, synth_->pose(p, method)); }
  std::vector<Vertices> pose_batch(const std::vector<PartPose>& poses, PoseMethod method, int threads) const {
    std::vector<Vertices> out(poses.size());
    const int n = std::max(
        1, std::min<int>(threads > 0 ? threads : static_cast<int>(std::thread::hardware_concurrency()), static_cast<int>(poses.size())));
    std::vector<std::thread> pool;
    std::vector<std::exception_ptr> error(static_cast<size_t>(n));
    for (int t = 0; t < n; ++t)
      pool.emplace_back([&, t] {
        try {
          Eigen::MatrixXd X;
          for (size_t i = static_cast<size_t>(t); i < poses.size(); i += static_cast<size_t>(n)) {
            synth_->pose(poses[i], method, &X);
            out[i] = in_callers_frame(frame_, X);
          }
        } catch (...) {
          error[static_cast<size_t>(t)] = std::current_exception();
        }
      });
    for (auto& th : pool) th.join();
    for (const auto& e : error)
      if (e) std::rethrow_exception(e);
    return out;
  }
  const SubjectSetupInfo& info() const { return synth_->info(); }
  const Eigen::MatrixXi& faces() const { return faces_; }
  const BodyFrame& frame() const { return frame_; }
  const std::shared_ptr<const PoseModel>& model() const { return model_; }
  const Eigen::MatrixXd& rest() const { return rest_; }  ///< in posekit's frame
  const PoseSynthesizer& synthesizer() const { return *synth_; }

 private:
  Eigen::MatrixXi faces_;
  BodyFrame frame_;
  std::shared_ptr<const PoseModel> model_;
  Eigen::MatrixXd rest_;
  std::unique_ptr<PoseSynthesizer> synth_;
};

/// posekit's errors as Python exceptions; the joint and part names.
void bind_errors_and_names(py::module_& m) {
  // Error (a RuntimeError); InvalidInput is also a ValueError, IoError also an OSError.
  py::object type = py::module_::import("builtins").attr("type");
  auto make_class = [&](const char* name, py::tuple bases, const char* doc) {
    py::dict body;
    body["__module__"] = "posekit";
    body["__doc__"] = doc;
    py::object cls = type(name, bases, body);
    m.attr(name) = cls;
    return cls.release();  // kept for the translator below, never released
  };
  static const py::handle error_class = make_class("Error", py::make_tuple(py::handle(PyExc_RuntimeError)), "Any posekit error.");
  static const py::handle invalid_class = make_class("InvalidInput", py::make_tuple(error_class, py::handle(PyExc_ValueError)),
                                                     "Input that is not what the function needs (the message says what and why).");
  static const py::handle io_class = make_class("IoError", py::make_tuple(error_class, py::handle(PyExc_OSError)),
                                                "A file that cannot be read or written (the message names it).");
  static const py::handle below_class =
      make_class("BelowConfidence", py::make_tuple(error_class),
                 "A result posekit computed but does not trust (the CLI's exit status 3); the message gives the reasons.");
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const InvalidInput& e) {
      PyErr_SetString(invalid_class.ptr(), e.what());
    } catch (const IoError& e) {
      PyErr_SetString(io_class.ptr(), e.what());
    } catch (const BelowConfidence& e) {
      PyErr_SetString(below_class.ptr(), e.what());
    } catch (const Error& e) {
      PyErr_SetString(error_class.ptr(), e.what());
    }
  });
  m.attr("joint_names") = [] {
    std::vector<std::string> names;
    for (int j = 0; j < kNumJoints; ++j) names.push_back(joint_name(j));
    return names;
  }();
  m.attr("girth_names") = girth_names();
  m.attr("part_names") = [] {
    std::vector<std::string> names;
    for (int p = 0; p < kNumParts; ++p) names.push_back(part_name(p));
    return names;
  }();
}

/// Reading and writing meshes and point clouds.
void bind_files(py::module_& m) {
  // Paths are str or pathlib.Path. With fields=True the readers also give what else the file holds.
  m.def(
      "read_mesh",
      [](const std::filesystem::path& path, bool fields) -> py::object {
        std::vector<std::string> warnings;
        const TriangleMesh mesh = read_mesh(path.string(), {Unit::kMetre, MeshFormat::kAuto, &warnings});
        warn_each("posekit.read_mesh", warnings);
        if (!fields) return py::make_tuple(rows(mesh.V), Faces(mesh.F));
        py::dict extra;
        extra["normals"] = rows(mesh.has_normals() ? mesh.N : Eigen::MatrixXd(0, 3));
        extra["colors"] = Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3, Eigen::RowMajor>(mesh.has_colors() ? mesh.C : RowMatrixX3u8(0, 3));
        extra["uv"] = Eigen::MatrixXd(mesh.has_uv() ? mesh.UV : Eigen::MatrixXd(0, 2));
        extra["vertex_scalars"] = mesh.vertex_scalars;
        extra["face_scalars"] = mesh.face_scalars;
        return py::make_tuple(rows(mesh.V), Faces(mesh.F), extra);
      },
      py::arg("path"), py::arg("fields") = false,
      "Reads a PLY, OBJ, OFF or STL mesh: (V #V x 3, F #F x 3), in the file's unit (what was read with a caveat: "
      "Python warnings); with fields=True (V, F, "
      "{'normals', 'colors' (uint8 RGB), 'uv', 'vertex_scalars': {name: #V}, 'face_scalars': {name: #F}}), empty "
      "where the file has none.");
  m.def(
      "write_mesh",
      [](const std::filesystem::path& path, const Eigen::Ref<const Vertices>& V, const Eigen::Ref<const Faces>& F,
         const py::object& normals, const py::object& colors, const std::map<std::string, Eigen::VectorXd>& scalars,
         bool double_precision) {
        TriangleMesh mesh = mesh_of(V, F);
        if (!normals.is_none()) mesh.N = normals.cast<Eigen::MatrixXd>();
        if (!colors.is_none()) mesh.C = colors.cast<Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3, Eigen::RowMajor>>();
        if (mesh.N.size() && (mesh.N.rows() != mesh.V.rows() || mesh.N.cols() != 3))
          throw InvalidInput("write_mesh: normals are #V x 3 (" + std::to_string(mesh.V.rows()) + " x 3)");
        if (mesh.C.size() && mesh.C.rows() != mesh.V.rows())
          throw InvalidInput("write_mesh: colors are #V x 3 uint8 (" + std::to_string(mesh.V.rows()) + " x 3)");
        for (const auto& [name, values] : scalars) {
          if (values.size() != mesh.V.rows())
            throw InvalidInput("write_mesh: scalar field '" + name + "' has " + std::to_string(values.size()) + " values for " +
                               std::to_string(mesh.V.rows()) + " vertices");
          mesh.vertex_scalars[name] = values;
        }
        MeshWriteOptions options;
        options.double_precision = double_precision;
        write_mesh(path.string(), mesh, options);
      },
      py::arg("path"), py::arg("V"), py::arg("F"), py::arg("normals") = py::none(), py::arg("colors") = py::none(),
      py::arg("scalars") = std::map<std::string, Eigen::VectorXd>{}, py::arg("double_precision") = false,
      "Writes a mesh (format from the extension), atomically, with per-vertex normals, uint8 RGB colors and named "
      "scalar fields where the format holds them (PLY all of them, as float32 properties scalar_<name> that "
      "CloudCompare keeps; double_precision=True: float64).");
  m.def(
      "read_point_cloud",
      [](const std::filesystem::path& path, bool fields) -> py::object {
        std::vector<std::string> warnings;
        const PointCloud cloud = read_point_cloud(path.string(), {Unit::kMetre, CloudFormat::kAuto, &warnings});
        warn_each("posekit.read_point_cloud", warnings);
        if (!fields) return py::cast(rows(cloud.P));
        py::dict extra;
        extra["normals"] = rows(cloud.has_normals() ? cloud.N : Eigen::MatrixXd(0, 3));
        extra["colors"] =
            Eigen::Matrix<std::uint8_t, Eigen::Dynamic, 3, Eigen::RowMajor>(cloud.has_colors() ? cloud.C : RowMatrixX3u8(0, 3));
        extra["scalars"] = cloud.point_scalars;
        return py::make_tuple(rows(cloud.P), extra);
      },
      py::arg("path"), py::arg("fields") = false,
      "Reads a point cloud (PLY, PCD, XYZ): #P x 3, in the file's unit; with fields=True (P, {'normals', 'colors', "
      "'scalars': {name: #P}}).");
  m.def(
      "write_point_cloud",
      [](const std::filesystem::path& path, const Eigen::Ref<const Vertices>& P, const py::object& normals,
         const std::map<std::string, Eigen::VectorXd>& scalars, bool double_precision) {
        PointCloud c;
        c.P = P;
        if (!normals.is_none()) c.N = normals.cast<Eigen::MatrixXd>();
        if (c.N.size() && (c.N.rows() != c.P.rows() || c.N.cols() != 3))
          throw InvalidInput("write_point_cloud: normals are #P x 3 (" + std::to_string(c.P.rows()) + " x 3)");
        for (const auto& [name, values] : scalars) {
          if (values.size() != c.P.rows())
            throw InvalidInput("write_point_cloud: scalar field '" + name + "' has " + std::to_string(values.size()) + " values for " +
                               std::to_string(c.P.rows()) + " points");
          c.point_scalars[name] = values;
        }
        CloudWriteOptions options;
        options.double_precision = double_precision;
        write_point_cloud(path.string(), c, options);
      },
      py::arg("path"), py::arg("P"), py::arg("normals") = py::none(), py::arg("scalars") = std::map<std::string, Eigen::VectorXd>{},
      py::arg("double_precision") = false,
      "Writes a point cloud (format from the extension), atomically, with normals and named scalar fields where the "
      "format holds them (float32 where it keeps the values; double_precision=True: float64).");
}

/// Measuring, segmenting, registering and comparing bodies.
/// Checking a mesh as posekit info does.
void bind_validation(py::module_& m) {
  m.def(
      "validate",
      [](const Eigen::Ref<const Vertices>& V, const Eigen::Ref<const Faces>& F) {
        TriangleMesh mesh;  // not mesh_of: a bad index is counted here, not raised
        mesh.V = V;
        mesh.F = F;
        MeshReport r;
        {
          py::gil_scoped_release release;
          r = validate_mesh(mesh);
        }
        py::dict out;
        out["vertices"] = r.num_vertices, out["faces"] = r.num_faces;
        out["out_of_range_indices"] = r.out_of_range_indices, out["non_finite_vertices"] = r.non_finite_vertices;
        out["degenerate_faces"] = r.degenerate_faces, out["duplicate_faces"] = r.duplicate_faces;
        out["unreferenced_vertices"] = r.unreferenced_vertices, out["boundary_edges"] = r.boundary_edges;
        out["non_manifold_edges"] = r.non_manifold_edges, out["boundary_loops"] = r.boundary_loops;
        out["components"] = r.components, out["watertight"] = r.watertight, out["usable"] = r.usable();
        out["surface_area"] = r.surface_area, out["signed_volume"] = r.signed_volume;
        return out;
      },
      py::arg("V"), py::arg("F"),
      "The mesh's defects, as posekit info reports them: {'vertices', 'faces', 'out_of_range_indices', "
      "'non_finite_vertices', 'degenerate_faces', 'duplicate_faces', 'unreferenced_vertices', 'boundary_edges', "
      "'non_manifold_edges', 'boundary_loops', 'components', 'watertight', 'usable' (indices in range, coordinates "
      "finite), 'surface_area' and 'signed_volume' (in the mesh's unit squared and cubed)}.");
}

void bind_body_functions(py::module_& m) {
  m.def(
      "measure",
      [](const Eigen::Ref<const Vertices>& V, const py::object& F, const std::string& unit, const std::string& up,
         const std::string& forward) {
        BodyMeasurements result;
        BodyFrame frame;
        const bool is_mesh = !F.is_none();
        TriangleMesh mesh = is_mesh ? mesh_of(V, F.cast<Faces>()) : TriangleMesh{};
        Eigen::MatrixXd points = is_mesh ? Eigen::MatrixXd() : Eigen::MatrixXd(V);
        {
          py::gil_scoped_release release;
          frame = bring_to_posekit_frame(is_mesh ? &mesh.V : &points, is_mesh ? &mesh.F : nullptr, nullptr, unit, up, forward);
          result = is_mesh ? measure_body(mesh.V, mesh.F) : measure_point_cloud(points);
        }
        for (Girth& g : result.girths) {
          g.point = in_callers_frame(frame, g.point.transpose()).transpose();
          if (g.tape.rows()) g.tape = in_callers_frame(frame, g.tape);
        }
        py::dict out = measurements_dict(result);
        for (const auto& w : frame.orientation.warnings) out["warnings"].cast<py::list>().append(w);
        out["frame"] = frame_dict(frame);
        return out;
      },
      py::arg("V"), py::arg("F") = py::none(), py::arg("unit") = "auto", py::arg("up") = "auto", py::arg("forward") = "auto",
      "Stature and girths of a standing body: a mesh (V, F) or, without F, a scan's points, in any unit and axes as "
      "the CLI reads them: unit m, dm, cm, mm or 'auto' (the largest extent tells), up and forward axes ('+Z', '-y', "
      "...) or 'auto' (detected). Values in metres; each girth's 'point' and 'tape' (its path, a closed polyline, "
      "#K x 3; empty when not measured) in the caller's unit and axes. Returns "
      "{'stature', 'stature_measured', 'stature_note', 'girths': {name: {'value', 'measured', 'note', 'point', 'tape'}}, "
      "'warnings', 'frame': {'unit', 'unit_detected', 'up', 'forward', 'description'}}.");

  m.def(
      "segment",
      [](const Eigen::Ref<const Vertices>& V, const Eigen::Ref<const Faces>& F, const std::shared_ptr<PoseModel>& model, bool checked,
         const std::string& unit, const std::string& up, const std::string& forward) {
        BodySegmentation result;
        TriangleMesh surface;
        BodyFrame frame;
        {
          py::gil_scoped_release release;
          TriangleMesh mesh = mesh_of(V, F);
          frame = bring_to_posekit_frame(&mesh.V, &mesh.F, nullptr, unit, up, forward);
          std::string left_out;
          surface = body_surface(mesh.V, mesh.F, &left_out);
          if (surface.F.rows() != mesh.F.rows())
            throw InvalidInput("segment: the mesh has floating pieces (" + left_out + "); pass the body alone");
          const BodyFeatures features = find_body_features(mesh.V, mesh.F);
          const LayeredRepresentation rep = build_layered_representation(surface.V, surface.F, features);
          SegmentationPrior prior;
          if (model) prior = segmentation_prior_of(*model);
          result = segment_standing_body(surface.V, surface.F, rep, features, model ? &prior : nullptr);
          if (checked && !result.check.ok())
            throw InvalidInput("segment: the result fails its sanity checks: " + result.check.summary() +
                               " (checked=False returns it anyway)");
        }
        py::dict out;
        out["triangle_part"] = Eigen::VectorXi(result.segmentation.triangle_part);
        out["joints"] = in_callers_frame(frame, result.joints);
        out["problems"] = result.check.problems;
        out["notes"] = result.notes;
        out["frame"] = frame_dict(frame);
        return out;
      },
      py::arg("V"), py::arg("F"), py::arg("model") = nullptr, py::arg("checked") = true, py::arg("unit") = "auto", py::arg("up") = "auto",
      py::arg("forward") = "auto",
      "Segments a standing body mesh into 16 parts (Eq. 2) and embeds the 15 joints; with a model, from its "
      "segmentation prior. Any unit and axes, as measure() reads them. Returns {'triangle_part' (#F, see part_names), "
      "'joints' (15 x 3, see joint_names, in the caller's unit and axes), 'problems', 'notes', 'frame'}; raises "
      "InvalidInput when the result fails the sanity checks (unless checked=False).");

  m.def(
      "register",
      [](const Eigen::Ref<const Vertices>& source_V, const Eigen::Ref<const Faces>& source_F, const Eigen::Ref<const Vertices>& target_V,
         const Eigen::Ref<const Faces>& target_F, const std::string& method, const std::string& shape_space, int threads) {
        RegistrationResult r;
        {
          RegistrationOptions o;
          o.method = parse_registration_method(method);
          if (threads < 0) throw InvalidInput("register: threads must be 0 (all cores) or more");
          o.threads = threads;
          if (!shape_space.empty()) {
            if (o.method != RegistrationMethod::kCtffd) throw InvalidInput("register: shape_space applies to method 'ctffd'");
            o.shape_space = std::make_shared<const ShapeSpace>(read_shape_space(shape_space));
          }
          const TriangleMesh source = mesh_of(source_V, source_F), target = mesh_of(target_V, target_F);
          py::gil_scoped_release release;
          r = register_bodies(source, target, o);
        }
        py::dict out;
        out["deformed_source"] = rows(r.deformed_source);
        out["correspondence"] = Eigen::VectorXi(r.correspondence);
        out["normal_failures"] = r.normal_failures;
        out["seconds"] = r.seconds;
        out["shape_space_kept"] = !shape_space.empty() && r.shape_fit.plausible;
        out["warnings"] = r.warnings;
        return out;
      },
      py::arg("source_V"), py::arg("source_F"), py::arg("target_V"), py::arg("target_F"), py::arg("method") = "ctffd",
      py::arg("shape_space") = "", py::arg("threads") = 0,
      "Registers source to target (ctffd, icp or nicp) and matches triangles by nearest centroid. shape_space: a .pks "
      "file (posekit shape-space) in the source's topology refining ct-FFD; threads: ct-FFD's (0: all cores; the same "
      "result to rounding). Returns {'deformed_source', 'correspondence' (for each target triangle its source "
      "triangle), 'normal_failures', 'seconds', 'shape_space_kept' (the fit was plausible and used), 'warnings'}.");

  m.def(
      "compare",
      [](const Eigen::Ref<const Vertices>& V, const Eigen::Ref<const Faces>& F, const Eigen::Ref<const Vertices>& scan,
         double outlier_threshold) {
        ScanComparison c;
        {
          const TriangleMesh mesh = mesh_of(V, F);
          PointCloud cloud;
          cloud.P = scan;
          ScanComparisonOptions o;
          o.outlier_threshold = outlier_threshold;
          py::gil_scoped_release release;
          c = compare_with_scan(mesh, cloud, o);
        }
        auto stats = [](const DistanceStats& s) {
          py::dict d;
          d["mean_mm"] = s.mean_mm, d["rms_mm"] = s.rms_mm, d["p95_mm"] = s.p95_mm, d["max_mm"] = s.max_mm;
          d["signed_mean_mm"] = s.signed_mean_mm, d["count"] = s.count, d["outliers"] = s.outliers;
          return d;
        };
        py::dict out;
        out["scan_to_model_mm"] = Eigen::VectorXd(1000 * c.scan_to_model);
        out["model_to_scan_mm"] = Eigen::VectorXd(1000 * c.model_to_scan);
        out["scan_stats"] = stats(c.scan_stats);
        out["model_stats"] = stats(c.model_stats);
        out["hausdorff_mm"] = c.hausdorff_mm;
        out["coverage"] = c.coverage;
        return out;
      },
      py::arg("V"), py::arg("F"), py::arg("scan"), py::arg("outlier_threshold") = 0.02,
      "Distances between a body mesh and a scan (both m; outlier_threshold m): every distance out is in mm, its key "
      "says so: signed 'scan_to_model_mm' per scan point and 'model_to_scan_mm' per vertex (NaN where uncovered), "
      "their statistics, 'hausdorff_mm', and 'coverage' (a fraction).");
}

/// Pose models and subjects prepared for posing.
/// Subject.fit: posekit fit (articulated ICP from a search), or fit --registered (the known
/// correspondences), with the CLI's frames: the target's unit detected and its vertical turned to +Y.
py::dict fit_subject(const Subject& s, const Eigen::Ref<const Vertices>& target, const py::object& faces, const std::string& unit,
                     const std::string& up, const std::string& method, int iterations, const py::object& start, bool registered) {
  const PoseMethod how = parse_pose_method(method);
  py::dict out;
  if (registered) {
    if (target.rows() != s.rest().rows())
      throw InvalidInput("fit(registered=True) needs the subject's own vertices posed (" + std::to_string(s.rest().rows()) +
                         " rows); the target has " + std::to_string(target.rows()));
    // The subject's unit and axes apply to its registered copy too.
    const Eigen::MatrixXd T = Eigen::MatrixXd(target) * s.frame().metres_per_unit * s.frame().orientation.rotation.transpose();
    PartPoseEstimate e;
    Eigen::MatrixXd X;
    {
      py::gil_scoped_release release;
      const PartPoseEstimator estimator(s.rest(), s.faces(), s.info().triangle_part, s.info().joint_centres);
      e = estimator.estimate(T);
      X = s.synthesizer().pose(e.pose, how);
    }
    const Eigen::VectorXd error = (X - T).rowwise().norm();
    py::dict parts;
    for (int p = 0; p < kNumParts; ++p) parts[py::str(part_name(p))] = 1000 * e.core_rms[static_cast<size_t>(p)];
    out["pose"] = pose_dict(e.pose);
    out["V"] = in_callers_frame(s.frame(), X);
    out["posed_to_target_mm"] = py::dict(py::arg("mean") = 1000 * error.mean(), py::arg("max") = 1000 * error.maxCoeff());
    out["rigid_parts_rms_mm"] = 1000 * e.rms;
    out["part_core_rms_mm"] = parts;
    out["worst_part"] = part_name(e.worst_part);
    out["warnings"] = pose_estimate_problems(e);
    return out;
  }
  Eigen::MatrixXd T = target;
  const Eigen::MatrixXi F = faces.is_none() ? Eigen::MatrixXi() : Eigen::MatrixXi(faces.cast<Faces>());
  PoseFitOptions o;
  o.method = how;
  o.iterations = iterations;
  if (iterations < 1) throw InvalidInput("fit: iterations must be at least 1");
  if (!start.is_none()) o.start = part_pose_of(start);
  PoseFitResult r;
  Eigen::Matrix3d to_fit = Eigen::Matrix3d::Identity();
  BodyFrame frame;
  {
    py::gil_scoped_release release;
    frame = scale_body_to_metres(&T, unit);
    // Only the vertical matters: the fit finds the heading itself.
    const Eigen::Vector3d vertical = up != "auto" ? parse_axis(up)
                                     : F.rows()   ? detect_mesh_orientation(T, F).up()
                                                  : detect_body_orientation(T).up();
    to_fit = Eigen::Quaterniond::FromTwoVectors(vertical.normalized(), Eigen::Vector3d::UnitY()).toRotationMatrix();
    r = fit_pose(s.synthesizer(), (T * to_fit.transpose()).eval(), o);
  }
  out["pose"] = pose_dict(r.pose);
  out["V"] = rows(r.V * to_fit / frame.metres_per_unit);  // the target's axes and unit
  out["residual_mm"] = Eigen::VectorXd(1000 * r.residual);
  out["target_to_body_mm"] = py::dict(py::arg("mean") = 1000 * r.target_mean, py::arg("p95") = 1000 * r.target_p95);
  out["coverage_1cm"] = r.coverage;
  out["iterations"] = r.iterations;
  out["seconds"] = r.seconds;
  out["warnings"] = r.warnings;
  return out;
}

void bind_posing(py::module_& m) {
  py::class_<PoseModel, std::shared_ptr<PoseModel>>(m, "PoseModel", "A trained pose model (Eq. 3-5; posekit train)")
      .def_static(
          "load", [](const std::filesystem::path& path) { return std::make_shared<PoseModel>(read_pose_model(path.string())); },
          py::arg("path"), "Reads a .pkm model file (posekit train), checksum checked.")
      .def(
          "save", [](const PoseModel& model, const std::filesystem::path& path) { write_pose_model(path.string(), model); },
          py::arg("path"), "Writes the model as a .pkm file, atomically.")
      .def(py::pickle([](const PoseModel& model) { return py::bytes(pose_model_bytes(model)); },
                      [](const py::bytes& state) {
                        return std::make_shared<PoseModel>(pose_model_from_bytes(std::string(state), "a pickled PoseModel"));
                      }))
      .def_readonly("training_poses", &PoseModel::training_poses, "How many posed examples Eq. 5 was fitted to.")
      .def_readonly("fit_rms", &PoseModel::fit_rms, "RMS residual of Eq. 5 over the training examples' T^Q entries.")
      .def_property_readonly(
          "triangle_rms", [](const PoseModel& model) { return Eigen::VectorXd(model.triangle_rms); },
          "Per template triangle, the RMS residual of Eq. 5 (weights Eq. 6's least squares); empty for an older model file.")
      .def_property_readonly(
          "template", [](const PoseModel& model) { return py::make_tuple(rows(model.template_V), Faces(model.template_F)); },
          "The training template at rest: (V #V x 3 in metres, F #F x 3).")
      .def_property_readonly(
          "calibration_bodies", [](const PoseModel& model) { return model.segmentation_prior.bodies.size(); },
          "Bodies in the segmentation prior (0: the template alone).");

  m.def(
      "train",
      [](const std::string& dataset, int calibration_bodies, const std::string& data_root) {
        py::gil_scoped_release release;
        auto model = std::make_shared<PoseModel>(train_on_dataset(dataset));
        if (calibration_bodies > 0) {
          CalibrationOptions o;
          o.bodies = calibration_bodies;
          const PriorReport report = add_segmentation_prior(model.get(), data_root, o);
          if (!report.not_made.empty()) throw InvalidInput("segmentation prior not made: " + report.not_made);
        }
        return model;
      },
      py::arg("dataset"), py::arg("calibration_bodies") = 128, py::arg("data_root") = "",
      "Trains a pose model on a posekit dataset's training split (as posekit train), with a segmentation "
      "prior of `calibration_bodies` MakeHuman bodies (0: the template alone).");

  py::class_<Subject>(m, "Subject",
                      "A customized body prepared for posing with a model (segmentation, skeleton, "
                      "correspondence, factorisation once; then each pose is one solve)")
      .def(py::init([](std::shared_ptr<PoseModel> model, const Eigen::Ref<const Vertices>& V, const Eigen::Ref<const Faces>& F,
                       const std::string& unit, const std::string& up, const std::string& forward) {
             TriangleMesh mesh = mesh_of(V, F);
             std::unique_ptr<Subject> subject;
             {
               py::gil_scoped_release release;
               const BodyFrame frame = bring_to_posekit_frame(&mesh.V, &mesh.F, nullptr, unit, up, forward);
               subject = std::make_unique<Subject>(std::move(model), mesh, frame);
             }
             // What the CLI prints as warnings: the skeleton's problems and weak orientation cues.
             const py::object warn = py::module_::import("warnings").attr("warn");
             for (const auto& w : subject->frame().orientation.warnings) warn("posekit.Subject: " + w);
             for (const auto& p : subject->info().skeleton_problems) warn("posekit.Subject: the skeleton: " + p);
             return subject;
           }),
           py::arg("model"), py::arg("V"), py::arg("F"), py::arg("unit") = "auto", py::arg("up") = "auto", py::arg("forward") = "auto",
           "The body at rest in any unit and axes (read as measure() reads them); posed bodies and joints come back "
           "in the same unit and axes. Pose rotations are about posekit's axes (the body's left, up and forward).")
      .def(
          "pose",
          [](const Subject& s, const py::object& pose, const std::string& method) {
            const PartPose p = part_pose_of(pose);
            const PoseMethod how = parse_pose_method(method);
            py::gil_scoped_release release;
            return s.pose(p, how);
          },
          py::arg("pose"), py::arg("method") = "learned",
          "The posed vertices (#V x 3) for joint rotations (axis-angle, radians, relative to the parent part, "
          "as posekit's pose JSON): a 15 x 3 array in joint_names order, a dict {joint name: rotation}, a pose "
          "file's path (str or pathlib.Path) or its JSON as loaded (with 'joints' and the root's rotation and "
          "translation). method: learned, rigid or lbs.")
      .def(
          "pose_batch",
          [](const Subject& s, const py::object& poses, const std::string& method, int threads) {
            const std::vector<PartPose> list = part_poses_of(poses);
            const PoseMethod how = parse_pose_method(method);
            std::vector<Vertices> posed;
            {
              py::gil_scoped_release release;
              posed = s.pose_batch(list, how, threads);
            }
            const py::ssize_t n = posed.empty() ? 0 : static_cast<py::ssize_t>(posed[0].rows());
            py::array_t<double> out({static_cast<py::ssize_t>(posed.size()), n, py::ssize_t{3}});
            auto w = out.mutable_unchecked<3>();
            for (size_t i = 0; i < posed.size(); ++i)
              for (py::ssize_t v = 0; v < n; ++v)
                for (int c = 0; c < 3; ++c) w(static_cast<py::ssize_t>(i), v, c) = posed[i](v, c);
            return out;
          },
          py::arg("poses"), py::arg("method") = "learned", py::arg("threads") = 0,
          "Poses several poses on `threads` threads (0: all cores): k x #V x 3. poses: a k x 15 x 3 array of joint "
          "rotations, or a list of anything pose() takes (read_poses()' poses, with their root motion).")
      .def("fit", &fit_subject, py::arg("target"), py::arg("faces") = py::none(), py::arg("unit") = "auto", py::arg("up") = "auto",
           py::arg("method") = "learned", py::arg("iterations") = 100, py::arg("start") = py::none(), py::arg("registered") = false,
           "The pose that makes the subject match a target (posekit fit): target points (#T x 3, a scan or a mesh's "
           "vertices with `faces`) in any unit and axes, its vertical detected (or `up`), its heading fitted; "
           "`start`: a pose to refine from instead of searching. registered=True: the target is the subject's own "
           "mesh posed (same vertices, the subject's unit and axes) and the pose comes from the correspondences "
           "(fit --registered). Returns {'pose' (pose JSON dict), 'V' (the fitted body in the target's unit and "
           "axes), 'residual_mm' (#V), 'target_to_body_mm' {'mean', 'p95'}, 'coverage_1cm', 'iterations', "
           "'seconds', 'warnings'}; registered: {'pose', 'V', 'posed_to_target_mm', 'rigid_parts_rms_mm', "
           "'part_core_rms_mm', 'worst_part', 'warnings'}.")
      .def_property_readonly(
          "triangle_part", [](const Subject& s) { return Eigen::VectorXi(s.info().triangle_part); },
          "The part of each triangle (#F, indices into part_names).")
      .def_property_readonly(
          "joints", [](const Subject& s) { return in_callers_frame(s.frame(), s.info().joint_centres); },
          "The 15 joint centres at rest (15 x 3, joint_names order), in the body's own unit and axes.")
      .def_property_readonly(
          "frame", [](const Subject& s) { return frame_dict(s.frame()); },
          "How the body was read: {'unit', 'unit_detected', 'up', 'forward', 'description'}.")
      // Pickled as the model and the body in posekit's frame with how it got there; set-up runs again
      // where it is unpickled (a worker process), giving the same subject.
      .def(py::pickle(
          [](const Subject& s) {
            const BodyFrame& f = s.frame();
            return py::make_tuple(py::bytes(pose_model_bytes(*s.model())), rows(s.rest()), Faces(s.faces()),
                                  Eigen::Matrix3d(f.orientation.rotation), f.metres_per_unit, f.unit, f.unit_detected, f.extent,
                                  f.orientation.up_detected, f.orientation.forward_detected);
          },
          [](const py::tuple& t) {
            if (t.size() != 10) throw InvalidInput("a pickled Subject has 10 fields, this one " + std::to_string(t.size()));
            auto model = std::make_shared<const PoseModel>(pose_model_from_bytes(t[0].cast<std::string>(), "a pickled Subject"));
            TriangleMesh mesh;
            mesh.V = t[1].cast<Eigen::MatrixXd>();
            mesh.F = t[2].cast<Eigen::MatrixXi>();
            BodyFrame f;
            f.orientation.rotation = t[3].cast<Eigen::Matrix3d>();
            f.metres_per_unit = t[4].cast<double>();
            f.unit = t[5].cast<std::string>();
            f.unit_detected = t[6].cast<bool>();
            f.extent = t[7].cast<double>();
            f.orientation.up_detected = t[8].cast<bool>();
            f.orientation.forward_detected = t[9].cast<bool>();
            py::gil_scoped_release release;
            return std::make_unique<Subject>(std::move(model), mesh, f);
          }))
      .def_property_readonly(
          "faces", [](const Subject& s) { return Faces(s.faces()); }, "The body's triangles (#F x 3).")
      .def_property_readonly(
          "skeleton_problems", [](const Subject& s) { return s.info().skeleton_problems; },
          "What the skeleton checks found wrong (empty: nothing); also given as warnings.");
}

const char* bvh_channel_name(BvhChannel c) {
  static const char* names[] = {"Xposition", "Yposition", "Zposition", "Xrotation", "Yrotation", "Zrotation"};
  return names[static_cast<int>(c)];
}

/// read_poses' options as the CLI's --frames, --joint-map and --root-motion give them.
PoseSequenceOptions pose_sequence_options(const py::object& frames, const py::object& joint_map, const std::string& root_motion,
                                          const std::string& data_root) {
  PoseSequenceOptions o;
  o.data_root = data_root;
  if (root_motion == "none") o.root_motion = RetargetOptions::RootMotion::kNone;
  else if (root_motion == "all") o.root_motion = RetargetOptions::RootMotion::kAll;
  else if (root_motion != "vertical") throw InvalidInput("root_motion: expected 'none', 'vertical' or 'all', got '" + root_motion + "'");
  if (!frames.is_none()) {
    const auto range = frames.cast<std::pair<int, int>>();
    o.first = range.first, o.last = range.second;
  }
  const py::object path_like = py::module_::import("os").attr("PathLike");
  if (py::isinstance<py::str>(joint_map) || py::isinstance(joint_map, path_like))
    o.joint_map = read_bvh_joint_map(py::str(py::module_::import("os").attr("fspath")(joint_map)).cast<std::string>());
  else if (!joint_map.is_none()) o.joint_map = joint_map.cast<std::map<std::string, std::string>>();
  return o;
}

/// BVH reading and retargeting, the library functions `posekit pose --pose x.bvh` and `posekit retarget` call.
void bind_motion(py::module_& m) {
  m.def(
      "read_bvh",
      [](const std::filesystem::path& path) {
        const BvhMotion motion = read_bvh(path.string());
        py::list joints;
        for (const BvhJoint& j : motion.joints) {
          py::dict d;
          d["name"] = j.name;
          d["parent"] = j.parent;
          d["offset"] = Eigen::Vector3d(j.offset);
          py::list channels;
          for (BvhChannel c : j.channels) channels.append(bvh_channel_name(c));
          d["channels"] = channels;
          d["first_channel"] = j.first_channel;
          joints.append(d);
        }
        py::dict out;
        out["joints"] = joints;
        out["frame_time"] = motion.frame_time;
        out["frames"] = Eigen::MatrixXd(motion.frames);
        return out;
      },
      py::arg("path"),
      "Reads a BVH motion: {'joints': [{'name', 'parent' (index, -1 for the root), 'offset' (m), 'channels', "
      "'first_channel'}], 'frame_time' (s), 'frames' (#frames x #channels; positions in metres, rotations in "
      "degrees)}. Offsets and positions are read as metres, as the CLI reads them.");
  m.def(
      "read_poses",
      [](const std::filesystem::path& path, const Subject* subject, const py::object& frames, const py::object& joint_map,
         const std::string& root_motion, const std::string& data_root) {
        const PoseSequenceOptions options = pose_sequence_options(frames, joint_map, root_motion, data_root);
        PoseSequence sequence;
        {
          py::gil_scoped_release release;
          Eigen::MatrixXd rest_joints;
          if (subject) {
            rest_joints = subject->info().joint_centres;
          } else {
            const auto mh = load_makehuman_model(find_data_root(data_root));
            rest_joints = joint_centres(mh->rig, build_body(*mh, BodySpec{}));
          }
          sequence = load_pose_sequence(path.string(), rest_joints, options);
        }
        py::list poses;
        for (size_t i = 0; i < sequence.poses.size(); ++i) {
          validate_part_pose(sequence.poses[i], path.string());
          py::dict pose = pose_dict(sequence.poses[i]);
          pose["name"] = sequence.names[i];
          poses.append(pose);
        }
        py::dict out;
        out["poses"] = poses;
        out["notes"] = sequence.notes;
        return out;
      },
      py::arg("path"), py::arg("subject") = nullptr, py::arg("frames") = py::none(), py::arg("joint_map") = py::none(),
      py::arg("root_motion") = "vertical", py::arg("data_root") = "",
      "The poses of a pose JSON or a BVH of any humanoid skeleton, as `posekit pose --pose FILE` (with subject: "
      "retargeted to the subject's own joints) and `posekit retarget` (without: to the default MakeHuman body's) "
      "make them: {'poses': [pose JSON dicts with 'name', 'joints', 'root_rotation', 'root_translation'], "
      "'notes': how the skeleton was mapped}. frames: (first, last) of a BVH, last excluded; joint_map: "
      "{posekit joint: BVH joint} or a JSON file of it; root_motion: none, vertical (feet stay down) or all. "
      "Each pose goes to Subject.pose() or, all of them, to Subject.pose_batch().");
}

}  // namespace

PYBIND11_MODULE(posekit, m) {
  m.doc() =
      "posekit: customize, pose and validate human body models (Zhu & Mok). Arrays are numpy; "
      "lengths in metres, bodies Y up and facing +Z.";
  m.attr("__version__") = posekit::version();
  bind_errors_and_names(m);
  bind_files(m);
  bind_posing(m);  // before the functions that take a PoseModel, for their signatures
  bind_body_functions(m);
  bind_validation(m);
  bind_motion(m);
  bind_photos_and_body_model(m);
}
