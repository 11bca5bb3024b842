#pragma once
// Internal: binary glTF 2.0 (.glb) writing.
#include <string>

#include "posekit/core/triangle_mesh.h"

namespace posekit::io_detail {

/// Writes `mesh` as one glTF 2.0 binary file (atomically): positions (metres, as glTF defines them,
/// after `scale`), normals, colours as COLOR_0 (RGBA 8-bit), texture coordinates as TEXCOORD_0 (v
/// flipped: glTF's origin is the top left), each vertex scalar as a float attribute "_<NAME>"
/// (glTF's application-specific attributes), the triangles as 32-bit indices.
void write_glb(const std::string& path, const TriangleMesh& mesh, double scale);

}  // namespace posekit::io_detail
