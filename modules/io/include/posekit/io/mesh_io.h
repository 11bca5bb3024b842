#pragma once
// Triangle mesh files: OBJ, PLY (ascii, binary), OFF, STL (ascii, binary).
#include <string>
#include <vector>

#include "posekit/core/triangle_mesh.h"
#include "posekit/core/units.h"

namespace posekit {

enum class MeshFormat { kAuto, kObj, kPly, kOff, kStl, kGlb };  ///< kGlb: binary glTF 2.0, written only

/// Format from a file name's extension (.obj .ply .off .stl .glb, any case); kAuto when unknown.
MeshFormat mesh_format_from_path(const std::string& path);

struct MeshReadOptions {
  Unit unit = Unit::kMetre;               ///< unit the file is written in; the mesh comes back in metres
  MeshFormat format = MeshFormat::kAuto;  ///< kAuto: from the extension
  /// Receives what was read with a caveat (texture seams, skipped header lines); nullptr: ignored.
  std::vector<std::string>* warnings = nullptr;
};

struct MeshWriteOptions {
  Unit unit = Unit::kMetre;  ///< unit to write coordinates in
  MeshFormat format = MeshFormat::kAuto;
  bool binary = true;  ///< PLY and STL: binary (default) or ascii
  /// Receives one line per attribute the format cannot hold (not written); nullptr: ignored.
  std::vector<std::string>* warnings = nullptr;
  /// PLY stores float32 wherever it keeps the values (coordinates to 1 micrometre, fields to a
  /// millionth of their spread, whole numbers exactly), float64 otherwise; true: float64 throughout.
  bool double_precision = false;
};

/// Reads a mesh; polygons are fan-triangulated. Kept: OBJ groups (face_group), normals (OBJ: through
/// the faces' v//vn indices), vertex colours (PLY red/green/blue or diffuse_*, OBJ `v x y z r g b`,
/// COFF), texture coordinates (PLY u/v or per-corner texcoord, OBJ vt, when each vertex has one),
/// PLY vertex properties beyond those as vertex_scalars (alpha included) and PLY face properties as
/// face_scalars. What cannot be kept (a vertex with several normals or texture coordinates, colours
/// on some vertices only, other PLY elements) is named in options.warnings. PLY elements may come
/// in any order.
/// Throws IoError naming the file, the line or element, and what was expected.
TriangleMesh read_mesh(const std::string& path, const MeshReadOptions& options = {});

/// Writes a mesh (to a temporary file, renamed when complete). PLY keeps normals, colours, texture
/// coordinates and scalar fields (vertex fields named `scalar_<name>`, as CloudCompare names and
/// keeps them; read_mesh drops the prefix again); glTF (.glb, always in metres: another options.unit
/// is a warning) normals, colours, texture coordinates and vertex fields (attributes `_<NAME>`); OBJ normals, colours, texture coordinates
/// and groups; OFF normals and colours; STL geometry only. What the format cannot hold goes to options.warnings. Throws IoError (unwritable
/// path, unknown extension) or InvalidInput (unusable mesh).
void write_mesh(const std::string& path, const TriangleMesh& mesh, const MeshWriteOptions& options = {});

/// What `format` cannot hold of `mesh`, one line each (empty when nothing is lost).
std::vector<std::string> mesh_attributes_lost(const TriangleMesh& mesh, MeshFormat format);

}  // namespace posekit
