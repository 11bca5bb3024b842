#pragma once
// `posekit report`: the paper's evaluation figures and tables regenerated from a dataset, as an
// HTML page and Markdown with PNG figures (VTK, off-screen).
#include <functional>
#include <string>
#include <utility>
#include <vector>

namespace posekit {

struct ReportOptions {
  std::string model_path;           ///< trained model (.pkm); empty: train on the dataset
  int calibration_bodies = 128;     ///< segmentation prior of a model trained here (0: the template alone)
  int threads = 0;                  ///< for the scan comparisons (0: all cores)
  int registration_runs = 3;        ///< timed runs per method and subject in Table 1
  int nicp_subjects = 2;            ///< non-rigid ICP (seconds per run) on the first N subjects only
  int shape_space_bodies = 300;     ///< Table 1's "ct-FFD + shape space" row: MakeHuman bodies in the space (0: no row)
  std::string shape_space_path;     ///< that row's space from a .pks file (posekit shape-space) instead
  std::string customization_path;   ///< photo customization model (.pkc); empty: train one here
  int customization_bodies = 2000;  ///< population of a customization model trained here
  /// Folder of reusable results (the trained models, Table 1), each kept under a hash of all it was
  /// made from (the dataset's and data root's files by size and time, the options, the posekit
  /// binary) and reused when that is unchanged; empty: everything made afresh, nothing kept.
  std::string cache_dir;
  std::string command_line;  ///< how the report was asked for, quoted in it
  std::function<void(int, int, const std::string&)> progress;
};

struct ReportSummary {
  std::vector<std::string> files;     ///< everything written, relative to the output folder
  std::vector<std::string> warnings;  ///< also listed in the report
  double seconds = 0;
  std::vector<std::pair<std::string, double>> stage_seconds;  ///< wall seconds of each stage, in order
  std::vector<std::string> reused;                            ///< the results taken from the cache
};

/// Writes index.html, report.md, report.json and the figures into `out_dir` (created; existing
/// report files are replaced). Each figure or table that cannot be made becomes a warning in the
/// report instead of a broken link. Throws IoError when the dataset cannot be read at all.
ReportSummary write_report(const std::string& dataset_dir, const std::string& out_dir, const ReportOptions& options);

}  // namespace posekit
