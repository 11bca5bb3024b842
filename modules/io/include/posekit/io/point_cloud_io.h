#pragma once
// Point cloud files: PCD (ascii, binary, binary_compressed), PLY (vertices), XYZ/PTS/TXT columns,
// and the vertices of OBJ and OFF files.
#include <string>
#include <vector>

#include "posekit/core/point_cloud.h"
#include "posekit/core/units.h"

namespace posekit {

enum class CloudFormat { kAuto, kPcd, kPly, kXyz, kObj, kOff };

/// Format from the extension (.pcd .ply .xyz .txt .pts .obj .off); kAuto when unknown.
CloudFormat cloud_format_from_path(const std::string& path);

struct CloudReadOptions {
  Unit unit = Unit::kMetre;  ///< unit the file is written in (scanners write mm)
  CloudFormat format = CloudFormat::kAuto;
  /// Receives what was read with a caveat (points dropped for a non-finite coordinate, how
  /// unnamed XYZ columns were read); nullptr: ignored.
  std::vector<std::string>* warnings = nullptr;
};

struct CloudWriteOptions {
  Unit unit = Unit::kMetre;
  CloudFormat format = CloudFormat::kAuto;
  bool binary = true;  ///< PCD and PLY: binary (default) or ascii
  /// Receives one line per attribute the format cannot hold (not written); nullptr: ignored.
  std::vector<std::string>* warnings = nullptr;
  /// PLY and PCD store float32 wherever it keeps the values (coordinates to 1 micrometre, fields to a
  /// millionth of their spread, whole numbers exactly), float64 otherwise; true: float64 throughout.
  bool double_precision = false;
};

/// Reads a point cloud: positions, and normals, RGB colours and scalar fields where the file has
/// them (PCD rgb/rgba, PLY red/green/blue or diffuse_red/green/blue, XYZ columns named by a `//X Y Z R G B` header or, without
/// one, recognised as unit normals or 0..255 colours). A mesh file yields its vertices. Every format
/// drops points with a NaN or infinite coordinate (organised clouds mark missing returns so) and
/// says how many in options.warnings. A file with no (finite) point is refused ("no points"), since
/// every use of a cloud needs one. Throws IoError naming the file and element.
PointCloud read_point_cloud(const std::string& path, const CloudReadOptions& options = {});

/// Writes a point cloud atomically, in float32 or float64 as options.double_precision says. PLY
/// names the scalar fields `scalar_<name>` (CloudCompare's names; read_point_cloud drops the prefix
/// again), PCD by their names. XYZ writes a
/// `//X Y Z ...` header naming the columns when there are more than three. Throws IoError or InvalidInput.
void write_point_cloud(const std::string& path, const PointCloud& cloud, const CloudWriteOptions& options = {});

}  // namespace posekit
