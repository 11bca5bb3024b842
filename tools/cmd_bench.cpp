// posekit bench <what>: timings reported as median/min/max over several runs (never timed tests).
#include <unistd.h>

#include <chrono>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/skinning.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/datasets/dataset.h"
#include "posekit/datasets/remesh.h"
#include "posekit/io/atomic_file.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/registration/registration.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"

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
    const auto t0 = Clock::now();
    body();
    seconds.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    progress.update(r + 1);
  }
  progress.finish();
  return stats_of(seconds);
}

int bench_io(int argc, char** argv) {
  ArgParser args("bench io", "Times reading large files: binary PLY, OBJ and binary STL meshes and a binary PCD cloud.\n"
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
  std::filesystem::create_directories(dir);
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
      results.push_back({{"case", "read " + c.name}, {"elements", mesh.num_faces()}, {"element", "triangles"},
                         {"file_mib", size / 1048576.0}, {"median_s", s.median}, {"min_s", s.min}, {"max_s", s.max}});
    }
    const std::string pcd = (dir / "c.pcd").string();
    write_point_cloud(pcd, cloud);
    const auto size = std::filesystem::file_size(pcd);
    const Stats s = time_runs(runs, "read pcd_binary", [&] { (void)read_point_cloud(pcd); });
    results.push_back({{"case", "read pcd_binary"}, {"elements", points}, {"element", "points"},
                       {"file_mib", size / 1048576.0}, {"median_s", s.median}, {"min_s", s.min}, {"max_s", s.max}});
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
    std::cout << "| " << r["case"].get<std::string>() << " | " << r["elements"] << " " << r["element"].get<std::string>()
              << " | " << std::setprecision(1) << r["file_mib"].get<double>() << " | " << std::setprecision(3)
              << r["median_s"].get<double>() << " | " << r["min_s"].get<double>() << " | " << r["max_s"].get<double>() << " |\n";
  std::cout << "peak RSS: " << std::setprecision(0) << out["peak_rss_mib"].get<double>() << " MiB, " << runs << " runs each\n";
  return 0;
}

int bench_body(int argc, char** argv) {
  ArgParser args("bench body", "Times building a MakeHuman body from a spec and posing it (13,380 vertices): the model is\n"
                               "loaded once, then each run shapes a body and skins it into a 16-part pose, single thread.");
  args.option("data", "DIR", "MakeHuman data root").option("runs", "R", "timed runs (median reported)", "50")
      .flag("json", "machine-readable results on stdout");
  if (!args.parse(argc, argv)) return 0;
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  const auto t0 = Clock::now();
  const auto model = load_makehuman_model(find_data_root(args.get("data")));
  const double load_s = std::chrono::duration<double>(Clock::now() - t0).count();
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
    build_s.push_back(std::chrono::duration<double>(b - a).count());
    lbs_s.push_back(std::chrono::duration<double>(c - b).count());
    dqs_s.push_back(std::chrono::duration<double>(d - c).count());
    total_s.push_back(std::chrono::duration<double>(c - a).count());
    progress.update(r + 1);
  }
  progress.finish();
  auto row = [](const std::string& name, const std::vector<double>& v) {
    const Stats s = stats_of(v);
    return nlohmann::json{{"case", name}, {"median_ms", s.median * 1e3}, {"min_ms", s.min * 1e3}, {"max_ms", s.max * 1e3}};
  };
  nlohmann::json results = nlohmann::json::array({row("build body (shape + joints)", build_s), row("pose, LBS", lbs_s),
                                                   row("pose, DQS", dqs_s), row("build + pose (LBS)", total_s)});
  nlohmann::json out = {{"benchmark", "body"}, {"vertices", model->num_body_vertices}, {"runs", runs},
                        {"model_load_s", load_s}, {"results", results}, {"peak_rss_mib", peak_rss_mib()},
                        {"checksum", checksum}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << "| case | median ms | min ms | max ms |\n|---|---|---|---|\n" << std::fixed << std::setprecision(2);
  for (const auto& r : results)
    std::cout << "| " << r["case"].get<std::string>() << " | " << r["median_ms"].get<double>() << " | "
              << r["min_ms"].get<double>() << " | " << r["max_ms"].get<double>() << " |\n";
  std::cout << model->num_body_vertices << " vertices, " << runs << " runs, model load " << std::setprecision(3) << load_s
            << " s, peak RSS " << std::setprecision(0) << out["peak_rss_mib"].get<double>() << " MiB\n";
  return 0;
}

