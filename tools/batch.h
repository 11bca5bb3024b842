#pragma once
// Internal to the posekit CLI: what the batch commands (cmd_batch*.cpp) share: the job runner,
// the summary, the bodies' reading and the options.
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "cli.h"
#include "posekit/core/units.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/measurements.h"

namespace posekit::cli::batch {

/// A body file read quietly into posekit's frame (Y up, facing +Z) and metres: the unit from
/// `unit_option` or the body's extent, the orientation detected.
struct PreparedBody {
  BodyInput in;
  Unit unit = Unit::kMetre;
  BodyOrientation orientation;
  std::vector<std::string> warnings;
};

PreparedBody prepare_body(const std::string& path, const std::string& unit_option);

/// One batch command: what it does to an input, the settings its results depend on (a result made
/// with other settings is made again), and its columns in summary.csv.
struct BatchColumn {
  std::string header;
  std::function<std::string(const nlohmann::ordered_json&)> value;  ///< of a successful result
};
struct BatchJob {
  std::string command;
  nlohmann::ordered_json settings;
  /// The result fields of one input; `stem` names its extra output files. Throws on failure.
  std::function<nlohmann::ordered_json(const std::string& input, const std::string& stem)> process;
  std::vector<BatchColumn> columns;
  /// The files an input reads (its content key); empty: the input itself.
  std::function<std::vector<std::string>(const std::string& input)> files;
};

/// The inputs in a stable order: a folder's body files (recursively, sorted by path), or a list
/// file's lines (blank lines and # comments skipped), as given.
std::vector<std::string> list_inputs(const std::string& inputs);
/// A number of a result for summary.csv, with `digits` decimals ("" when absent).
std::string number(const nlohmann::json& value, int digits);
/// summary.json (no timings: shards merge into exactly the unsharded run's file) and summary.csv,
/// one row per input in input order.
void write_summary(const std::filesystem::path& out, const std::string& stem, const nlohmann::ordered_json& summary,
                   const std::vector<BatchColumn>& columns);
std::vector<BatchColumn> measure_columns();
std::vector<BatchColumn> compare_columns(bool measure);
std::vector<BatchColumn> pose_columns();
std::vector<BatchColumn> register_columns();

/// The options every batch command shares, and what their help says of them.
void add_batch_options(ArgParser* args);
extern const char* const kBatchCommon;

/// Runs `job` over the shard's inputs on --jobs threads: results/<name>.json per input, the summary,
/// run*.json. Returns the exit status.
int run_batch_job(const ArgParser& args, const BatchJob& job, const std::vector<std::string>& all);

int run_batch_measure(int argc, char** argv);
int run_batch_compare(int argc, char** argv);
int run_batch_pose(int argc, char** argv);
int run_batch_register(int argc, char** argv);
int run_batch_merge(int argc, char** argv);

}  // namespace posekit::cli::batch
