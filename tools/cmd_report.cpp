// posekit report: the paper's figures and tables regenerated from a dataset into an HTML page.
#include <iomanip>
#include <iostream>
#include <limits>
#include <memory>

#include "cli.h"
#include "commands.h"
#include "posekit/paper/report.h"

namespace posekit::cli {

int run_report(int argc, char** argv) {
  ArgParser args("report",
                 "Regenerates the paper's evaluation figures and tables from a dataset: the template in synthesized\n"
                 "poses (Fig. 2), the same poses on a customized model (Fig. 3), customized models against scans\n"
                 "(Fig. 4, customized from photos), all women and men customized from photos (Figs. 5, 6), all female and male subjects "
                 "(Fig. 7), posed subjects (Fig. 8), posed models beside their\n"
                 "scans (Fig. 9), the registration timing table (Table 1) and the pose error table, into\n"
                 "OUT/index.html and OUT/report.md with the PNGs (off-screen VTK; no display needed).");
  args.option("dataset", "DIR", "a posekit dataset (posekit dataset make)")
      .output_folder("out", "DIR", "report folder (created; report files in it are replaced)", "report")
      .pose_model_option("default: train on the dataset")
      .option("calibration-bodies", "N", "segmentation prior of a pose model trained here: MakeHuman bodies (0: the template alone)", "128")
      .option("threads", "N", "threads for the scan comparisons (0: all cores)", "0")
      .option("runs", "R", "timed runs per method and subject in Table 1", "3")
      .option("nicp-subjects", "N", "run the slow non-rigid ICP baseline on the first N subjects (0: leave it out)", "2")
      .option("customization", "FILE", "photo customization model (.pkc); default: train one (customize train)")
      .option("customization-bodies", "N", "population of a customization model trained here", "2000")
      .option("shape-space", "N|FILE",
              "Table 1's ct-FFD + shape space row: MakeHuman bodies in the space, or a .pks file "
              "(posekit shape-space) (0: no row)",
              "300")
      .option("cache", "DIR",
              "folder of reusable results: the trained models and Table 1, reused while their inputs "
              "(dataset, data root, options, this posekit) are unchanged (default: OUT/.cache)")
      .flag("no-cache", "make everything afresh and keep nothing")
      .flag("full-table", "Table 1 in full: the slow non-rigid ICP baseline on every subject (as --nicp-subjects all)")
      .example("posekit report --dataset out/dataset --out report")
      .example("posekit report --dataset out/dataset --out report --full-table --no-cache");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  ReportOptions o;
  o.model_path = args.has("model") ? args.get("model") : "";
  o.threads = static_cast<int>(args.get_int("threads"));
  o.calibration_bodies = static_cast<int>(args.get_int("calibration-bodies"));
  if (o.calibration_bodies < 0) throw UsageError("--calibration-bodies must not be negative");
  o.registration_runs = static_cast<int>(args.get_int("runs"));
  o.nicp_subjects = args.flag_set("full-table") ? std::numeric_limits<int>::max() : static_cast<int>(args.get_int("nicp-subjects"));
  if (!args.flag_set("no-cache")) o.cache_dir = args.has("cache") ? args.get("cache") : args.get("out") + "/.cache";
  o.customization_path = args.has("customization") ? args.get("customization") : "";
  o.customization_bodies = static_cast<int>(args.get_int("customization-bodies"));
  if (is_shape_space_file(args.get("shape-space"))) {
    o.shape_space_path = args.get("shape-space");
  } else {
    o.shape_space_bodies = static_cast<int>(args.get_int("shape-space"));
    if (o.shape_space_bodies < 0 || o.shape_space_bodies == 1)
      throw UsageError("--shape-space must be 0, at least 2 bodies, or a .pks file");
  }
  if (o.registration_runs < 1) throw UsageError("--runs must be at least 1");
  o.command_line = "posekit report --dataset " + args.get("dataset") + " --out " + args.get("out");
  std::unique_ptr<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress = std::make_unique<Progress>("report", total);
    progress->update(done);
  };
  const ReportSummary s = write_report(args.get("dataset"), args.get("out"), o);
  if (progress) progress->finish();
  for (const auto& w : s.warnings) std::cerr << "posekit report: warning: " << w << "\n";
  std::cerr << "posekit report: stages (s):";
  for (const auto& [what, seconds] : s.stage_seconds)
    std::cerr << " " << what << " " << std::fixed << std::setprecision(1) << seconds << ";";
  std::cerr << "\n";
  for (const auto& r : s.reused) std::cerr << "posekit report: reused " << r << "\n";
  std::cout << "wrote " << args.get("out") << "/index.html (" << s.files.size() << " files, " << s.warnings.size() << " warnings) in "
            << static_cast<int>(s.seconds + 0.5) << " s, peak RSS " << static_cast<int>(peak_rss_mib() + 0.5) << " MiB\n";
  return 0;
}

}  // namespace posekit::cli
