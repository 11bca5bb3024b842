// posekit convert <in> <out>: between mesh or cloud formats and units.
#include <iostream>

#include "cli.h"
#include "commands.h"
#include "posekit/core/error.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"

namespace posekit::cli {

int run_convert(int argc, char** argv) {
  ArgParser args("convert",
                 "Converts a mesh (OBJ, PLY, OFF, STL) or a point cloud (PCD, PLY, XYZ) to another format\n"
                 "and/or unit. Formats follow the extensions. Point clouds stay point clouds; a mesh written\n"
                 "to .pcd or .xyz keeps its vertices. The output appears only when complete.");
  args.positional("in", "input file").positional("out", "output file")
      .option("from-unit", "U", "unit of the input: m, dm, cm, mm", "m")
      .option("to-unit", "U", "unit of the output: m, dm, cm, mm", "m")
      .option("group", "NAME", "keep only this OBJ group of a mesh")
      .flag("ascii", "write PLY/PCD/STL as text instead of binary")
      .example("posekit convert base.obj body.ply --group body --from-unit dm --to-unit m")
      .example("posekit convert scan.pcd scan.xyz --from-unit mm --to-unit mm");
  if (!args.parse(argc, argv)) return 0;
  const std::string in = args.positionals()[0], out = args.positionals()[1];
  const Unit from = parse_unit(args.get("from-unit")), to = parse_unit(args.get("to-unit"));
  const bool binary = !args.flag_set("ascii");
  const bool in_cloud = cloud_format_from_path(in) == CloudFormat::kPcd || cloud_format_from_path(in) == CloudFormat::kXyz;
  const bool out_cloud = cloud_format_from_path(out) == CloudFormat::kPcd || cloud_format_from_path(out) == CloudFormat::kXyz;
  if (in_cloud && mesh_format_from_path(out) != MeshFormat::kAuto && mesh_format_from_path(out) != MeshFormat::kPly)
    throw InvalidInput(in + " is a point cloud: it can be written as .pcd, .ply or .xyz, not " + out);
  if (in_cloud) {
    const PointCloud cloud = read_point_cloud(in, {from});
    write_point_cloud(out, cloud, {to, CloudFormat::kAuto, binary});
    std::cerr << "wrote " << out << ": " << cloud.size() << " points (" << unit_name(to) << ")\n";
    return 0;
  }
  TriangleMesh mesh = read_mesh(in, {from});
  if (args.has("group")) mesh = extract_group(mesh, args.get("group"));
  if (out_cloud) {
    PointCloud cloud;
    cloud.P = mesh.V;
    if (mesh.has_normals()) cloud.N = mesh.N;
    cloud.point_scalars = mesh.vertex_scalars;
    write_point_cloud(out, cloud, {to, CloudFormat::kAuto, binary});
    std::cerr << "wrote " << out << ": " << cloud.size() << " points (" << unit_name(to) << ")\n";
    return 0;
  }
  write_mesh(out, mesh, {to, MeshFormat::kAuto, binary});
  std::cerr << "wrote " << out << ": " << mesh.num_vertices() << " vertices, " << mesh.num_faces() << " triangles ("
            << unit_name(to) << ")\n";
  return 0;
}

}  // namespace posekit::cli
