// posekit batch compare: many models against their scans (distances, coverage, girth discrepancies).
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
#include "posekit/evaluation/scan_comparison.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/shape/measurements.h"
#include "posekit/viewers/viewer.h"

namespace posekit::cli::batch {
namespace fs = std::filesystem;

/// "MODEL SCAN" (separated by a tab, a comma or spaces) or, with a shared model, "SCAN".
std::pair<std::string, std::string> model_and_scan(const std::string& line, const std::string& shared_model) {
  if (!shared_model.empty()) return {shared_model, line};
  size_t cut = line.find('\t');
  if (cut == std::string::npos) cut = line.find(',');
  if (cut == std::string::npos) cut = line.find(' ');
  if (cut == std::string::npos)
    throw InvalidInput("'" + line + "': expected a model and a scan on the line (MODEL SCAN), or give --model for all scans");
  const size_t scan_start = line.find_first_not_of(" \t,", cut);
  if (scan_start == std::string::npos) throw InvalidInput("'" + line + "': no scan after the model");
  return {line.substr(0, cut), line.substr(scan_start)};
}

nlohmann::ordered_json distance_stats_json(const DistanceStats& s) {
  return {{"mean_mm", s.mean_mm}, {"rms_mm", s.rms_mm},    {"p95_mm", s.p95_mm}, {"max_mm", s.max_mm}, {"signed_mean_mm", s.signed_mean_mm},
          {"count", s.count},     {"outliers", s.outliers}};
}

std::vector<BatchColumn> compare_columns(bool measure) {
  auto stat = [](const char* direction, const char* key) {
    return [direction, key](const nlohmann::ordered_json& r) { return number(r[direction][key], 3); };
  };
  std::vector<BatchColumn> columns = {{"model", [](const auto& r) { return r["model"].template get<std::string>(); }},
                                      {"scan", [](const auto& r) { return r["scan"].template get<std::string>(); }},
                                      {"scan_points", [](const auto& r) { return std::to_string(r["scan_points"].template get<long>()); }},
                                      {"scan_to_model_mean_mm", stat("scan_to_model", "mean_mm")},
                                      {"scan_to_model_rms_mm", stat("scan_to_model", "rms_mm")},
                                      {"scan_to_model_p95_mm", stat("scan_to_model", "p95_mm")},
                                      {"model_to_scan_mean_mm", stat("model_to_scan", "mean_mm")},
                                      {"model_to_scan_p95_mm", stat("model_to_scan", "p95_mm")},
                                      {"hausdorff_mm", [](const auto& r) { return number(r["hausdorff_mm"], 3); }},
                                      {"coverage", [](const auto& r) { return number(r["coverage"], 4); }}};
  if (measure)
    for (const char* g : {"stature", "bust", "waist", "hip"})
      columns.push_back({std::string(g) + "_difference_cm", [g](const auto& r) {
                           if (!r.contains("girths") || !r["girths"].contains(g)) return std::string();
                           const auto& d = r["girths"][g];
                           return d.value("measured", false) ? number(d["difference_cm"], 2) : std::string();
                         }});
  return columns;
}

int run_batch_compare(int argc, char** argv) {
  ArgParser args("batch compare",
                 std::string("Compares many models with their scans (posekit compare, one pair per input): the distances\n"
                             "both ways in mm, coverage and, with --measure, the girth discrepancies with ISO 20685-1\n"
                             "tolerances. Units come from each body's extent and orientations are detected. One result per\n"
                             "pair in OUT/results, OUT/summary.json and summary.csv; --heatmaps adds each model with its\n"
                             "signed_distance_mm scalar in OUT/heatmaps (PLY, in the model file's frame and unit).") +
                     kBatchCommon);
  args.option("inputs", "DIR|LIST",
              "a text file of pairs, one per line: MODEL SCAN (separated by a tab, a comma or a space); with "
              "--model, a folder or list of scans")
      .option("model", "FILE", "one model for every scan (e.g. a person's body against the scans of a session)")
      .option("threshold", "MM", "points beyond this distance are outliers, counted apart", "20")
      .option("coverage", "MM", "a vertex with no scan point this close is uncovered (0: 4x scan spacing, >= 10)", "0")
      .flag("measure", "also measure both and report the girth discrepancies (cm)")
      .flag("heatmaps", "write each model with its signed distances (OUT/heatmaps/<input>.ply)");
  add_batch_options(&args);
  args.example("posekit batch compare --inputs pairs.txt --out compared --measure")
      .example("posekit batch compare --model f01_customized.ply --inputs scans/f01/ --out f01_vs_scans --heatmaps");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("inputs") || !args.has("out")) throw UsageError("--inputs and --out are required");
  const std::string shared_model = args.has("model") ? args.get("model") : "";
  if (shared_model.empty() && fs::is_directory(args.get("inputs")))
    throw UsageError("--inputs " + args.get("inputs") + " is a folder of scans: give --model, or a list of MODEL SCAN pairs");
  ScanComparisonOptions o;
  o.outlier_threshold = args.get_double("threshold") / 1000;
  o.coverage_radius = args.get_double("coverage") / 1000;
  o.threads = 1;  // one pair per job
  if (!(o.outlier_threshold > 0)) throw UsageError("--threshold must be positive");
  const bool measure = args.flag_set("measure"), heatmaps = args.flag_set("heatmaps");
  const fs::path heatmap_dir = fs::path(args.get("out")) / "heatmaps";
  if (heatmaps) create_folders(heatmap_dir.string());
  BatchJob job;
  job.command = "compare";
  job.settings = {{"model", shared_model},
                  {"threshold_mm", 1000 * o.outlier_threshold},
                  {"coverage_mm", 1000 * o.coverage_radius},
                  {"measure", measure},
                  {"heatmaps", heatmaps}};
  job.files = [&](const std::string& input) {
    const auto [model_path, scan_path] = model_and_scan(input, shared_model);
    return std::vector<std::string>{model_path, scan_path};
  };
  job.process = [&](const std::string& input, const std::string& stem) {
    const auto [model_path, scan_path] = model_and_scan(input, shared_model);
    PreparedBody model = prepare_body(model_path, "auto");
    if (model.in.is_cloud) throw InvalidInput(model_path + ": the model must be a mesh (triangles); this file has only points");
    PreparedBody scan = prepare_body(scan_path, "auto");
    PointCloud cloud = scan.in.cloud;
    if (!scan.in.is_cloud) cloud.P = scan.in.mesh.V;
    if (cloud.P.rows() == 0) throw InvalidInput(scan_path + ": the scan has no points");
    ScanComparison c;
    try {
      c = compare_with_scan(model.in.mesh, cloud, o);
    } catch (const InvalidInput& e) {
      throw InvalidInput(scan_path + " against " + model_path + ": " + e.what());
    }
    nlohmann::ordered_json r = {{"model", model_path},
                                {"scan", scan_path},
                                {"model_unit", unit_name(model.unit)},
                                {"scan_unit", unit_name(scan.unit)},
                                {"scan_points", cloud.P.rows()},
                                {"model_vertices", model.in.mesh.V.rows()},
                                {"scan_to_model", distance_stats_json(c.scan_stats)},
                                {"model_to_scan", distance_stats_json(c.model_stats)},
                                {"hausdorff_mm", c.hausdorff_mm},
                                {"coverage", c.coverage}};
    std::vector<std::string> warnings = model.warnings;
    warnings.insert(warnings.end(), scan.warnings.begin(), scan.warnings.end());
    if (measure) {
      try {
        for (const auto& d : girth_discrepancies(model.in.mesh, cloud)) {
          nlohmann::ordered_json g = {{"measured", d.measured}, {"iso20685_tolerance_mm", d.tolerance_mm}};
          if (d.measured) g["difference_cm"] = d.difference_cm, g["within_tolerance"] = std::abs(d.difference_cm) * 10 <= d.tolerance_mm;
          else g["note"] = d.note;
          r["girths"][d.name] = g;
        }
      } catch (const InvalidInput& e) {
        warnings.push_back(std::string("girths not compared: ") + e.what());
      }
    }
    if (heatmaps) {
      TriangleMesh shown = model.in.mesh;
      shown.V = in_file_frame(model.orientation, model.in.mesh.V);
      if (shown.has_normals()) shown.N = in_file_frame(model.orientation, model.in.mesh.N);
      shown.vertex_scalars["signed_distance_mm"] = 1000 * c.model_to_scan;
      const std::string path = (heatmap_dir / (stem + ".ply")).string();
      std::vector<std::string> io;
      write_mesh(path, shown, {model.unit, MeshFormat::kPly, true, &io});
      r["heatmap"] = (fs::path("heatmaps") / (stem + ".ply")).string();  // relative to OUT
      warnings.insert(warnings.end(), io.begin(), io.end());
    }
    r["warnings"] = warnings;
    return r;
  };
  job.columns = compare_columns(measure);
  std::vector<std::string> inputs;
  if (!shared_model.empty()) {
    inputs = list_inputs(args.get("inputs"));
  } else {
    std::istringstream lines(read_file_bytes(args.get("inputs")));
    for (std::string line; std::getline(lines, line);) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty() && line[0] != '#') inputs.push_back(line);
    }
    if (inputs.empty()) throw InvalidInput(args.get("inputs") + ": no MODEL SCAN pairs");
  }
  return run_batch_job(args, job, inputs);
}

}  // namespace posekit::cli::batch
