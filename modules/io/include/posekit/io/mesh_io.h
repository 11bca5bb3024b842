#pragma once
// Triangle mesh files: OBJ, PLY (ascii, binary), OFF, STL (ascii, binary).
#include <string>

#include "posekit/core/triangle_mesh.h"
#include "posekit/core/units.h"

namespace posekit {

enum class MeshFormat { kAuto, kObj, kPly, kOff, kStl };

/// Format from a file name's extension (.obj .ply .off .stl, any case); kAuto when unknown.
MeshFormat mesh_format_from_path(const std::string& path);

struct MeshReadOptions {
  Unit unit = Unit::kMetre;           ///< unit the file is written in; the mesh comes back in metres
  MeshFormat format = MeshFormat::kAuto;  ///< kAuto: from the extension
};

struct MeshWriteOptions {
  Unit unit = Unit::kMetre;           ///< unit to write coordinates in
  MeshFormat format = MeshFormat::kAuto;
  bool binary = true;                 ///< PLY and STL: binary (default) or ascii
};

/// Reads a mesh; polygons are fan-triangulated, OBJ groups kept as face_group, PLY vertex
/// properties beyond x,y,z / normals / colours kept as vertex_scalars. Throws IoError naming
/// the file, the line or element, and what was expected.
TriangleMesh read_mesh(const std::string& path, const MeshReadOptions& options = {});

/// Writes a mesh (to a temporary file, renamed when complete). PLY keeps normals, colours and
/// scalar fields; OBJ keeps normals and groups; OFF and STL keep geometry only.
/// Throws IoError (unwritable path, unknown extension) or InvalidInput (unusable mesh).
void write_mesh(const std::string& path, const TriangleMesh& mesh, const MeshWriteOptions& options = {});

}  // namespace posekit
