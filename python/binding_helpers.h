#pragma once
// What the binding sources share: numpy-facing matrix types, meshes from arrays, frames and poses
// as Python dicts, and the functions each source binds.
#include <pybind11/eigen.h>
#include <pybind11/pybind11.h>

#include <string>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::python {

namespace py = pybind11;

using Vertices = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
using Faces = Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>;

inline TriangleMesh mesh_of(const Eigen::Ref<const Vertices>& V, const Eigen::Ref<const Faces>& F) {
  TriangleMesh m;
  m.V = V;
  m.F = F;
  if (m.F.size() > 0 && (m.F.minCoeff() < 0 || m.F.maxCoeff() >= m.V.rows()))
    throw InvalidInput("faces refer to vertex " + std::to_string(m.F.minCoeff() < 0 ? m.F.minCoeff() : m.F.maxCoeff()) + ", outside the " +
                       std::to_string(m.V.rows()) + " vertices");
  return m;
}

inline Vertices rows(const Eigen::MatrixXd& M) { return M; }

/// Points in the caller's unit and axes from posekit's frame (metres, Y up, facing +Z).
inline Vertices in_callers_frame(const BodyFrame& frame, const Eigen::MatrixXd& P) {
  return P * frame.orientation.rotation / frame.metres_per_unit;
}

inline py::dict frame_dict(const BodyFrame& frame) {
  py::dict out;
  out["unit"] = frame.unit;
  out["unit_detected"] = frame.unit_detected;
  out["up"] = axis_name(frame.orientation.up());
  out["forward"] = axis_name(frame.orientation.forward());
  out["description"] = frame.describe();
  return out;
}

/// A pose as posekit's pose JSON, loaded: {'format', 'units', 'root_rotation', 'root_translation', 'joints'}.
inline py::dict pose_dict(const PartPose& pose) { return py::module_::import("json").attr("loads")(part_pose_to_json(pose)); }

/// customize() and BodyModel (bind_photos_and_body_model.cpp).
void bind_photos_and_body_model(py::module_& m);

}  // namespace posekit::python
