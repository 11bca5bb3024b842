// posekit bench <what>: timings reported as median/min/max over several runs (never timed tests).
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>

#include "bench_tools.h"
#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/body/bvh_retarget.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/skinning.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/parallel.h"
#include "posekit/core/timer.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/datasets/dataset.h"
#include "posekit/datasets/remesh.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/segmentation_calibration.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/evaluation/scan_comparison.h"
#include "posekit/fitting/fitted_measurements.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/paper/registration_table.h"
#include "posekit/registration/registration.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/measurements.h"

namespace posekit::cli {
namespace {

using Clock = std::chrono::steady_clock;

/// A closed torus-like tube mesh with about `triangles` triangles (2 per grid cell).
TriangleMesh make_torus(long triangles) {
  const int n = std::max(8, static_cast<int>(std::sqrt(triangles / 2.0)));
  TriangleMesh mesh;
  mesh.V.resize(static_cast<Eigen::Index>(n) * n, 3);
  mesh.F.resize(2L * n * n, 3);
  for (int i = 0; i < n; ++i)
    for (int j = 0; j < n; ++j) {
      const double u = 2 * M_PI * i / n, v = 2 * M_PI * j / n;
      mesh.V.row(i * n + j) << (0.5 + 0.2 * std::cos(v)) * std::cos(u), 0.2 * std::sin(v), (0.5 + 0.2 * std::cos(v)) * std::sin(u);
      const int a = i * n + j, b = ((i + 1) % n) * n + j, c = ((i + 1) % n) * n + (j + 1) % n, d = i * n + (j + 1) % n;
      mesh.F.row(2 * a) << a, b, c;
      mesh.F.row(2 * a + 1) << a, c, d;
    }
  return mesh;
}

template <typename F>
Stats time_runs(int runs, const std::string& label, F&& body) {
  std::vector<double> seconds;
  Progress progress(label, runs);
  for (int r = 0; r < runs; ++r) {
    const Stopwatch t0;
    body();
    seconds.push_back(t0.seconds());
    progress.update(r + 1);
  }
  progress.finish();
  return stats_of(seconds);
}

int bench_io(int argc, char** argv) {
  ArgParser args("bench io",
                 "Times reading large files: binary PLY, OBJ and binary STL meshes and a binary PCD cloud.\n"
                 "Files are generated in a temporary folder and removed afterwards.");
  args.option("triangles", "N", "triangles of the test mesh", "1000000")
      .option("points", "N", "points of the test cloud", "1000000")
      .option("runs", "R", "timed runs per format (median reported)", "5")
      .option("tmp", "DIR", "folder for the temporary files", std::filesystem::temp_directory_path().string())
      .flag("json", "machine-readable results on stdout");
  if (!args.parse(argc, argv)) return 0;
  const long triangles = args.get_int("triangles");
  const long points = args.get_int("points");
  const int runs = static_cast<int>(args.get_int("runs"));
  if (triangles < 100 || points < 1 || runs < 1) throw UsageError("--triangles >= 100, --points >= 1, --runs >= 1");
  const auto dir = std::filesystem::path(args.get("tmp")) / ("posekit-bench-io-" + std::to_string(::getpid()));
  create_folders(dir.string());
  nlohmann::json results = nlohmann::json::array();
  try {
    const TriangleMesh mesh = make_torus(triangles);
    PointCloud cloud;
    cloud.P = Eigen::MatrixXd::Random(points, 3);
    struct Case {
      std::string name, file;
    };
    for (const Case& c : {Case{"ply_binary", "m.ply"}, Case{"obj", "m.obj"}, Case{"stl_binary", "m.stl"}}) {
      const std::string path = (dir / c.file).string();
      write_mesh(path, mesh);
      const auto size = std::filesystem::file_size(path);
      long read_faces = 0;
      const Stats s = time_runs(runs, "read " + c.name, [&] { read_faces = read_mesh(path).num_faces(); });
      if (read_faces != mesh.num_faces()) throw Error("bench io: " + c.name + " read back " + std::to_string(read_faces) + " faces");
      results.push_back({{"case", "read " + c.name},
                         {"elements", mesh.num_faces()},
                         {"element", "triangles"},
                         {"file_mib", size / 1048576.0},
                         {"median_s", s.median},
                         {"min_s", s.min},
                         {"max_s", s.max}});
    }
    const std::string pcd = (dir / "c.pcd").string();
    write_point_cloud(pcd, cloud);
    const auto size = std::filesystem::file_size(pcd);
    const Stats s = time_runs(runs, "read pcd_binary", [&] { (void)read_point_cloud(pcd); });
    results.push_back({{"case", "read pcd_binary"},
                       {"elements", points},
                       {"element", "points"},
                       {"file_mib", size / 1048576.0},
                       {"median_s", s.median},
                       {"min_s", s.min},
                       {"max_s", s.max}});
  } catch (...) {
    std::filesystem::remove_all(dir);
    throw;
  }
  std::filesystem::remove_all(dir);
  nlohmann::json out = {{"benchmark", "io"}, {"runs", runs}, {"results", results}, {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << "| case | elements | file MiB | median s | min s | max s |\n|---|---|---|---|---|---|\n" << std::fixed;
  for (const auto& r : results)
    std::cout << "| " << r["case"].get<std::string>() << " | " << r["elements"] << " " << r["element"].get<std::string>() << " | "
              << std::setprecision(1) << r["file_mib"].get<double>() << " | " << std::setprecision(3) << r["median_s"].get<double>()
              << " | " << r["min_s"].get<double>() << " | " << r["max_s"].get<double>() << " |\n";
  std::cout << "peak RSS: " << std::setprecision(0) << out["peak_rss_mib"].get<double>() << " MiB, " << runs << " runs each\n";
  return 0;
}

/// A table row of timings in milliseconds: median, min and max of `seconds`.
nlohmann::json ms_row(const std::string& name, const std::vector<double>& seconds) {
  const Stats s = stats_of(seconds);
  return nlohmann::json{{"case", name}, {"median_ms", s.median * 1e3}, {"min_ms", s.min * 1e3}, {"max_ms", s.max * 1e3}};
}

/// Prints rows of ms_row as a Markdown table.
void print_ms_table(const nlohmann::json& rows, int precision) {
  std::cout << "| case | median ms | min ms | max ms |\n|---|---|---|---|\n" << std::fixed << std::setprecision(precision);
  for (const auto& r : rows)
    std::cout << "| " << r["case"].get<std::string>() << " | " << r["median_ms"].get<double>() << " | " << r["min_ms"].get<double>()
              << " | " << r["max_ms"].get<double>() << " |\n";
}

int bench_body(int argc, char** argv) {
  ArgParser args("bench body",
                 "Times building a MakeHuman body from a spec and posing it (13,380 vertices): the model is\n"
                 "loaded once, then each run shapes a body and skins it into a 16-part pose, single thread.");
  args.data_option().option("runs", "R", "timed runs (median reported)", "50").flag("json", "machine-readable results on stdout");
  if (!args.parse(argc, argv)) return 0;
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  const Stopwatch t0;
  const auto model = load_makehuman_model(find_data_root(args.get("data")));
  const double load_s = t0.seconds();
  BodySpec spec;
  spec.gender = 0.8;
  spec.weight = 0.7;
  spec.muscle = 0.3;
  spec.height = 0.6;
  spec.modifiers["measure/measure-waist-circ-decr|incr"] = 0.3;
  PartPose pose;
  pose.joint_rotation[find_joint_index("left_elbow")] = Eigen::Vector3d(1.2, 0.3, 0);
  pose.joint_rotation[find_joint_index("right_knee")] = Eigen::Vector3d(1.0, 0, 0);
  pose.joint_rotation[find_joint_index("left_shoulder")] = Eigen::Vector3d(0, 0, 0.9);
  double checksum = 0;
  std::vector<double> build_s, lbs_s, dqs_s, total_s;
  Progress progress("bench body", runs);
  for (int r = 0; r < runs; ++r) {
    const auto a = Clock::now();
    const Body body = build_body(*model, spec);
    const auto b = Clock::now();
    const BoneTransforms T = pose_bone_transforms(model->rig, body.bone_heads, bone_pose_from_part_pose(model->rig, pose));
    const Eigen::MatrixXd U = linear_blend_skinning(body.mesh.V, model->weights, T);
    const auto c = Clock::now();
    const Eigen::MatrixXd D = dual_quaternion_skinning(body.mesh.V, model->weights, T);
    const auto d = Clock::now();
    checksum += U(0, 0) + D(0, 0);
    build_s.push_back(seconds_between(a, b));
    lbs_s.push_back(seconds_between(b, c));
    dqs_s.push_back(seconds_between(c, d));
    total_s.push_back(seconds_between(a, c));
    progress.update(r + 1);
  }
  progress.finish();
  nlohmann::json results = nlohmann::json::array({ms_row("build body (shape + joints)", build_s), ms_row("pose, LBS", lbs_s),
                                                  ms_row("pose, DQS", dqs_s), ms_row("build + pose (LBS)", total_s)});
  nlohmann::json out = {{"benchmark", "body"}, {"vertices", model->num_body_vertices}, {"runs", runs},        {"model_load_s", load_s},
                        {"results", results},  {"peak_rss_mib", peak_rss_mib()},       {"checksum", checksum}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  print_ms_table(results, 2);
  std::cout << model->num_body_vertices << " vertices, " << runs << " runs, model load " << std::setprecision(3) << load_s
            << " s, peak RSS " << std::setprecision(0) << out["peak_rss_mib"].get<double>() << " MiB\n";
  return 0;
}

int bench_customize(int argc, char** argv) {
  ArgParser args("bench customize",
                 "Times customization from photos (section 3.2) on every subject of a dataset: silhouettes from the\n"
                 "two PNG photos (background model + GrabCut), then 2-D features, learned sections and ct-FFD to a\n"
                 "mesh; the model is loaded once. Single thread apart from OpenCV's own.");
  args.option("dataset", "DIR", "dataset folder (posekit dataset make)")
      .customization_model_option()
      .option("runs", "R", "timed runs per subject (median over all reported)", "5")
      .flag("json", "machine-readable results on stdout");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("bench customize needs --dataset DIR");
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  const Stopwatch t0;
  const CustomizationModel model = load_customization_model(args.get("model"));
  const double load_s = t0.seconds();
  const std::filesystem::path root(args.get("dataset"));
  std::ifstream in(root / "manifest.json");
  if (!in) throw IoError("cannot open " + (root / "manifest.json").string());
  nlohmann::json manifest;
  in >> manifest;
  std::vector<double> sil_s, body_s, total_s;
  Progress progress("bench customize", static_cast<long>(manifest.at("subjects").size()) * runs);
  long done = 0;
  for (const auto& subject : manifest.at("subjects")) {
    const auto& ph = subject.at("photos");
    const PhotoCameras cams = read_photo_cameras((root / ph.at("camera").get<std::string>()).string());
    for (int r = 0; r < runs; ++r) {
      const auto a = Clock::now();
      const Silhouette front = silhouette_from_photo((root / ph.at("front").get<std::string>()).string(), "front photo");
      const Silhouette side = silhouette_from_photo((root / ph.at("side").get<std::string>()).string(), "side photo");
      const auto b = Clock::now();
      const CustomizedBody body = customize_from_silhouettes(front, side, cams, model);
      const auto c = Clock::now();
      if (body.mesh.V.rows() == 0) throw InvalidInput("bench customize: empty result");
      sil_s.push_back(seconds_between(a, b));
      body_s.push_back(seconds_between(b, c));
      total_s.push_back(seconds_between(a, c));
      progress.update(++done);
    }
  }
  progress.finish();
  nlohmann::json results =
      nlohmann::json::array({ms_row("silhouettes from the two photos", sil_s), ms_row("features, sections, ct-FFD to a mesh", body_s),
                             ms_row("photos to mesh", total_s)});
  nlohmann::json out = {{"benchmark", "customize"},
                        {"subjects", manifest.at("subjects").size()},
                        {"runs", runs},
                        {"model_load_s", load_s},
                        {"results", results},
                        {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  print_ms_table(results, 1);
  std::cout << manifest.at("subjects").size() << " subjects x " << runs << " runs, model load " << std::setprecision(2) << load_s
            << " s, peak RSS " << std::setprecision(0) << out["peak_rss_mib"].get<double>() << " MiB\n";
  return 0;
}

int bench_registration(int argc, char** argv) {
  ArgParser args("bench registration",
                 "The paper's Table 1 on this machine: the template registered to every subject of a dataset by\n"
                 "ct-FFD (whole, and with the template's side made once; and refined by non-rigid ICP), by PCL's\n"
                 "rigid ICP (1 and 6 iterations) and by optimal-step non-rigid ICP, each followed by the\n"
                 "nearest-centroid correspondence; median/min/max\n"
                 "time over several runs (single thread; --threads adds the ct-FFD rows on more) and correspondence\n"
                 "error against the dataset's ground truth (mm): point error (mean, p95, max) and Eq. 2b's triangle\n"
                 "match (mean, p95).");
  args.option("dataset", "DIR", "a posekit dataset (posekit dataset make)")
      .option("runs", "R", "timed runs per method and subject", "5")
      .option("subjects", "N", "use only the first N subjects (0: all)", "0")
      .option("nicp-runs", "R", "timed runs of non-rigid ICP (seconds each; 0 leaves it out)", "1")
      .pose_model_option("also each correspondence's pose-transfer error on the posed subjects")
      .flag("other-topologies", "also to each subject remeshed to ~6,900 vertices and to a ~50,000-vertex remesh with 25 holes")
      .option("shape-space", "N|FILE",
              "also ct-FFD refined by a shape space of N MakeHuman bodies or a .pks file (posekit "
              "shape-space) (0: not)",
              "300")
      .option("shape-space-leave-out", "WHAT",
              "none, men (gender over 0.5), obese (BMI 30 and over) or local (the subjects' "
              "measure modifiers): what the shape space's population lacks",
              "none")
      .data_option("for the shape space")
      .option("threads", "T", "also the ct-FFD rows (whole, prepared, + shape space) on T threads (1: not)", "1")
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  const std::string dir = args.get("dataset");
  const long threads = args.get_int("threads");
  if (threads < 1 || threads > 256) throw UsageError("--threads must be between 1 and 256");
  const std::shared_ptr<const ShapeSpace> shape_space =
      shape_space_option(args.get("shape-space"), args.get("shape-space-leave-out"), args.get("data"));
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  const int nicp_runs = static_cast<int>(args.get_int("nicp-runs"));
  if (nicp_runs < 0) throw UsageError("--nicp-runs must not be negative");
  RegistrationTableOptions o;
  o.runs = runs;
  o.nicp_runs = nicp_runs;
  o.subjects = static_cast<int>(args.get_int("subjects"));
  o.other_topologies = args.flag_set("other-topologies");
  o.shape_space = shape_space;
  o.ctffd_threads = static_cast<int>(threads);
  if (args.has("model")) o.model = std::make_shared<const PoseModel>(read_pose_model(args.get("model")));
  std::unique_ptr<Progress> progress;
  o.progress = [&](int done, int total) {
    if (!progress) progress = std::make_unique<Progress>("bench registration", total);
    progress->update(done);
  };
  const RegistrationTable table = measure_registration_table(dir, o);
  if (progress) progress->finish();
  const int count = static_cast<int>(table.subject_ids.size());
  const auto table_json = [&](const RegistrationTable& t) {
    nlohmann::ordered_json rows = nlohmann::ordered_json::array();
    for (const auto& row : t.rows)
      rows.push_back({{"method", row.method},
                      {"median_s", row.median_s},
                      {"min_s", row.min_s},
                      {"max_s", row.max_s},
                      {"point_mean_mm", row.point_mean_mm},
                      {"point_p95_mm", row.point_p95_mm},
                      {"point_max_mm", row.point_max_mm},
                      {"worst_subject_point_mean_mm", row.worst_subject_point_mean_mm},
                      {"subject_point_mean_mm", row.subject_point_mean_mm},
                      {"mean_error_mm", row.mean_error_mm},
                      {"p95_error_mm", row.p95_error_mm},
                      {"worst_subject_mean_error_mm", row.worst_subject_mean_error_mm},
                      {"subject_mean_error_mm", row.subject_mean_error_mm},
                      {"pose_transfer_mm", row.pose_transfer_mm}});
    return nlohmann::ordered_json{{"targets", t.targets},
                                  {"mean_subject_vertices", t.mean_subject_vertices},
                                  {"mean_subject_triangles", t.mean_subject_triangles},
                                  {"triangle_floor_mean_mm", t.triangle_floor_mean_mm},
                                  {"triangle_floor_p95_mm", t.triangle_floor_p95_mm},
                                  {"pose_transfer_true_mm", t.pose_transfer_true_mm},
                                  {"ctffd_template_s", t.ctffd_template_seconds},
                                  {"results", rows}};
  };
  nlohmann::ordered_json out = {{"benchmark", "registration"},
                                {"subjects", count},
                                {"runs", runs},
                                {"ctffd_threads", threads},
                                {"template_vertices", table.template_vertices},
                                {"template_triangles", table.template_triangles},
                                {"subject_ids", table.subject_ids}};
  out.update(table_json(table));
  nlohmann::ordered_json others = nlohmann::ordered_json::array();
  for (const RegistrationTable& t : table.other_targets) others.push_back(table_json(t));
  out["other_targets"] = others;
  out["peak_rss_mib"] = peak_rss_mib();
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << "Registration of the template (" << table.template_vertices << " vertices), " << runs << " runs each (non-rigid ICP "
            << nicp_runs << "), single thread"
            << (threads > 1 ? " except the rows marked (" + std::to_string(threads) + " threads)" : std::string()) << "\n"
            << std::fixed;
  std::vector<nlohmann::ordered_json> sets = {out};
  for (const auto& t : others) sets.push_back(t);
  for (const auto& set : sets) {
    std::cout
        << "\nTo " << set["targets"].get<std::string>() << " (" << count << ", ~" << set["mean_subject_vertices"] << " vertices, ~"
        << set["mean_subject_triangles"] << " triangles)\n\n"
        << "| method | median s | min s | max s | point mean mm | p95 | max | worst subject | triangle mean mm | p95 | pose transfer mm |\n"
        << "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const auto& r : set["results"])
      std::cout << "| " << r["method"].get<std::string>() << " | " << std::setprecision(3) << r["median_s"].get<double>() << " | "
                << r["min_s"].get<double>() << " | " << r["max_s"].get<double>() << " | " << std::setprecision(1)
                << r["point_mean_mm"].get<double>() << " | " << r["point_p95_mm"].get<double>() << " | " << r["point_max_mm"].get<double>()
                << " | " << r["worst_subject_point_mean_mm"].get<double>() << " | " << r["mean_error_mm"].get<double>() << " | "
                << r["p95_error_mm"].get<double>() << " | "
                << (r["pose_transfer_mm"].get<double>() >= 0 ? std::to_string(r["pose_transfer_mm"].get<double>()).substr(0, 5) : "")
                << " |\n";
    if (set["pose_transfer_true_mm"].get<double>() >= 0)
      std::cout << "\nPose transfer (learned, the subjects' posed ground truth) with the true correspondence: "
                << set["pose_transfer_true_mm"].get<double>() << " mm";
    std::cout << "\nct-FFD's template side (features, representation, parametrisation), made once: " << std::setprecision(3)
              << set["ctffd_template_s"].get<double>() << " s" << std::setprecision(1);
    std::cout << "\nTriangle match of the true correspondence itself: mean " << set["triangle_floor_mean_mm"].get<double>() << " mm, p95 "
              << set["triangle_floor_p95_mm"].get<double>() << " mm\n";
  }
  std::cout << "\nPaper (Matlab, Core i7, 12,428 vertices): ICP 1 iteration 24 s, 6 iterations 229 s, ct-FFD 5.1 s.\n";
  return 0;
}

/// A motion of `frames` frames: consecutive poses blended (joint by joint, axis-angle), about 10
/// frames apart, as a capture at a steady rate would sample them.
std::vector<PartPose> blended_motion(const std::vector<PartPose>& poses, long frames) {
  std::vector<PartPose> motion(static_cast<size_t>(frames));
  for (long f = 0; f < frames; ++f) {
    const double at = static_cast<double>(f) / 10.0;
    const size_t i = static_cast<size_t>(at) % poses.size(), next = (i + 1) % poses.size();
    const double w = at - std::floor(at);
    PartPose& p = motion[static_cast<size_t>(f)];
    for (int j = 0; j < kNumJoints; ++j) p.joint(j) = (1 - w) * poses[i].joint(j) + w * poses[next].joint(j);
    p.root_rotation = (1 - w) * poses[i].root_rotation + w * poses[next].root_rotation;
  }
  return motion;
}

/// bench pose's table, from its JSON.
void print_bench_pose(const nlohmann::ordered_json& out, double prior_seconds, bool per_stage) {
  // "median | min | max" of a statistic.
  auto j = [](const nlohmann::ordered_json& o, const char* key) {
    std::ostringstream row;
    row << std::fixed << std::setprecision(3) << o[key]["median"].get<double>() << " | " << o[key]["min"].get<double>() << " | "
        << o[key]["max"].get<double>();
    return row.str();
  };
  std::cout << std::fixed << std::setprecision(3) << "Pose deformation, single thread: " << out["training_poses"] << " training poses, "
            << out["subjects"] << " subjects of ~" << out["mean_subject_vertices"] << " vertices\n\n"
            << "| stage | median | min | max |\n|---|---|---|---|\n"
            << "| training (s) | " << j(out, "train_s") << " |\n"
            << "| segmentation prior, " << out["segmentation_prior_bodies"] << " bodies, 2 threads (s, once) | " << prior_seconds
            << " | | |\n"
            << "| set-up per subject (s) | " << j(out, "setup_s") << " |\n"
            << "| one pose, learned (ms) | " << j(out, "pose_ms_learned") << " |\n"
            << "| one pose, rigid (ms) | " << j(out, "pose_ms_rigid") << " |\n"
            << "| one pose, 16-part LBS (ms) | " << j(out, "pose_ms_lbs") << " |\n"
            << "| motion of " << out["motion_frames"] << " frames, learned, " << out["motion_threads"] << " threads (s) | "
            << j(out, "motion_s") << " |\n";
  if (!out["retarget_s"].is_null())
    std::cout << "| retargeting those frames from " << out["motion"].get<std::string>() << ", 1 thread (s) | " << j(out, "retarget_s")
              << " |\n";
  std::cout << "\npeak RSS " << std::setprecision(0);
  if (per_stage)
    std::cout << "training (with the prior) " << out["peak_rss_mib"]["train"].get<double>() << " MiB, set-up and posing "
              << out["peak_rss_mib"]["pose"].get<double>() << " MiB\n";
  else std::cout << out["peak_rss_mib"].get<double>() << " MiB (whole run)\n";
}

int bench_pose(int argc, char** argv) {
  ArgParser args("bench pose",
                 "Speed of the pose deformation pipeline (single thread): training on the dataset's training\n"
                 "split, per-subject set-up (representation, segmentation, skeleton, ct-FFD correspondence,\n"
                 "factorisation), and one pose of a subject (learned T^Q, right-hand side, back-substitution).");
  args.option("dataset", "DIR", "a posekit dataset (posekit dataset make)")
      .option("runs", "R", "training runs and set-up runs per subject", "5")
      .option("poses", "P", "poses timed per subject (the dataset's poses, cycled)", "50")
      .option("subjects", "N", "use only the first N subjects (0: all)", "0")
      .option("frames", "N",
              "a motion of N frames (the dataset's poses blended in sequence) posed by the learned "
              "method on the first subject",
              "1000")
      .option("threads", "T", "threads for the motion", "2")
      .option("motion", "FILE.bvh", "motion capture instead: its first N frames retargeted to the first subject (timed) and posed")
      .flag("json", "results as JSON on stdout")
      .example("posekit bench pose --dataset ds --motion ../shared/datasets/motions/cmu/01_01.bvh");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  const std::string dir = args.get("dataset");
  BvhMotion capture;
  if (args.has("motion")) {
    capture = read_bvh(args.get("motion"), Unit::kMetre, io_warnings());
    if (capture.num_frames() < 1) throw InvalidInput(args.get("motion") + ": the motion has no frames");
  }
  std::vector<double> retarget_s;
  const int runs = static_cast<int>(args.get_int("runs")), pose_count = static_cast<int>(args.get_int("poses"));
  const long frame_count = args.get_int("frames");
  const int motion_threads = static_cast<int>(args.get_int("threads"));
  if (runs < 1 || pose_count < 1) throw UsageError("--runs and --poses must be at least 1");
  if (frame_count < 1 || motion_threads < 1) throw UsageError("--frames and --threads must be at least 1");
  const PoseDataset data = load_pose_dataset(dir);
  std::vector<double> train_s;
  std::shared_ptr<const PoseModel> model;
  // Peak memory per stage: the peak is reset before each (where the kernel allows it).
  const bool per_stage = reset_peak_rss();
  Progress progress("bench pose", runs);
  for (int r = 0; r < runs; ++r) {
    const Stopwatch t0;
    model = std::make_shared<const PoseModel>(train_on_dataset(dir));
    train_s.push_back(t0.seconds());
    progress.update(r + 1);
  }
  progress.finish();
  // The segmentation prior, as posekit train makes it (not part of the Eq. 5 fit timed above).
  PoseModel with_prior = *model;
  const PriorReport prior = add_segmentation_prior(&with_prior);
  model = std::make_shared<const PoseModel>(std::move(with_prior));
  const double train_peak = peak_rss_mib();
  reset_peak_rss();
  const auto manifest = nlohmann::json::parse(read_file_bytes(dir + "/manifest.json"));
  const int limit = static_cast<int>(args.get_int("subjects"));
  std::vector<double> setup_s, pose_ms, rigid_ms, lbs_ms, motion_s;
  long vertices = 0;
  int count = 0;
  std::vector<PartPose> motion = blended_motion(data.poses, frame_count);
  Progress subjects_progress("bench pose subjects", static_cast<long>(manifest["subjects"].size()));
  for (const auto& s : manifest["subjects"]) {
    if (limit > 0 && count >= limit) break;
    const TriangleMesh subject = read_mesh(dir + "/" + s["rest"].get<std::string>());
    vertices += subject.num_vertices();
    std::unique_ptr<PoseSynthesizer> synth;
    for (int r = 0; r < runs; ++r) {
      const Stopwatch t0;
      synth = std::make_unique<PoseSynthesizer>(model, subject);
      setup_s.push_back(t0.seconds());
    }
    // Each method over its own run of poses, as a user posing a motion with it would.
    for (auto [method, out] :
         {std::pair{PoseMethod::kLearned, &pose_ms}, std::pair{PoseMethod::kRigid, &rigid_ms}, std::pair{PoseMethod::kLbs, &lbs_ms}})
      for (int i = 0; i < pose_count; ++i) {
        const PartPose& pose = data.poses[static_cast<size_t>(i) % data.poses.size()];
        const Stopwatch t0;
        const Eigen::MatrixXd X = synth->pose(pose, method);
        out->push_back(1000 * t0.seconds());
        if (!X.allFinite()) throw InvalidInput("posing produced a non-finite vertex");
      }
    if (count == 0 && args.has("motion")) {
      // The capture's frames retargeted to this subject's joints, as posekit pose does with a BVH.
      const BvhPartMap map = map_bvh_skeleton(capture);
      RetargetOptions ro;
      ro.last = static_cast<int>(std::min<long>(frame_count, capture.num_frames()));
      for (int r = 0; r < runs; ++r) {
        const Stopwatch t0;
        motion = retarget_bvh(capture, map, synth->info().joint_centres, ro);
        retarget_s.push_back(t0.seconds());
      }
      while (static_cast<long>(motion.size()) < frame_count) motion.push_back(motion[motion.size() % static_cast<size_t>(ro.last)]);
    }
    if (count == 0)
      for (int r = 0; r < runs; ++r) {
        // Each thread poses its share of the frames into its own buffer, as a player or exporter would.
        std::atomic<long> non_finite{0};
        const Stopwatch t0;
        parallel_for_ranges(
            frame_count, motion_threads,
            [&](long begin, long end) {
              Eigen::MatrixXd X;
              for (long f = begin; f < end; ++f) {
                synth->pose(motion[static_cast<size_t>(f)], PoseMethod::kLearned, &X);
                if (!X.allFinite()) ++non_finite;
              }
            },
            1);
        motion_s.push_back(t0.seconds());
        if (non_finite > 0) throw InvalidInput("posing the motion produced non-finite vertices");
      }
    ++count;
    subjects_progress.update(count);
  }
  subjects_progress.finish();
  const double pose_peak = peak_rss_mib();
  auto j = [](const Stats& st) { return nlohmann::ordered_json{{"median", st.median}, {"min", st.min}, {"max", st.max}}; };
  const Stats train = stats_of(train_s), setup = stats_of(setup_s), learned = stats_of(pose_ms), rigid = stats_of(rigid_ms),
              lbs = stats_of(lbs_ms), moving = stats_of(motion_s);
  nlohmann::ordered_json out = {{"benchmark", "pose"},
                                {"training_poses", model->training_poses},
                                {"template_vertices", model->template_V.rows()},
                                {"subjects", count},
                                {"mean_subject_vertices", vertices / std::max(count, 1)},
                                {"runs", runs},
                                {"poses_per_subject", pose_count},
                                {"train_s", j(train)},
                                {"setup_s", j(setup)},
                                {"pose_ms_learned", j(learned)},
                                {"pose_ms_rigid", j(rigid)},
                                {"pose_ms_lbs", j(lbs)},
                                {"motion_frames", frame_count},
                                {"motion_threads", motion_threads},
                                {"motion_s", j(moving)},
                                {"motion", args.has("motion") ? args.get("motion") : std::string("dataset poses blended")},
                                {"retarget_s", retarget_s.empty() ? nlohmann::ordered_json(nullptr) : j(stats_of(retarget_s))},
                                {"segmentation_prior_bodies", prior.bodies},
                                {"segmentation_prior_s", prior.seconds},
                                {"peak_rss_mib", per_stage ? nlohmann::ordered_json{{"train", train_peak}, {"pose", pose_peak}}
                                                           : nlohmann::ordered_json(peak_rss_mib())}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  print_bench_pose(out, prior.seconds, per_stage);
  return 0;
}

/// Wall seconds of a shell command (its output to `log`); -1 when it fails.
double timed_command(const std::string& command, const std::string& log) {
  const Stopwatch t0;
  const int status = std::system((command + " >" + log + " 2>&1").c_str());
  const double seconds = t0.seconds();
  return status == 0 ? seconds : -1;
}

/// A whole command as a user times it: process start, reading, work, output.
struct WholeCommand {
  std::string name, command, note;
  std::vector<double> seconds;
  double peak_mib = 0;
  bool ok = true;
};

/// posekit compare, CloudCompare (load + -c2m_dist) and Open3D (interpreter, import, read, BVH,
/// distance) as whole processes on the same files, interleaved run by run so that they share the
/// machine's noise.
std::vector<WholeCommand> time_whole_comparisons(const std::string& dir, int runs, int threads) {
  std::error_code ec;
  const std::string self = std::filesystem::read_symlink("/proc/self/exe", ec).string();
  std::vector<WholeCommand> tools;
  tools.push_back({"posekit",
                   self + " compare " + dir + "/model.ply " + dir + "/scan.ply --json --threads " + std::to_string(threads),
                   "",
                   {},
                   0,
                   true});
  if (have_program("CloudCompare"))
    tools.push_back({"CloudCompare",
                     "QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -NO_TIMESTAMP -AUTO_SAVE OFF -O " + dir + "/scan.ply -O " + dir +
                         "/model.ply -c2m_dist",
                     "",
                     {},
                     0,
                     true});
  else tools.push_back({"CloudCompare", "", "not installed (Debian: cloudcompare)", {}, 0, false});
  const std::string python = open3d_python();
  if (!python.empty()) {
    const std::string script = write_open3d_compare_script(dir);
    tools.push_back({"Open3D", python + " " + script + " " + dir + "/model.ply " + dir + "/scan.ply", "", {}, 0, true});
  } else {
    tools.push_back({"Open3D", "", "not installed (Debian: python3-open3d)", {}, 0, false});
  }
  for (int k = 0; k < runs; ++k)
    for (WholeCommand& t : tools) {
      if (!t.ok) continue;
      const ProcessRun r = run_process(t.command, dir + "/whole_" + t.name + ".log");
      if (r.seconds < 0) {
        t.ok = false;
        t.note = "failed (see " + dir + "/whole_" + t.name + ".log)";
        continue;
      }
      t.seconds.push_back(r.seconds);
      t.peak_mib = std::max(t.peak_mib, r.peak_mib);
    }
  return tools;
}

/// The same comparison run by the tools users would pick instead, on the same files.
struct PeerResult {
  std::string name, what;
  double compute_s = -1, wall_s = -1;  ///< median; -1 when the tool is missing or failed
  std::string note;
};

PeerResult run_open3d(const std::string& dir, int runs) {
  PeerResult r{"Open3D", "RaycastingScene BVH build + compute_distance (unsigned, scan to model)", -1, -1, ""};
  const std::string python = open3d_python();
  if (python.empty()) {
    r.note = "not installed (Debian: python3-open3d)";
    return r;
  }
  const std::string script = dir + "/open3d_c2m.py";
  write_file_atomically(
      script,
      [&](std::ostream& out) {
        out << "import sys, time, statistics\nimport numpy as np\nimport open3d as o3d\n"
               "t0 = time.perf_counter()\n"
               "mesh = o3d.t.geometry.TriangleMesh.from_legacy(o3d.io.read_triangle_mesh(sys.argv[1]))\n"
               "pts = o3d.core.Tensor(np.asarray(o3d.io.read_point_cloud(sys.argv[2]).points, dtype=np.float32))\n"
               "load = time.perf_counter() - t0\n"
               "times = []\n"
               "for _ in range(int(sys.argv[3])):\n"
               "    t = time.perf_counter()\n"
               "    scene = o3d.t.geometry.RaycastingScene()\n"
               "    scene.add_triangles(mesh)\n"
               "    d = scene.compute_distance(pts).numpy()\n"
               "    times.append(time.perf_counter() - t)\n"
               "print(statistics.median(times), load, float(d.mean()))\n";
      },
      false);
  const std::string log = dir + "/open3d.log";
  const double wall = timed_command(python + " " + script + " " + dir + "/model.ply " + dir + "/scan.ply " + std::to_string(runs), log);
  std::ifstream in(log);
  double median = -1, load = -1, mean = 0;
  if (wall < 0 || !(in >> median >> load >> mean)) {
    r.note = "failed (see " + log + ")";
    return r;
  }
  r.compute_s = median;
  r.wall_s = load + median;
  r.note = "mean distance " + std::to_string(1000 * mean).substr(0, 5) + " mm";
  return r;
}

PeerResult run_cloudcompare(const std::string& dir, int runs) {
  PeerResult r{"CloudCompare", "-c2m_dist (scan to model), computation = wall(load + c2m) - wall(load)", -1, -1, ""};
  if (!have_program("CloudCompare")) {
    r.note = "not installed (Debian: cloudcompare)";
    return r;
  }
  const std::string base =
      "QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -NO_TIMESTAMP -AUTO_SAVE OFF -O " + dir + "/scan.ply -O " + dir + "/model.ply";
  std::vector<double> load, full;
  for (int k = 0; k < runs; ++k) {
    load.push_back(timed_command(base, dir + "/cc_load.log"));
    full.push_back(timed_command(base + " -c2m_dist", dir + "/cc_c2m.log"));
  }
  if (*std::min_element(load.begin(), load.end()) < 0 || *std::min_element(full.begin(), full.end()) < 0) {
    r.note = "failed (see " + dir + "/cc_c2m.log)";
    return r;
  }
  r.wall_s = stats_of(full).median;
  r.compute_s = std::max(0.0, r.wall_s - stats_of(load).median);
  return r;
}

/// Median, min and max of timings as JSON.
nlohmann::ordered_json stats_json(const std::vector<double>& v) {
  const Stats st = stats_of(v);
  return {{"median", st.median}, {"min", st.min}, {"max", st.max}};
}

/// Median (min-max) of timings as a table cell.
std::string stats_cell(const std::vector<double>& v, int digits) {
  const Stats st = stats_of(v);
  std::ostringstream c;
  c << std::fixed << std::setprecision(digits) << st.median << " (" << st.min << "-" << st.max << ")";
  return c.str();
}

int bench_measure(int argc, char** argv) {
  ArgParser args("bench measure",
                 "Times `posekit measure` in process on a large mesh and a large scan of the default body, per\n"
                 "stage: reading the binary PLY, telling unit and orientation, and measuring (sections, features,\n"
                 "girths). The mesh is the body remeshed to --vertices; the scan, --points samples with 1.5 mm noise.\n"
                 "Median, min and max over --runs. No peer tool measures girths, so there is no comparison.");
  args.option("vertices", "N", "vertices of the mesh", "300000")
      .option("points", "N", "points of the scan", "300000")
      .option("runs", "R", "runs", "5")
      .data_option()
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  const int runs = static_cast<int>(args.get_int("runs"));
  const long vertices = args.get_int("vertices"), points = args.get_int("points");
  if (runs < 1 || vertices < 1000 || points < 1000) throw UsageError("--runs must be at least 1, --vertices and --points 1000");
  const auto model = load_makehuman_model(find_data_root(args.get("data")));
  const Body body = build_body(*model, BodySpec{});
  // A fine mesh of another connectivity: midpoint subdivisions up to the size asked for, then
  // remeshed (Loop subdivision and decimation) to it.
  std::cerr << "bench measure: remeshing the body to " << vertices << " vertices\n";
  TriangleMesh fine = body.mesh;
  while (fine.V.rows() < vertices / 3) fine = subdivide_midpoints(fine);
  const TriangleMesh mesh = remesh_body(fine, static_cast<int>(vertices));
  const PointCloud scan = sample_surface(body.mesh, points, 0.0015, 11);
  ScratchDir dir;
  write_mesh(dir.path + "/body.ply", mesh);
  write_point_cloud(dir.path + "/scan.ply", scan);
  struct Stage {
    std::vector<double> read, orient, measure, total;
  } stages[2];
  BodyMeasurements last[2];
  reset_peak_rss();
  Progress progress("bench measure", 2L * runs);
  for (int k = 0; k < runs; ++k)
    for (int kind = 0; kind < 2; ++kind) {
      const std::string path = dir.path + (kind == 0 ? "/body.ply" : "/scan.ply");
      auto t0 = Clock::now();
      BodyInput in = read_body_input(path, Unit::kMetre);
      Unit unit;
      (void)guess_body_unit(robust_largest_extent(kind == 0 ? in.mesh.V : in.cloud.P), &unit);
      auto t1 = Clock::now();
      const BodyOrientation o = kind == 0 ? detect_mesh_orientation(in.mesh.V, in.mesh.F) : detect_body_orientation(in.cloud.P);
      if (!o.is_identity()) throw InvalidInput("bench measure: the body was not found upright: " + o.describe());
      auto t2 = Clock::now();
      last[kind] = kind == 0 ? measure_body(in.mesh.V, in.mesh.F) : measure_point_cloud(in.cloud.P);
      auto t3 = Clock::now();
      Stage& s = stages[kind];
      s.read.push_back(seconds_between(t0, t1));
      s.orient.push_back(seconds_between(t1, t2));
      s.measure.push_back(seconds_between(t2, t3));
      s.total.push_back(seconds_between(t0, t3));
      progress.update(2L * k + kind + 1);
    }
  progress.finish();
  const double peak = peak_rss_mib();
  nlohmann::ordered_json out = {{"runs", runs},
                                {"mesh_vertices", mesh.V.rows()},
                                {"mesh_triangles", mesh.F.rows()},
                                {"scan_points", scan.P.rows()},
                                {"units", "s"},
                                {"peak_rss_mib", peak}};
  for (int kind = 0; kind < 2; ++kind) {
    nlohmann::ordered_json g;
    for (const auto& m : last[kind].girths)
      if (m.name == "bust" || m.name == "waist" || m.name == "hip")
        g[m.name] = m.measured ? nlohmann::json(m.value) : nlohmann::json(m.note);
    out[kind == 0 ? "mesh" : "scan"] = {{"read", stats_json(stages[kind].read)},
                                        {"unit_and_orientation", stats_json(stages[kind].orient)},
                                        {"measure", stats_json(stages[kind].measure)},
                                        {"total", stats_json(stages[kind].total)},
                                        {"girths_m", g}};
  }
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(3) << "measure, median of " << runs << " runs (min-max), seconds\n\n"
            << "| input | read | unit + orientation | measure | total |\n|---|---|---|---|---|\n";
  for (int kind = 0; kind < 2; ++kind) {
    const Stage& s = stages[kind];
    std::cout << "| " << (kind == 0 ? std::to_string(mesh.V.rows()) + "-vertex mesh" : std::to_string(scan.P.rows()) + "-point scan")
              << " | " << stats_cell(s.read, 3) << " | " << stats_cell(s.orient, 3) << " | " << stats_cell(s.measure, 3) << " | "
              << stats_cell(s.total, 3) << " |\n";
  }
  std::cout << "\npeak RSS " << std::setprecision(0) << peak << " MiB\n";
  return 0;
}

int bench_fit(int argc, char** argv) {
  ArgParser args("bench fit",
                 "Times `posekit measure --body-model` in process: the body model fitted to the default MakeHuman\n"
                 "body (its 13,380-vertex mesh) and to scans of it of --points samples (1.5 mm noise), then the girths\n"
                 "measured on the target by the fit. Per input: reading the binary PLY, the fit (and its stages),\n"
                 "measuring, the total, and the peak resident memory of that input's runs; median, min and max over\n"
                 "--runs. The body model is loaded once, before (its time is given apart). No peer tool (PCL, Open3D,\n"
                 "CloudCompare) fits a body model, so there is no comparison.");
  args.body_model_option()
      .option("points", "LIST", "the scans' sizes, comma-separated", "1000000,10000000")
      .option("runs", "R", "runs per input", "3")
      .data_option()
      .flag("json", "results as JSON on stdout")
      .example("posekit shape-space --ansur --out ansur.pks && posekit bench fit --body-model ansur.pks");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("body-model")) throw UsageError("--body-model FILE is required (build one with posekit shape-space --ansur --out FILE)");
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  std::vector<long> sizes;
  std::istringstream list(args.get("points"));
  for (std::string item; std::getline(list, item, ',');) {
    size_t used = 0;
    long n = 0;
    try {
      n = std::stol(item, &used);
    } catch (...) {
    }
    if (used != item.size() || n < 1000)
      throw UsageError("--points: each scan needs a whole number of at least 1000 points, not '" + item + "'");
    sizes.push_back(n);
  }
  const Stopwatch t_load;
  const std::unique_ptr<BodyModel> body_model = load_body_model(args);
  const double load_seconds = t_load.seconds();
  const auto makehuman = load_makehuman_model(find_data_root(args.get("data")));
  const Body body = build_body(*makehuman, BodySpec{});
  ScratchDir dir;
  std::vector<std::string> inputs = {dir.path + "/body.ply"};
  write_mesh(inputs[0], body.mesh);
  for (const long n : sizes) {
    std::cerr << "bench fit: sampling a scan of " << n << " points\n";
    inputs.push_back(dir.path + "/scan_" + std::to_string(n) + ".ply");
    write_point_cloud(inputs.back(), sample_surface(body.mesh, n, 0.0015, 13));
  }
  struct Timings {
    std::vector<double> read, fit, measure, total;
    std::vector<std::pair<std::string, std::vector<double>>> stages;  // in the fit's order
    double peak_mib = 0;
    long points = 0;
    bool confident = true;
    std::map<std::string, double> girths;
  };
  std::vector<Timings> timings(inputs.size());
  Progress progress("bench fit", static_cast<long>(inputs.size()) * runs);
  for (size_t k = 0; k < inputs.size(); ++k) {
    Timings& t = timings[k];
    reset_peak_rss();
    for (int r = 0; r < runs; ++r) {
      const auto t0 = Clock::now();
      const BodyInput in = read_body_input(inputs[k], Unit::kMetre);
      const auto t1 = Clock::now();
      const Eigen::MatrixXd& T = in.is_cloud ? in.cloud.P : in.mesh.V;
      const BodyFit fit = in.is_cloud ? fit_body_model(*body_model, T) : fit_body_model_to_mesh(*body_model, T, in.mesh.F);
      const auto t2 = Clock::now();
      const FittedMeasurements fm = measure_by_body_fit(*body_model, fit, T, in.is_cloud ? Eigen::MatrixXi() : in.mesh.F);
      const auto t3 = Clock::now();
      t.read.push_back(seconds_between(t0, t1));
      t.fit.push_back(seconds_between(t1, t2));
      t.measure.push_back(seconds_between(t2, t3));
      t.total.push_back(seconds_between(t0, t3));
      for (const auto& stage_time : fit.stage_seconds) {
        const std::string& stage = stage_time.first;  // a structured binding cannot be captured in C++17
        auto it = std::find_if(t.stages.begin(), t.stages.end(), [&](const auto& e) { return e.first == stage; });
        if (it == t.stages.end()) it = t.stages.insert(t.stages.end(), {stage, {}});
        it->second.push_back(stage_time.second);
      }
      t.points = T.rows();
      t.confident = t.confident && fit.confident;
      for (const Girth& g : fm.target.girths)
        if (g.measured && (g.name == "bust" || g.name == "waist" || g.name == "hip")) t.girths[g.name] = g.value;
      progress.update(static_cast<long>(k) * runs + r + 1);
    }
    t.peak_mib = peak_rss_mib();
  }
  progress.finish();
  nlohmann::ordered_json out = {{"runs", runs},
                                {"units", "s"},
                                {"body_model", args.get("body-model")},
                                {"load_body_model_s", load_seconds},
                                {"inputs", nlohmann::ordered_json::array()}};
  for (size_t k = 0; k < inputs.size(); ++k) {
    const Timings& t = timings[k];
    nlohmann::ordered_json e = {{"input", k == 0 ? "mesh" : "scan"}, {"points", t.points},         {"confident", t.confident},
                                {"read", stats_json(t.read)},        {"fit", stats_json(t.fit)},   {"measure", stats_json(t.measure)},
                                {"total", stats_json(t.total)},      {"peak_rss_mib", t.peak_mib}, {"girths_m", t.girths}};
    for (const auto& [stage, v] : t.stages) e["fit_stages"][stage] = stats_json(v);
    out["inputs"].push_back(e);
  }
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << "measure --body-model, median of " << runs << " runs (min-max), seconds; body model loaded in "
            << std::setprecision(2) << load_seconds << " s\n\n"
            << "| input | read | fit | measure | total | peak RSS (MiB) | bust / waist / hip (cm) |\n|---|---|---|---|---|---|---|\n";
  for (size_t k = 0; k < inputs.size(); ++k) {
    const Timings& t = timings[k];
    std::ostringstream g;
    g << std::fixed << std::setprecision(1);
    for (const char* name : {"bust", "waist", "hip"}) {
      const auto it = t.girths.find(name);
      g << (name[0] == 'b' ? "" : " / ") << (it == t.girths.end() ? std::string("-") : std::to_string(100 * it->second).substr(0, 5));
    }
    std::cout << "| " << t.points << (k == 0 ? "-vertex mesh" : "-point scan") << (t.confident ? "" : " (POOR FIT)") << " | "
              << stats_cell(t.read, 2) << " | " << stats_cell(t.fit, 2) << " | " << stats_cell(t.measure, 2) << " | "
              << stats_cell(t.total, 2) << " | " << std::setprecision(0) << t.peak_mib << " | " << g.str() << " |\n";
  }
  std::cout << "\nfit stages, median seconds:\n";
  for (size_t k = 0; k < inputs.size(); ++k) {
    std::cout << "  " << timings[k].points << ":";
    for (const auto& [stage, v] : timings[k].stages) std::cout << " " << stage << " " << std::setprecision(2) << stats_of(v).median << ",";
    std::cout << "\n";
  }
  return 0;
}

int bench_compare(int argc, char** argv) {
  ArgParser args("bench compare",
                 "Times posekit compare: a MakeHuman body (26,756 triangles) against a synthetic scan of N points\n"
                 "sampled uniformly on it with Gaussian noise (both directions, signs, coverage, statistics).\n"
                 "With --peers, the same model and scan go through CloudCompare (-c2m_dist) and Open3D\n"
                 "(RaycastingScene) when they are installed, and the ratio of the times is printed. Those\n"
                 "compute one direction, unsigned; posekit computes both, signed.");
  args.data_option()
      .option("points", "N", "scan points", "1000000")
      .option("threads", "T", "threads (0: all cores)", "0")
      .option("runs", "R", "timed runs (median reported)", "5")
      .flag("peers", "also time CloudCompare and Open3D on the same files")
      .flag("json", "machine-readable results on stdout");
  if (!args.parse(argc, argv)) return 0;
  const int runs = static_cast<int>(args.get_int("runs"));
  const long n = args.get_int("points");
  if (runs < 1 || n < 1) throw UsageError("--runs and --points must be at least 1");
  const auto model = load_makehuman_model(find_data_root(args.get("data")));
  const Body body = build_body(*model, BodySpec{});
  const PointCloud scan = sample_surface(body.mesh, n, 0.0015, 7);
  // The files every tool reads: binary PLY in metres.
  const ScratchDir scratch;
  const std::string& dir = scratch.path;
  write_mesh(dir + "/model.ply", body.mesh);
  write_point_cloud(dir + "/scan.ply", scan);
  std::vector<double> load;
  for (int k = 0; k < runs; ++k) {
    const Stopwatch t0;
    (void)read_point_cloud(dir + "/scan.ply");
    (void)read_mesh(dir + "/model.ply");
    load.push_back(t0.seconds());
  }
  ScanComparisonOptions o;
  o.threads = static_cast<int>(args.get_int("threads"));
  std::vector<double> seconds, build, s2m, m2s, stats;
  ScanComparison r;
  const bool compare_peak_only = reset_peak_rss();  // the peak of the comparison, not of making the scan
  Progress progress("bench compare", runs);
  for (int k = 0; k < runs; ++k) {
    const Stopwatch t0;
    r = compare_with_scan(body.mesh, scan, o);
    seconds.push_back(t0.seconds());
    build.push_back(r.build_seconds);
    s2m.push_back(r.scan_to_model_seconds);
    m2s.push_back(r.model_to_scan_seconds);
    stats.push_back(r.stats_seconds);
    progress.update(k + 1);
  }
  progress.finish();
  const double compare_peak = peak_rss_mib();
  const Stats t = stats_of(seconds);
  const double load_s = stats_of(load).median;
  std::vector<PeerResult> peers;
  if (args.flag_set("peers")) {
    std::cerr << "bench compare: timing the peers on the same files\n";
    peers.push_back(run_cloudcompare(dir, runs));
    peers.push_back(run_open3d(dir, runs));
  }
  std::vector<WholeCommand> whole;
  if (args.flag_set("peers")) {
    std::cerr << "bench compare: timing whole processes (start, read, compare, output)\n";
    whole = time_whole_comparisons(dir, runs, o.threads);
  }
  double best_whole = -1, posekit_whole = -1;
  std::string best_whole_name;
  for (const WholeCommand& w : whole) {
    if (!w.ok || w.seconds.empty()) continue;
    const double m = stats_of(w.seconds).median;
    if (w.name == "posekit") posekit_whole = m;
    else if (best_whole < 0 || m < best_whole) best_whole = m, best_whole_name = w.name;
  }
  double best_peer = -1;
  std::string best_name;
  for (const PeerResult& p : peers)
    if (p.compute_s > 0 && (best_peer < 0 || p.compute_s < best_peer)) best_peer = p.compute_s, best_name = p.name;
  nlohmann::ordered_json out = {{"benchmark", "compare"},
                                {"model_triangles", body.mesh.F.rows()},
                                {"scan_points", n},
                                {"threads", o.threads},
                                {"runs", runs},
                                {"median_s", t.median},
                                {"min_s", t.min},
                                {"max_s", t.max},
                                {"stages_median_s",
                                 {{"load", load_s},
                                  {"build", stats_of(build).median},
                                  {"scan_to_model", stats_of(s2m).median},
                                  {"model_to_scan", stats_of(m2s).median},
                                  {"stats", stats_of(stats).median}}},
                                {"scan_to_model_mean_mm", r.scan_stats.mean_mm},
                                {"scan_to_model_rms_mm", r.scan_stats.rms_mm},
                                {"coverage", r.coverage},
                                {compare_peak_only ? "compare_peak_rss_mib" : "peak_rss_mib", compare_peak}};
  if (!peers.empty()) {
    nlohmann::ordered_json jp = nlohmann::ordered_json::array();
    for (const PeerResult& p : peers)
      jp.push_back({{"name", p.name}, {"what", p.what}, {"compute_median_s", p.compute_s}, {"wall_median_s", p.wall_s}, {"note", p.note}});
    out["peers"] = jp;
    out["ratio_to_best_peer"] = best_peer > 0 ? nlohmann::ordered_json(t.median / best_peer) : nlohmann::ordered_json();
    nlohmann::ordered_json jw = nlohmann::ordered_json::array();
    for (const WholeCommand& w : whole) {
      nlohmann::ordered_json e = {{"case", "whole process: " + w.name}, {"name", w.name}, {"command", w.command}};
      if (w.ok && !w.seconds.empty()) {
        const Stats st = stats_of(w.seconds);
        e["median_s"] = st.median, e["min_s"] = st.min, e["max_s"] = st.max, e["peak_rss_mib"] = w.peak_mib;
      }
      if (!w.note.empty()) e["note"] = w.note;
      jw.push_back(e);
    }
    out["whole_process"] = jw;
    out["whole_ratio_to_best_peer"] =
        best_whole > 0 && posekit_whole > 0 ? nlohmann::ordered_json(posekit_whole / best_whole) : nlohmann::ordered_json();
  }
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(3) << "compare: " << n << " scan points against " << body.mesh.F.rows()
            << " triangles, threads " << (o.threads > 0 ? std::to_string(o.threads) : std::string("all")) << ": median " << t.median
            << " s (min " << t.min << ", max " << t.max << ") over " << runs << " runs; RMS " << std::setprecision(2) << r.scan_stats.rms_mm
            << " mm (noise sigma 1.5 mm); peak RSS " << (compare_peak_only ? "of the comparison " : "") << std::setprecision(0)
            << compare_peak << " MiB\n"
            << std::setprecision(3) << "  stages (median s): load " << load_s << ", build " << stats_of(build).median << ", scan-to-model "
            << stats_of(s2m).median << ", model-to-scan " << stats_of(m2s).median << ", stats " << stats_of(stats).median << "\n";
  for (const PeerResult& p : peers) {
    std::cout << "  " << std::left << std::setw(13) << p.name << std::right;
    if (p.compute_s < 0) std::cout << p.note << "\n";
    else
      std::cout << "computation " << p.compute_s << " s, wall " << p.wall_s << " s: " << p.what << (p.note.empty() ? "" : "; " + p.note)
                << "\n";
  }
  if (best_peer > 0) std::cout << "  posekit / best peer (" << best_name << "): " << std::setprecision(2) << t.median / best_peer << "\n";
  if (!whole.empty()) {
    std::cout << "whole processes (start, read, compare, output), median over " << runs << " runs:\n";
    for (const WholeCommand& w : whole) {
      std::cout << "  " << std::left << std::setw(13) << w.name << std::right;
      if (!w.ok || w.seconds.empty()) std::cout << w.note << "\n";
      else std::cout << std::setprecision(3) << stats_cell(w.seconds, 3) << " s, peak " << std::setprecision(0) << w.peak_mib << " MiB\n";
    }
    if (best_whole > 0 && posekit_whole > 0)
      std::cout << "  posekit / best peer (" << best_whole_name << "): " << std::setprecision(2) << posekit_whole / best_whole << "\n";
  }
  return 0;
}

}  // namespace

int run_bench(int argc, char** argv) {
  const std::string usage =
      "usage: posekit bench <what> [options]\n\nbenchmarks:\n  io    reading 1M-triangle meshes and 1M-point clouds\n"
      "  body  building and posing a MakeHuman body\n"
      "  registration  the paper's Table 1: ct-FFD vs ICP on a dataset, with correspondence accuracy\n"
      "  customize  photos to a customized body on a dataset's subjects\n"
      "  pose  training, per-subject set-up and per-pose time of the pose deformation\n"
      "  compare  a 1M-point scan against a 25k-triangle model\n"
      "  measure  measuring a 300k-vertex mesh and a 300k-point scan\n"
      "  fit   the body model fitted and measuring by it: a mesh, 1M- and 10M-point scans\n"
      "  commands  whole commands (read, measure, compare, convert) at 1M and 10M points, beside CloudCompare and Open3D\n"
      "  all   every benchmark above, one table with the date and machine (benchmarks.json, benchmarks.md)\n";
  if (argc < 1 || std::string(argv[0]) == "--help" || std::string(argv[0]) == "-h") {
    std::cout << usage;
    return argc < 1 ? 2 : 0;
  }
  const std::string what = argv[0];
  if (what == "io") return bench_io(argc - 1, argv + 1);
  if (what == "body") return bench_body(argc - 1, argv + 1);
  if (what == "registration") return bench_registration(argc - 1, argv + 1);
  if (what == "customize") return bench_customize(argc - 1, argv + 1);
  if (what == "pose") return bench_pose(argc - 1, argv + 1);
  if (what == "compare") return bench_compare(argc - 1, argv + 1);
  if (what == "measure") return bench_measure(argc - 1, argv + 1);
  if (what == "fit") return bench_fit(argc - 1, argv + 1);
  if (what == "commands") return bench_commands(argc - 1, argv + 1);
  if (what == "all") return bench_all(argc - 1, argv + 1);
  throw UsageError("unknown benchmark '" + what + "'\n" + usage);
}

}  // namespace posekit::cli
