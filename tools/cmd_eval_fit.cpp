// posekit eval fit: posekit fit on a dataset's simulated scans of posed subjects, against the truth.
#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <numeric>

#include "cli.h"
#include "commands.h"
#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/datasets/dataset.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posing_inputs.h"

namespace fs = std::filesystem;

namespace posekit::cli {
namespace {

/// Angle (degrees) between two poses' rotations: the root's, then each joint's.
std::vector<double> joint_angle_errors(const PartPose& a, const PartPose& b) {
  std::vector<double> out{rotation_difference(a.root_rotation, b.root_rotation) * 180 / M_PI};
  for (int j = 0; j < kNumJoints; ++j) out.push_back(rotation_difference(a.joint(j), b.joint(j)) * 180 / M_PI);
  return out;
}
}  // namespace

int run_eval_fit(int argc, char** argv) {
  ArgParser args("eval fit",
                 "posekit fit on a dataset's simulated scans of posed subjects (holes, noise, outliers), against the\n"
                 "poses and posed meshes that made them: joint angle error, per-vertex error against the true posed\n"
                 "mesh, target-to-body distance and time, for the learned and the LBS posing in the loop.");
  args.option("dataset", "DIR", "a posekit dataset")
      .pose_model_option()
      .option("subjects", "N", "the first N subjects (0: all)", "0")
      .flag("from-truth", "start every fit at the true pose instead of searching: what the objective itself gives")
      .flag("json", "results as JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset") || !args.has("model")) throw UsageError("--dataset DIR and --model FILE are required");
  const bool from_truth = args.flag_set("from-truth");
  const std::string dir = args.get("dataset");
  const auto model = read_posing_model(args.get("model"), "eval fit");
  const auto manifest = nlohmann::json::parse(read_file_bytes(dir + "/manifest.json"));
  const long limit = args.get_int("subjects");
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  struct Sums {
    std::vector<double> angle, vertex, target, seconds;
  };
  std::map<std::string, Sums> sums;
  int done = 0;
  Progress progress("eval fit", limit > 0 ? limit : static_cast<long>(manifest["subjects"].size()));
  for (const auto& s : manifest["subjects"]) {
    if (limit > 0 && done >= limit) break;
    const std::string id = s["id"];
    const TriangleMesh subject = load_subject_mesh(dir + "/" + s["rest"].get<std::string>());
    const PoseSynthesizer synth(model, subject);
    for (const auto& p : s.value("posed", nlohmann::json::array())) {
      const std::string pose_name = p["pose"];
      const std::string scan = dir + "/scans/" + id + "/" + pose_name + ".pcd";
      if (!fs::is_regular_file(scan)) continue;
      const PointCloud cloud = load_scan(scan);
      const PartPose truth = read_part_pose(dir + "/" + p["pose_json"].get<std::string>());
      const TriangleMesh truth_mesh = read_mesh(dir + "/" + p["mesh"].get<std::string>());
      for (PoseMethod method : {PoseMethod::kLearned, PoseMethod::kLbs}) {
        PoseFitOptions o;
        o.method = method;
        if (from_truth) o.start = truth;
        const PoseFitResult r = fit_pose(synth, cloud.P, o);
        const std::vector<double> angles = joint_angle_errors(r.pose, truth);
        const double angle_mean = std::accumulate(angles.begin(), angles.end(), 0.0) / static_cast<double>(angles.size());
        const double angle_max = *std::max_element(angles.begin(), angles.end());
        nlohmann::ordered_json per_joint = {{"root", angles[0]}};
        for (int j = 0; j < kNumJoints; ++j) per_joint[joint_name(j)] = angles[static_cast<size_t>(j + 1)];
        const double vertex = (r.V - truth_mesh.V).rowwise().norm().mean();
        Sums& a = sums[pose_method_name(method)];
        a.angle.push_back(angle_mean);
        a.vertex.push_back(1000 * vertex);
        a.target.push_back(1000 * r.target_mean);
        a.seconds.push_back(r.seconds);
        rows.push_back({{"subject", id},
                        {"pose", pose_name},
                        {"method", pose_method_name(method)},
                        {"joint_angle_error_deg", {{"mean", angle_mean}, {"max", angle_max}, {"per_joint", per_joint}}},
                        {"vertex_error_mm", 1000 * vertex},
                        {"fit", fit_summary_json(r)}});
      }
    }
    progress.update(++done);
  }
  progress.finish();
  auto mean = [](const std::vector<double>& v) {
    double t = 0;
    for (double x : v) t += x;
    return v.empty() ? 0.0 : t / static_cast<double>(v.size());
  };
  nlohmann::ordered_json summary = nlohmann::ordered_json::object();
  for (const auto& [method, a] : sums)
    summary[method] = {{"scans", a.angle.size()},
                       {"joint_angle_error_deg_mean", mean(a.angle)},
                       {"vertex_error_mm_mean", mean(a.vertex)},
                       {"target_to_body_mm_mean", mean(a.target)},
                       {"seconds_median", stats_of(a.seconds).median},
                       {"seconds_max", stats_of(a.seconds).max}};
  if (args.flag_set("json")) {
    print_json({{"dataset", dir}, {"summary", summary}, {"fits", rows}});
    return 0;
  }
  std::cout << std::fixed << std::setprecision(2)
            << "| posing in the loop | scans | joint angle error, mean deg | vertex error vs truth, mean mm | scan to body, mean mm | s "
               "per scan (median / max) |\n"
               "|---|---|---|---|---|---|\n";
  for (const auto& [method, a] : sums)
    std::cout << "| " << method << " | " << a.angle.size() << " | " << mean(a.angle) << " | " << mean(a.vertex) << " | " << mean(a.target)
              << " | " << stats_of(a.seconds).median << " / " << stats_of(a.seconds).max << " |\n";
  return 0;
}

}  // namespace posekit::cli
