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
                 "Converts a mesh (OBJ, PLY, OFF, STL) or a point cloud (PCD, PLY, XYZ/PTS/TXT, or an OBJ/OFF/PLY\n"
                 "without faces) to another format and/or unit. Formats follow the extensions. Point clouds stay\n"
                 "point clouds; a mesh written to .pcd or .xyz keeps its vertices. Colours, normals, texture\n"
                 "coordinates and scalar fields are kept where the target format can hold them; a warning names\n"
                 "what it cannot. The output appears only when complete. .glb writes glTF 2.0 (metres, as glTF\n"
                 "defines it); --heatmap colours the vertices by one of their fields (e.g. compare's\n"
                 "signed_distance_mm), for viewers that show colours and not fields.");
  args.positional("in", "input file")
      .positional_output("out", "output file")
      .option("from-unit", "U", "unit of the input: m, dm, cm, mm", "m")
      .option("to-unit", "U", "unit of the output: m, dm, cm, mm", "m")
      .option("group", "NAME", "keep only this OBJ group of a mesh")
      .flag("ascii", "write PLY/PCD/STL as text instead of binary")
      .flag("double", "write PLY/PCD coordinates and fields as float64 (default: float32 where it keeps them to 1 um)")
      .option("heatmap", "FIELD", "colour the vertices by this scalar field (a mesh's or a cloud's)")
      .option("colours", "KIND", "--heatmap: diverging (signed) or sequential (|value|)", "diverging")
      .option("range", "MIN:MAX", "--heatmap: colour range (default: the 95th percentile of |value|)")
      .example("posekit convert base.obj body.ply --group body --from-unit dm --to-unit m")
      .example("posekit convert scan.pcd scan.xyz --from-unit mm --to-unit mm")
      .example("posekit convert errors.ply errors.glb --heatmap signed_distance_mm");
  if (!args.parse(argc, argv)) return 0;
  const std::string in = args.positionals()[0], out = args.positionals()[1];
  const Unit from = parse_unit(args.get("from-unit")), to = parse_unit(args.get("to-unit"));
  const bool binary = !args.flag_set("ascii");
  const bool out_cloud = cloud_format_from_path(out) == CloudFormat::kPcd || cloud_format_from_path(out) == CloudFormat::kXyz;
  BodyInput input = read_body_input(in, from);
  if (args.has("heatmap")) {
    const std::string field = args.get("heatmap");
    auto& fields = input.is_cloud ? input.cloud.point_scalars : input.mesh.vertex_scalars;
    if (!fields.count(field)) {
      std::string known;
      for (const auto& kv : fields) known += (known.empty() ? "" : ", ") + kv.first;
      throw InvalidInput(in + " has no field '" + field + "' for --heatmap (its fields: " + (known.empty() ? "none" : known) + ")");
    }
    (input.is_cloud ? input.cloud.C : input.mesh.C) = heatmap_from(args, fields.at(field), ColourMapKind::kDiverging);
  }
  if (input.is_cloud) {
    if (args.has("group")) throw InvalidInput(in + " is a point cloud: it has no groups for --group");
    if (mesh_format_from_path(out) == MeshFormat::kStl)
      throw InvalidInput(in + " is a point cloud: STL holds triangles only; write .pcd, .ply, .xyz, .obj or .off");
    write_point_cloud(out, input.cloud, {to, CloudFormat::kAuto, binary, io_warnings(), args.flag_set("double")});
    flush_warnings();
    std::cerr << "wrote " << out << ": " << input.cloud.size() << " points (" << unit_name(to) << ")\n";
    return 0;
  }
  TriangleMesh& mesh = input.mesh;
  if (args.has("group")) mesh = extract_group(mesh, args.get("group"));
  if (out_cloud) {
    PointCloud cloud;
    cloud.P = mesh.V;
    if (mesh.has_normals()) cloud.N = mesh.N;
    if (mesh.has_colors()) cloud.C = mesh.C;
    cloud.point_scalars = mesh.vertex_scalars;
    for (const auto& kv : mesh.face_scalars)
      io_warnings()->push_back(out + ": a point cloud cannot hold the face field " + kv.first + ": not written");
    write_point_cloud(out, cloud, {to, CloudFormat::kAuto, binary, io_warnings(), args.flag_set("double")});
    flush_warnings();
    std::cerr << "wrote " << out << ": " << cloud.size() << " points (" << unit_name(to) << ")\n";
    return 0;
  }
  write_mesh(out, mesh, {to, MeshFormat::kAuto, binary, io_warnings(), args.flag_set("double")});
  flush_warnings();
  std::cerr << "wrote " << out << ": " << mesh.num_vertices() << " vertices, " << mesh.num_faces() << " triangles (" << unit_name(to)
            << ")\n";
  return 0;
}

}  // namespace posekit::cli
