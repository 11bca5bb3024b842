#pragma once
// Internal: the OBJ and OFF readers, shared by meshes and point clouds (a file's vertices).
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"

namespace posekit::io_detail {

/// `scale` multiplies coordinates (file unit -> metres). The mesh may have no faces.
TriangleMesh read_obj(const std::string& path, double scale, std::vector<std::string>* warnings);
TriangleMesh read_off(const std::string& path, double scale);

/// `scale` multiplies coordinates (metres -> file unit). The mesh may have no faces (a point cloud).
void write_obj(const std::string& path, const TriangleMesh& mesh, double scale);
void write_off(const std::string& path, const TriangleMesh& mesh, double scale);

}  // namespace posekit::io_detail
