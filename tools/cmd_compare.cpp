// posekit compare / view: a model against a scan, and VTK viewers for meshes with error fields.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <tuple>

#include "cli.h"
#include "commands.h"
#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/evaluation/scan_comparison.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/io/point_stream.h"
#include "posekit/viewers/viewer.h"

namespace posekit::cli {
namespace {

nlohmann::ordered_json stats_json(const DistanceStats& s) {
  return {{"mean_mm", s.mean_mm}, {"rms_mm", s.rms_mm},    {"p95_mm", s.p95_mm}, {"max_mm", s.max_mm}, {"signed_mean_mm", s.signed_mean_mm},
          {"count", s.count},     {"outliers", s.outliers}};
}

}  // namespace

ColourMap colour_map_from(const ArgParser& args, ColourMapKind default_kind) {
  ColourMap map;
  map.kind = default_kind;
  if (args.has("colours")) {
    const std::string c = args.get("colours");
    if (c == "diverging") map.kind = ColourMapKind::kDiverging;
    else if (c == "sequential") map.kind = ColourMapKind::kSequential;
    else if (c == "categorical") map.kind = ColourMapKind::kCategorical;
    else throw UsageError("--colours expects diverging, sequential or categorical, got '" + c + "'");
  }
  if (args.has("range")) {
    std::tie(map.min, map.max) = parse_number_pair(args.get("range"), ':', "--range (mm)");
    if (!(map.max > map.min)) throw UsageError("--range: MAX must exceed MIN");
    map.automatic = false;
  }
  return map;
}

RowMatrixX3u8 heatmap_from(const ArgParser& args, const Eigen::VectorXd& values, ColourMapKind default_kind) {
  const ColourMap map = colour_map_from(args, default_kind);
  if (map.kind == ColourMapKind::kCategorical) throw UsageError("--colours categorical colours labels, not a heatmap");
  const Eigen::VectorXd shown = map.kind == ColourMapKind::kSequential ? Eigen::VectorXd(values.cwiseAbs()) : values;
  const auto [lo, hi] = map.automatic ? heatmap_range(map.kind, {&shown}) : std::make_pair(map.min, map.max);
  return heatmap_colours(shown, map.kind, lo, hi);
}

/// --out, --scan-out and --png: the model and the scan with their distances, each in its file's own
/// frame and unit, and the heatmap.
void write_compared_files(const ArgParser& args, const TriangleMesh& model, const BodyOrientation& model_orientation,
                          const BodyUnit& model_unit, const PointCloud& scan, const BodyOrientation& scan_orientation,
                          const BodyUnit& scan_unit, const ScanComparison& r) {
  if (args.has("out")) {
    TriangleMesh out = model;  // written in the model file's own frame
    out.V = in_file_frame(model_orientation, model.V);
    if (out.has_normals()) out.N = in_file_frame(model_orientation, model.N);
    out.vertex_scalars["signed_distance_mm"] = 1000 * r.model_to_scan;
    // "coverage", not "covered": CloudCompare reads a property whose name holds "red" as the red channel.
    Eigen::VectorXd coverage(model.V.rows());
    for (Eigen::Index v = 0; v < coverage.size(); ++v) coverage[v] = std::isfinite(r.model_to_scan[v]) ? 1 : 0;
    out.vertex_scalars["coverage"] = coverage;
    if (mesh_format_from_path(args.get("out")) == MeshFormat::kGlb) {
      // glTF is metres, Y up, facing +Z: posekit's own frame. The heatmap as vertex colours.
      out.V = model.V;
      out.N = model.has_normals() ? model.N : Eigen::MatrixXd();
      out.C = heatmap_from(args, 1000 * r.model_to_scan, ColourMapKind::kDiverging);
      write_mesh(args.get("out"), out, {Unit::kMetre, MeshFormat::kGlb, true, io_warnings()});
    } else {
      write_mesh(args.get("out"), out, {model_unit.unit, MeshFormat::kAuto, true, io_warnings(), args.flag_set("double")});
    }
  }
  if (args.has("scan-out")) {
    PointCloud out = scan;  // in the scan file's own frame
    out.P = in_file_frame(scan_orientation, scan.P);
    if (out.has_normals()) out.N = in_file_frame(scan_orientation, scan.N);
    out.point_scalars["signed_distance_mm"] = 1000 * r.scan_to_model;
    write_point_cloud(args.get("scan-out"), out, {scan_unit.unit, CloudFormat::kAuto, true, io_warnings(), args.flag_set("double")});
  }
  if (args.has("png")) {
    ViewOptions v;
    v.colour_map = colour_map_from(args, ColourMapKind::kDiverging);
    v.colour_map.title = "model to scan (mm)";
    TriangleMesh shown = model;
    shown.vertex_scalars["signed_distance_mm"] = 1000 * r.model_to_scan;
    if (v.colour_map.kind == ColourMapKind::kSequential)
      shown.vertex_scalars["signed_distance_mm"] = shown.vertex_scalars["signed_distance_mm"].cwiseAbs();
    std::vector<ViewPanel> panels(2);
    for (int i = 0; i < 2; ++i) {
      panels[static_cast<size_t>(i)].mesh = shown;
      panels[static_cast<size_t>(i)].scalar = "signed_distance_mm";
      panels[static_cast<size_t>(i)].camera = i == 0 ? CameraPreset::kFront : CameraPreset::kBack;
      panels[static_cast<size_t>(i)].caption = i == 0 ? "front" : "back";
    }
    render_panels_png(panels, v, args.get("png"));
  }
}

/// The comparison as text: both directions' statistics, coverage, warnings and the girths.
void print_comparison(const ArgParser& args, Eigen::Index model_vertices, Eigen::Index scan_points, const ScanComparison& r,
                      const ScanComparisonOptions& o, const std::vector<GirthDiscrepancy>& girths,
                      const std::vector<std::string>& warnings) {
  std::cout << std::fixed << std::setprecision(2) << "compared " << args.positionals()[0] << " (" << model_vertices << " vertices) with "
            << args.positionals()[1] << " (" << scan_points << " points) in " << r.seconds
            << " s\n\n| direction | mean mm | RMS mm | 95th pct mm | max mm | signed mean mm | outliers (> " << 1000 * o.outlier_threshold
            << " mm) |\n|---|---|---|---|---|---|---|\n";
  for (auto [name, s] : {std::pair{"scan to model", &r.scan_stats}, std::pair{"model to scan", &r.model_stats}})
    std::cout << "| " << name << " | " << s->mean_mm << " | " << s->rms_mm << " | " << s->p95_mm << " | " << s->max_mm << " | "
              << s->signed_mean_mm << " | " << s->outliers << " |\n";
  std::cout << "\nHausdorff " << r.hausdorff_mm << " mm; coverage " << std::setprecision(1) << 100 * r.coverage << "% ("
            << r.uncovered_vertices << " model vertices without scan data within " << 1000 * r.coverage_radius << " mm)\n";
  for (const auto& w : warnings) std::cout << "\nwarning: " << w << "\n";
  if (!girths.empty()) {
    std::cout << "\n| measure | model cm | scan cm | difference cm | ISO 20685-1 tolerance mm | within |\n|---|---|---|---|---|---|\n";
    for (const auto& d : girths) {
      std::cout << "| " << d.name << " | ";
      if (d.measured)
        std::cout << d.model_cm << " | " << d.scan_cm << " | " << std::showpos << d.difference_cm << std::noshowpos << " | "
                  << d.tolerance_mm << " | " << (std::abs(d.difference_cm) * 10 <= d.tolerance_mm ? "yes" : "no") << " |\n";
      else std::cout << "- | - | - | " << d.tolerance_mm << " | " << d.note << " |\n";
    }
  }
}

int run_compare(int argc, char** argv) {
  ArgParser args("compare",
                 "Compares a model mesh with a scan (point cloud or mesh): scan-to-model point-to-triangle distance\n"
                 "(exact, AABB tree over the model's triangles) and model-to-scan distance (nearest scan point,\n"
                 "uniform grid) where the scan has data; vertices in scan holes are reported as uncovered, not as\n"
                 "error. Distances are signed by the model's outward normal (+: the scan lies outside the model).\n"
                 "All figures are in millimetres.");
  args.positional("model", "model mesh (PLY/OBJ/OFF/STL)")
      .positional("scan", "scan: PCD/PLY/XYZ cloud, or a mesh")
      .option("model-unit", "U", "unit of the model: m, dm, cm, mm, or auto (its largest extent tells)", "auto")
      .option("scan-unit", "U", "unit of the scan, as --model-unit", "auto")
      .option("model-up", "AXIS", "the axis the model stands along (+X, -Y, ...) or auto (detected)", "auto")
      .option("model-forward", "AXIS", "the axis the model faces, or auto (the feet tell)", "auto")
      .option("scan-up", "AXIS", "the same for the scan", "auto")
      .option("scan-forward", "AXIS", "the same for the scan", "auto")
      .option("threshold", "MM", "points beyond this distance are outliers, counted apart", "20")
      .option("coverage", "MM", "a vertex with no scan point this close is uncovered (0: 4x scan spacing, >= 10)", "0")
      .option("threads", "N", "threads (0: all cores)", "0")
      .output("out", "FILE",
              "the model with vertex scalars signed_distance_mm (NaN: uncovered) and coverage (0/1), as float32 "
              "PLY properties scalar_<name> (CloudCompare's names); .glb: glTF 2.0 (metres, Y up) with the heatmap (--colours, "
              "--range) as vertex colours")
      .output("scan-out", "FILE", "the scan with point scalar signed_distance_mm (PLY/PCD)")
      .output("png", "FILE", "heatmap of the model's error, front and back (off-screen VTK)")
      .option("range", "MIN:MAX", "colour range in mm (default: automatic)")
      .option("colours", "KIND", "diverging (signed) or sequential (|error|)", "diverging")
      .flag("double", "write --out/--scan-out as float64 (default: float32 where it keeps the values)")
      .flag("measure", "also measure both and print the girth discrepancies (cm) with ISO 20685-1 tolerances")
      .flag("json", "results as JSON on stdout")
      .example("posekit compare out/dataset/subjects/f01/rest.ply out/dataset/scans/f01/rest.pcd --measure --png f01.png");
  if (!args.parse(argc, argv)) return 0;
  BodyUnit model_unit, scan_unit;
  BodyInput model_input = read_body_input(args.positionals()[0], args.get("model-unit"), "compare", &model_unit);
  if (model_input.is_cloud) throw InvalidInput(args.positionals()[0] + ": the model must be a mesh (triangles); this file has only points");
  const BodyOrientation model_orientation =
      orient_body_input(&model_input, args.get("model-up"), args.get("model-forward"), args.positionals()[0], "compare");
  const TriangleMesh model = std::move(model_input.mesh);
  const std::string& scan_path = args.positionals()[1];
  ScanComparisonOptions o;
  o.outlier_threshold = args.get_double("threshold") / 1000;
  o.coverage_radius = args.get_double("coverage") / 1000;
  o.threads = static_cast<int>(args.get_int("threads"));
  if (!(o.outlier_threshold > 0)) throw UsageError("--threshold must be positive");
  // A large binary scan is compared as it is read, never whole in memory (unless its points are written out).
  constexpr Eigen::Index kStreamFrom = 3'000'000;
  std::unique_ptr<PointStream> stream;
  if (!args.has("scan-out") && !args.flag_set("measure") && is_point_cloud_file(scan_path)) {
    const Unit read_unit = args.get("scan-unit") == "auto" ? Unit::kMetre : parse_unit(args.get("scan-unit"));
    stream = PointStream::open(scan_path, metres_per_unit(read_unit), io_warnings());
    flush_warnings();
    if (stream && stream->size() < kStreamFrom) stream.reset();
    if (stream) scan_unit.unit = read_unit;
  }
  PointCloud scan;
  BodyOrientation scan_orientation;
  ScanComparison r;
  Eigen::Index scan_points = 0;
  try {
    if (stream) {
      // Unit and orientation from the same evenly spread sample the whole-cloud detection takes.
      constexpr Eigen::Index kSample = 200000;
      const Eigen::Index n = stream->size(), stride = (n + kSample - 1) / kSample, m = (n + stride - 1) / stride;
      BodyInput sample;
      sample.is_cloud = true;
      sample.cloud.P.resize(m, 3);
      Eigen::MatrixXd one;
      for (Eigen::Index i = 0; i < m; ++i) {
        stream->read(i * stride, 1, &one);
        sample.cloud.P.row(i) = one.row(0);
      }
      stream->release(n);  // the sample touched every page of the file
      if (args.get("scan-unit") == "auto") scan_unit = detect_body_unit(&sample.cloud.P, scan_path, "compare");
      scan_orientation = orient_body_input(&sample, args.get("scan-up"), args.get("scan-forward"), scan_path, "compare");
      const double factor = scan_unit.detected ? metres_per_unit(scan_unit.unit) : 1.0;
      const Eigen::Matrix3d Rt = scan_orientation.rotation.transpose();
      ScanPieces pieces;
      pieces.size = n;
      pieces.read = [&](Eigen::Index first, Eigen::Index count, Eigen::MatrixXd* P) {
        stream->read(first, count, P);
        if (factor != 1) *P *= factor;
        if (!scan_orientation.is_identity()) *P = (*P * Rt).eval();
      };
      pieces.release = [&](Eigen::Index end) { stream->release(end); };
      scan_points = n;
      r = compare_with_scan(model, pieces, o);
    } else {
      BodyInput scan_input = read_body_input(scan_path, args.get("scan-unit"), "compare", &scan_unit);
      scan_orientation = orient_body_input(&scan_input, args.get("scan-up"), args.get("scan-forward"), scan_path, "compare");
      scan = std::move(scan_input.cloud);
      if (!scan_input.is_cloud) scan.P = std::move(scan_input.mesh.V);
      if (scan.P.rows() == 0) throw InvalidInput(scan_path + ": the scan has no points");
      scan_points = scan.P.rows();
      r = compare_with_scan(model, scan, o);
    }
  } catch (const InvalidInput& e) {
    const std::string what = e.what();
    if (what.rfind(scan_path, 0) == 0) throw;  // the scan file's own problem, already named
    throw InvalidInput(scan_path + " against " + args.positionals()[0] + ": " + what + " (set --scan-unit / --model-unit)");
  }
  // The girths are an optional extra: when they cannot be taken, the distances still stand.
  std::vector<GirthDiscrepancy> girths;
  std::vector<std::string> warnings;
  if (args.flag_set("measure")) {
    try {
      girths = girth_discrepancies(model, scan);
    } catch (const InvalidInput& e) {
      warnings.push_back(std::string("girths not compared: ") + e.what());
      std::cerr << "posekit compare: warning: " << warnings.back() << "\n";
    }
  }

  write_compared_files(args, model, model_orientation, model_unit, scan, scan_orientation, scan_unit, r);

  nlohmann::ordered_json g = nlohmann::ordered_json::array();
  for (const auto& d : girths)
    g.push_back({{"name", d.name},
                 {"model_cm", d.model_cm},
                 {"scan_cm", d.scan_cm},
                 {"difference_cm", d.difference_cm},
                 {"measured", d.measured},
                 {"iso20685_tolerance_mm", d.tolerance_mm},
                 {"within_tolerance", d.measured && std::abs(d.difference_cm) * 10 <= d.tolerance_mm},
                 {"note", d.note}});
  nlohmann::ordered_json out = {{"model", args.positionals()[0]},
                                {"scan", args.positionals()[1]},
                                {"units", "mm"},
                                {"scan_points", scan_points},
                                {"model_vertices", model.V.rows()},
                                {"scan_to_model", stats_json(r.scan_stats)},
                                {"model_to_scan", stats_json(r.model_stats)},
                                {"hausdorff_mm", r.hausdorff_mm},
                                {"coverage", r.coverage},
                                {"uncovered_vertices", r.uncovered_vertices},
                                {"coverage_radius_mm", 1000 * r.coverage_radius},
                                {"outlier_threshold_mm", 1000 * o.outlier_threshold},
                                {"seconds", r.seconds}};
  out["model_unit"] = {{"unit", unit_name(model_unit.unit)}, {"detected", model_unit.detected}};
  out["scan_unit"] = {{"unit", unit_name(scan_unit.unit)}, {"detected", scan_unit.detected}};
  out["model_orientation"] = orientation_json(model_orientation);
  out["scan_orientation"] = orientation_json(scan_orientation);
  if (!girths.empty()) out["girths"] = g;
  out["warnings"] = warnings;
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  print_comparison(args, model.V.rows(), scan_points, r, o, girths, warnings);
  return 0;
}

}  // namespace posekit::cli