/// Distances (mm) on the template between each target triangle's matched source centroid and its
/// true corresponding point (the centroid of its vertices' ground-truth template points).
std::pair<double, double> correspondence_error_mm(const TriangleMesh& templ, const TriangleMesh& subject,
                                                  const SurfacePoints& truth, const Eigen::VectorXi& match) {
  const Eigen::MatrixXd true_points = face_centroids(evaluate_surface_points(templ.V, templ.F, truth), subject.F);
  const Eigen::MatrixXd source_centroids = face_centroids(templ.V, templ.F);
  std::vector<double> d(static_cast<size_t>(match.size()));
  for (Eigen::Index k = 0; k < match.size(); ++k) d[k] = 1000 * (source_centroids.row(match[k]) - true_points.row(k)).norm();
  double mean = 0;
  for (double x : d) mean += x;
  mean /= static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  return {mean, d[static_cast<size_t>(0.95 * static_cast<double>(d.size() - 1))]};
}

int bench_registration(int argc, char** argv) {
  ArgParser args("bench registration",
                 "The paper's Table 1 on this machine: the template registered to every subject of a dataset by\n"
                 "ct-FFD, by PCL's rigid ICP (1 and 6 iterations) and by optimal-step non-rigid ICP, each followed\n"
                 "by the nearest-centroid\n"
                 "correspondence; median/min/max time over several runs (single thread) and correspondence error\n"
                 "against the dataset's ground truth (mean and 95th percentile, mm).");
  args.option("dataset", "DIR", "a posekit dataset (posekit dataset make)")
      .option("runs", "R", "timed runs per method and subject", "5")
      .option("subjects", "N", "use only the first N subjects (0: all)", "0")
      .option("nicp-runs", "R", "timed runs of non-rigid ICP (seconds each)", "1")
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  const std::string dir = args.get("dataset");
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  const auto manifest = nlohmann::json::parse(read_file_bytes(dir + "/manifest.json"));
  const TriangleMesh templ = read_mesh(dir + "/" + manifest["template"]["mesh"].get<std::string>());
  struct Method {
    std::string name;
    RegistrationOptions options;
  };
  std::vector<Method> methods(4);
  methods[0].name = "ct-FFD";
  methods[1].name = "ICP (1 iteration)";
  methods[1].options.method = RegistrationMethod::kIcp;
  methods[1].options.icp_iterations = 1;
  methods[2].name = "ICP (6 iterations)";
  methods[2].options.method = RegistrationMethod::kIcp;
  methods[2].options.icp_iterations = 6;
  methods[3].name = "non-rigid ICP (optimal step)";
  methods[3].options.method = RegistrationMethod::kNicp;
  const int nicp_runs = static_cast<int>(args.get_int("nicp-runs"));
  if (nicp_runs < 1) throw UsageError("--nicp-runs must be at least 1");
  std::vector<std::vector<double>> seconds(methods.size()), mean(methods.size()), p95(methods.size());
  long subject_vertices = 0, subject_triangles = 0;
  int count = 0;
  const int limit = static_cast<int>(args.get_int("subjects"));
  const int total = limit > 0 ? std::min<int>(limit, static_cast<int>(manifest["subjects"].size())) : static_cast<int>(manifest["subjects"].size());
  Progress progress("bench registration", total * static_cast<int>(methods.size()));
  for (const auto& s : manifest["subjects"]) {
    if (count >= total) break;
    const TriangleMesh subject = read_mesh(dir + "/" + s["rest"].get<std::string>());
    const SurfacePoints truth = load_correspondence(dir + "/" + s["correspondence"].get<std::string>());
    subject_vertices += subject.num_vertices();
    subject_triangles += subject.num_faces();
    for (size_t m = 0; m < methods.size(); ++m) {
      RegistrationResult r;
      for (int k = 0; k < (methods[m].options.method == RegistrationMethod::kNicp ? nicp_runs : runs); ++k) {
        r = register_bodies(templ, subject, methods[m].options);
        seconds[m].push_back(r.seconds);
      }
      const auto [e_mean, e_p95] = correspondence_error_mm(templ, subject, truth, r.correspondence);
      mean[m].push_back(e_mean);
      p95[m].push_back(e_p95);
      progress.update(count * static_cast<int>(methods.size()) + static_cast<int>(m) + 1);
    }
    ++count;
  }
  progress.finish();
  auto average = [](const std::vector<double>& v) { double a = 0; for (double x : v) a += x; return a / std::max<size_t>(1, v.size()); };
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  for (size_t m = 0; m < methods.size(); ++m) {
    const Stats t = stats_of(seconds[m]);
    rows.push_back({{"method", methods[m].name}, {"median_s", t.median}, {"min_s", t.min}, {"max_s", t.max},
                    {"mean_error_mm", average(mean[m])}, {"p95_error_mm", average(p95[m])},
                    {"worst_subject_mean_error_mm", *std::max_element(mean[m].begin(), mean[m].end())}});
  }
  nlohmann::ordered_json out = {{"benchmark", "registration"}, {"subjects", count}, {"runs", runs},
                                {"template_vertices", templ.num_vertices()}, {"template_triangles", templ.num_faces()},
                                {"mean_subject_vertices", subject_vertices / std::max(1, count)},
                                {"mean_subject_triangles", subject_triangles / std::max(1, count)},
                                {"results", rows}, {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << "Registration of the template (" << templ.num_vertices() << " vertices) to " << count << " subjects (~"
            << out["mean_subject_vertices"] << " vertices, ~" << out["mean_subject_triangles"] << " triangles), " << runs
            << " runs each (non-rigid ICP " << nicp_runs << "), single thread\n\n| method | median s | min s | max s | mean error mm | 95th pct mm |\n|---|---|---|---|---|---|\n"
            << std::fixed;
  for (const auto& r : rows)
    std::cout << "| " << r["method"].get<std::string>() << " | " << std::setprecision(3) << r["median_s"].get<double>() << " | "
              << r["min_s"].get<double>() << " | " << r["max_s"].get<double>() << " | " << std::setprecision(1)
              << r["mean_error_mm"].get<double>() << " | " << r["p95_error_mm"].get<double>() << " |\n";
  std::cout << "\nPaper (Matlab, Core i7, 12,428 vertices): ICP 1 iteration 24 s, 6 iterations 229 s, ct-FFD 5.1 s.\n";
  return 0;
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
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  const std::string dir = args.get("dataset");
  const int runs = static_cast<int>(args.get_int("runs")), pose_count = static_cast<int>(args.get_int("poses"));
  if (runs < 1 || pose_count < 1) throw UsageError("--runs and --poses must be at least 1");
  const PoseDataset data = load_pose_dataset(dir);
  std::vector<double> train_s;
  std::shared_ptr<const PoseModel> model;
  Progress progress("bench pose", runs);
  for (int r = 0; r < runs; ++r) {
    const auto t0 = Clock::now();
    model = std::make_shared<const PoseModel>(train_on_dataset(dir));
    train_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    progress.update(r + 1);
  }
  progress.finish();
  const auto manifest = nlohmann::json::parse(read_file_bytes(dir + "/manifest.json"));
  const int limit = static_cast<int>(args.get_int("subjects"));
  std::vector<double> setup_s, pose_ms, rigid_ms, lbs_ms;
  long vertices = 0;
  int count = 0;
  Progress subjects_progress("bench pose subjects", static_cast<long>(manifest["subjects"].size()));
  for (const auto& s : manifest["subjects"]) {
    if (limit > 0 && count >= limit) break;
    const TriangleMesh subject = read_mesh(dir + "/" + s["rest"].get<std::string>());
    vertices += subject.num_vertices();
    std::unique_ptr<PoseSynthesizer> synth;
    for (int r = 0; r < runs; ++r) {
      const auto t0 = Clock::now();
      synth = std::make_unique<PoseSynthesizer>(model, subject);
      setup_s.push_back(std::chrono::duration<double>(Clock::now() - t0).count());
    }
    for (int i = 0; i < pose_count; ++i) {
      const PartPose& pose = data.poses[static_cast<size_t>(i) % data.poses.size()];
      for (auto [method, out] : {std::pair{PoseMethod::kLearned, &pose_ms}, std::pair{PoseMethod::kRigid, &rigid_ms},
                                 std::pair{PoseMethod::kLbs, &lbs_ms}}) {
        const auto t0 = Clock::now();
        const Eigen::MatrixXd X = synth->pose(pose, method);
        out->push_back(1000 * std::chrono::duration<double>(Clock::now() - t0).count());
        if (!X.allFinite()) throw InvalidInput("posing produced a non-finite vertex");
      }
    }
    ++count;
    subjects_progress.update(count);
  }
  subjects_progress.finish();
  auto j = [](const Stats& st) { return nlohmann::ordered_json{{"median", st.median}, {"min", st.min}, {"max", st.max}}; };
  const Stats train = stats_of(train_s), setup = stats_of(setup_s), learned = stats_of(pose_ms), rigid = stats_of(rigid_ms),
              lbs = stats_of(lbs_ms);
  nlohmann::ordered_json out = {{"benchmark", "pose"}, {"training_poses", model->training_poses},
                                {"template_vertices", model->template_V.rows()}, {"subjects", count},
                                {"mean_subject_vertices", vertices / std::max(count, 1)}, {"runs", runs},
                                {"poses_per_subject", pose_count}, {"train_s", j(train)}, {"setup_s", j(setup)},
                                {"pose_ms_learned", j(learned)}, {"pose_ms_rigid", j(rigid)}, {"pose_ms_lbs", j(lbs)},
                                {"peak_rss_mib", peak_rss_mib()}};
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(3) << "Pose deformation, single thread: " << model->training_poses
            << " training poses, " << count << " subjects of ~" << out["mean_subject_vertices"] << " vertices\n\n"
            << "| stage | median | min | max |\n|---|---|---|---|\n"
            << "| training (s) | " << train.median << " | " << train.min << " | " << train.max << " |\n"
            << "| set-up per subject (s) | " << setup.median << " | " << setup.min << " | " << setup.max << " |\n"
            << "| one pose, learned (ms) | " << learned.median << " | " << learned.min << " | " << learned.max << " |\n"
            << "| one pose, rigid (ms) | " << rigid.median << " | " << rigid.min << " | " << rigid.max << " |\n"
            << "| one pose, 16-part LBS (ms) | " << lbs.median << " | " << lbs.min << " | " << lbs.max << " |\n"
            << "\npeak RSS " << std::setprecision(0) << peak_rss_mib() << " MiB\n";
  return 0;
}

}  // namespace

int run_bench(int argc, char** argv) {
  const std::string usage =
      "usage: posekit bench <what> [options]\n\nbenchmarks:\n  io    reading 1M-triangle meshes and 1M-point clouds\n"
      "  body  building and posing a MakeHuman body\n"
      "  registration  the paper's Table 1: ct-FFD vs ICP on a dataset, with correspondence accuracy\n"
      "  pose  training, per-subject set-up and per-pose time of the pose deformation\n";
  if (argc < 1 || std::string(argv[0]) == "--help" || std::string(argv[0]) == "-h") {
    std::cout << usage;
    return argc < 1 ? 2 : 0;
  }
  const std::string what = argv[0];
  if (what == "io") return bench_io(argc - 1, argv + 1);
  if (what == "body") return bench_body(argc - 1, argv + 1);
  if (what == "registration") return bench_registration(argc - 1, argv + 1);
  if (what == "pose") return bench_pose(argc - 1, argv + 1);
  throw UsageError("unknown benchmark '" + what + "'\n" + usage);
}

}  // namespace posekit::cli
