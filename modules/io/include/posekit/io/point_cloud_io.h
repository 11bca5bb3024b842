#pragma once
// Point cloud files: PCD (ascii, binary, binary_compressed), PLY (vertices), XYZ (x y z [nx ny nz]).
#include <string>

#include "posekit/core/point_cloud.h"
#include "posekit/core/units.h"

namespace posekit {

enum class CloudFormat { kAuto, kPcd, kPly, kXyz };

/// Format from the extension (.pcd .ply .xyz .txt .pts); kAuto when unknown.
CloudFormat cloud_format_from_path(const std::string& path);

struct CloudReadOptions {
  Unit unit = Unit::kMetre;  ///< unit the file is written in (scanners write mm)
  CloudFormat format = CloudFormat::kAuto;
};

struct CloudWriteOptions {
  Unit unit = Unit::kMetre;
  CloudFormat format = CloudFormat::kAuto;
  bool binary = true;        ///< PCD and PLY: binary (default) or ascii
};

/// Reads a point cloud (a mesh PLY yields its vertices). Throws IoError naming the file and element.
PointCloud read_point_cloud(const std::string& path, const CloudReadOptions& options = {});

/// Writes a point cloud atomically. Throws IoError or InvalidInput.
void write_point_cloud(const std::string& path, const PointCloud& cloud,
                       const CloudWriteOptions& options = {});

}  // namespace posekit
