// posekit batch register: one source (the template) registered to many targets, its side made once.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "batch.h"
#include "cli.h"
#include "commands.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/core/units.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/checksum.h"
#include "posekit/io/mesh_io.h"
#include "posekit/registration/registration.h"
#include "posekit/registration/shape_space.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::cli::batch {
namespace fs = std::filesystem;

std::vector<BatchColumn> register_columns() {
  auto quality = [](const char* key, int digits) {
    return [key, digits](const nlohmann::ordered_json& r) { return number(r["quality"][key], digits); };
  };
  return {{"unit", [](const auto& r) { return r["unit"].template get<std::string>(); }},
          {"target_triangles", [](const auto& r) { return std::to_string(r["target_triangles"].template get<long>()); }},
          {"seconds", [](const auto& r) { return number(r["seconds"], 4); }},
          {"mean_distance_mm", quality("mean_distance_mm", 2)},
          {"p95_distance_mm", quality("p95_distance_mm", 2)},
          {"target_covered", quality("target_covered", 4)},
          {"normals_agree", quality("normals_agree", 4)},
          {"folded_triangles", [](const auto& r) { return std::to_string(r["quality"]["folded_triangles"].template get<long>()); }},
          {"shape_space_kept", [](const auto& r) {
             return r.contains("shape_space_kept") ? std::string(r["shape_space_kept"].template get<bool>() ? "1" : "0") : std::string();
           }}};
}

int run_batch_register(int argc, char** argv) {
  ArgParser args("batch register",
                 std::string("Registers one source body (e.g. the dataset's template) to many targets (posekit register):\n"
                             "the source's side of ct-FFD and the shape space are made once and shared by the jobs. Per\n"
                             "target: OUT/correspondence/<input>.json (each target triangle's source triangle, Eq. 2b/2c),\n"
                             "with --deformed the source on the target (OUT/deformed/<input>.ply, in the target file's frame\n"
                             "and unit), and the quality judged without ground truth in the summary. Units and\n"
                             "orientations are detected.") +
                     kBatchCommon);
  args.option("source", "FILE", "the source mesh registered to every target")
      .option("inputs", "DIR|LIST", "a folder of target meshes (recursively, in sorted order) or a text file of paths")
      .option("method", "M", "ctffd, icp or nicp", "ctffd")
      .option("shape-space", "N|FILE", "ctffd: refine by a shape space of N MakeHuman bodies or a .pks file (0: not)", "0")
      .data_option("for --shape-space N")
      .flag("refine", "ctffd: refine by soft non-rigid ICP steps")
      .flag("deformed", "also write the source deformed onto each target");
  add_batch_options(&args);
  args.example("posekit batch register --source dataset/template/rest.ply --inputs scans/ --shape-space makehuman300.pks --out registered");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"source", "inputs", "out"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  RegistrationOptions o;
  o.method = parse_registration_method(args.get("method"));
  o.refine = args.flag_set("refine");
  const std::string shape_arg = args.get("shape-space");
  if ((o.refine || shape_arg != "0") && o.method != RegistrationMethod::kCtffd)
    throw UsageError("--refine and --shape-space apply to --method ctffd");
  PreparedBody source = prepare_body(args.get("source"), "auto");
  if (source.in.is_cloud) throw InvalidInput(args.get("source") + ": the source must be a mesh (triangles); this file has only points");
  for (const std::string& w : source.warnings) std::cerr << "posekit batch register: " << args.get("source") << ": " << w << "\n";
  const TriangleMesh& source_mesh = source.in.mesh;
  o.shape_space = shape_space_option(shape_arg, "none", args.has("data") ? args.get("data") : "");
  if (o.shape_space && (o.shape_space->vertices() != source_mesh.num_vertices() ||
                        (o.shape_space->faces.size() > 0 && o.shape_space->faces != source_mesh.F)))
    throw InvalidInput(args.get("source") + ": the shape space is of another topology (" + std::to_string(o.shape_space->vertices()) +
                       " vertices; the source has " + std::to_string(source_mesh.num_vertices()) + ")");
  std::unique_ptr<const CtffdSource> prepared;
  if (o.method == RegistrationMethod::kCtffd) prepared = std::make_unique<const CtffdSource>(source_mesh, o.points_per_layer);
  const std::uint32_t space_crc = is_shape_space_file(shape_arg) ? file_crc32(shape_arg) : 0;
  const fs::path out = args.get("out"), corr_dir = out / "correspondence", deformed_dir = out / "deformed";
  const bool deformed = args.flag_set("deformed");
  create_folders(corr_dir.string());
  if (deformed) create_folders(deformed_dir.string());
  BatchJob job;
  job.command = "register";
  // A changed source or space file redoes every target.
  job.settings = {{"source", args.get("source")},
                  {"source_checksum", file_crc32(args.get("source"))},
                  {"method", args.get("method")},
                  {"shape_space", shape_arg},
                  {"shape_space_checksum", space_crc},
                  {"refine", o.refine},
                  {"deformed", deformed}};
  job.process = [&](const std::string& input, const std::string& stem) {
    PreparedBody target = prepare_body(input, "auto");
    if (target.in.is_cloud) throw InvalidInput(input + ": register needs a mesh (triangles); this file has only points");
    const TriangleMesh& mesh = target.in.mesh;
    const RegistrationResult r = prepared ? register_bodies(*prepared, mesh, o) : register_bodies(source_mesh, mesh, o);
    const RegistrationQuality q = assess_registration(source_mesh, r.deformed_source, mesh);
    nlohmann::json corr = {
        {"source", args.get("source")},
        {"target", input},
        {"method", args.get("method")},
        {"meaning", "target_to_source[k] is the source triangle matched to target triangle k"},
        {"target_to_source", std::vector<int>(r.correspondence.data(), r.correspondence.data() + r.correspondence.size())}};
    const std::string text = corr.dump() + "\n";
    write_file_atomically((corr_dir / (stem + ".json")).string(), [&](std::ostream& os) { os << text; }, false);
    std::vector<std::string> warnings = target.warnings;
    for (const std::string& w : r.warnings) warnings.push_back(w);
    for (const std::string& w : q.warnings) warnings.push_back(w);
    nlohmann::ordered_json result = {{"unit", unit_name(target.unit)},
                                     {"up", axis_name(target.orientation.up())},
                                     {"forward", axis_name(target.orientation.forward())},
                                     {"target_triangles", mesh.num_faces()},
                                     {"seconds", r.seconds},
                                     {"normal_failures", r.normal_failures},
                                     {"quality", registration_quality_json(q, false)},
                                     {"correspondence", (fs::path("correspondence") / (stem + ".json")).string()}};
    if (o.shape_space) {
      result["shape_space_kept"] = r.shape_fit.plausible;
      result["shape_space_median_distance_mm"] = 1000 * r.shape_fit.median_distance;
    }
    if (deformed) {
      TriangleMesh d;
      d.V = in_file_frame(target.orientation, r.deformed_source);
      d.F = source_mesh.F;
      std::vector<std::string> io;
      write_mesh((deformed_dir / (stem + ".ply")).string(), d, {target.unit, MeshFormat::kPly, true, &io});
      warnings.insert(warnings.end(), io.begin(), io.end());
      result["deformed"] = (fs::path("deformed") / (stem + ".ply")).string();
    }
    result["warnings"] = warnings;
    return result;
  };
  job.columns = register_columns();
  return run_batch_job(args, job, list_inputs(args.get("inputs")));
}

}  // namespace posekit::cli::batch
