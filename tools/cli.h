#pragma once
// Command-line plumbing shared by the posekit subcommands.
#include <chrono>
#include <map>
#include <stdexcept>
#include <string>
#include <vector>

#include <nlohmann/json_fwd.hpp>

#include "posekit/core/point_cloud.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/core/units.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::cli {

/// Wrong usage of a subcommand (unknown option, missing value): exit code 2.
struct UsageError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

/// The non-empty items of a comma-separated list ("a,b,,c": a, b, c).
std::vector<std::string> split_commas(const std::string& list);

/// Declarative options of one subcommand; builds its --help text.
class ArgParser {
 public:
  ArgParser(std::string command, std::string summary) : command_(std::move(command)), summary_(std::move(summary)) {}

  ArgParser& positional(const std::string& name, const std::string& help, bool required = true);
  ArgParser& option(const std::string& name, const std::string& value_name, const std::string& help, const std::string& default_value = "");
  ArgParser& flag(const std::string& name, const std::string& help);
  /// --data DIR, the MakeHuman data root (find_data_root: else $POSEKIT_DATA, else
  /// ../shared/datasets/makehuman); `purpose` says what the command reads there ("for the BVH skeleton").
  ArgParser& data_option(const std::string& purpose = "");
  /// --model FILE, a trained pose model (.pkm, posekit train); `use` says what it does here ("" nothing more).
  ArgParser& pose_model_option(const std::string& use = "");
  /// --model FILE, a customization model (posekit customize train), customization.pkc by default.
  ArgParser& customization_model_option(const std::string& use = "");
  /// --body-model FILE, a body model (.pks, posekit shape-space --ansur).
  ArgParser& body_model_option(const std::string& use = "");
  ArgParser& example(const std::string& line);
  /// An option naming a file the command writes: its folder must exist, or --mkdir (added with the
  /// first output) creates it; a typo in a path is an error, not a new folder tree.
  ArgParser& output(const std::string& name, const std::string& value_name, const std::string& help, const std::string& default_value = "");
  /// An option naming a folder the command fills: the folder is created, its parent must exist (or --mkdir).
  ArgParser& output_folder(const std::string& name, const std::string& value_name, const std::string& help,
                           const std::string& default_value = "");
  /// A positional argument naming a file the command writes (as output()).
  ArgParser& positional_output(const std::string& name, const std::string& help);

  /// Parses argv; returns false when --help was printed.
  bool parse(int argc, char** argv);

  const std::string& get(const std::string& name) const;
  bool has(const std::string& name) const;
  /// Whether the command takes option `name` (given or not).
  bool declares(const std::string& name) const;
  bool flag_set(const std::string& name) const { return has(name); }
  double get_double(const std::string& name) const;
  std::vector<double> get_double_list(const std::string& name) const;  ///< "a,b,c"
  long get_int(const std::string& name) const;
  const std::vector<std::string>& positionals() const { return positional_values_; }
  std::string help() const;

 private:
  enum class Output { kNone, kFile, kFolder };
  struct Option {
    std::string name, value_name, help, default_value;
    bool is_flag = false;
    Output output = Output::kNone;
  };
  struct Positional {
    std::string name, help;
    bool required = true;
    bool is_output = false;
  };
  void add_mkdir_flag();
  void check_outputs() const;
  std::string command_, summary_;
  std::vector<Option> options_;
  std::vector<Positional> positional_specs_;
  std::vector<std::string> examples_;
  std::map<std::string, std::string> values_;
  std::vector<std::string> positional_values_;
};

/// Progress on stderr: a bar when stderr is a terminal, otherwise a line every ~10% (after 1 s).
/// finish() reports completion; destroying an unfinished Progress (an error) does not.
class Progress {
 public:
  Progress(std::string label, long total);
  void update(long done);
  void finish();
  ~Progress();

 private:
  std::string label_;
  long total_;
  int last_decile_ = -1;
  bool tty_;
  bool finished_ = false;
  bool shown_ = false;
  std::chrono::steady_clock::time_point start_;
};

/// A body file as the user gave it: a mesh, or a point cloud (PCD, XYZ, or a PLY without faces).
struct BodyInput {
  bool is_cloud = false;
  TriangleMesh mesh;
  PointCloud cloud;
};
BodyInput read_body_input(const std::string& path, Unit unit);
/// Whether read_body_input reads `path` as a point cloud (PCD, XYZ, a PLY whose header has no faces).
bool is_point_cloud_file(const std::string& path);
/// The same, quiet: the readers' warnings go to `warnings` (for work on several threads).
BodyInput read_body_input(const std::string& path, Unit unit, std::vector<std::string>* warnings);

/// The unit a body file was read in: given, or detected from its largest extent.
struct BodyUnit {
  Unit unit = Unit::kMetre;
  bool detected = false;
  double extent = 0;  ///< when detected: robust_largest_extent() in the file's numbers
  /// e.g. "mm (detected from the body's largest extent, 1712)" or "m (given)".
  std::string describe() const;
};
/// One unit rule for meshes and scans: `unit_option` is a unit (m, dm, cm, mm) or "auto", where the
/// largest extent (stray points aside) tells (a standing body or a torso, 0.5 to 3 m, in m, dm, cm or mm). A detected
/// unit is announced on stderr by `command`; an extent no unit explains is an error naming the
/// file and asking for the unit.
BodyInput read_body_input(const std::string& path, const std::string& unit_option, const std::string& command, BodyUnit* chosen);
/// The unit of `points` read in metres, detected from their largest extent as read_body_input does
/// (the same message on stderr); scales them to metres.
BodyUnit detect_body_unit(Eigen::MatrixXd* points, const std::string& path, const std::string& command);

/// Adds --<prefix>up and --<prefix>forward (an axis such as +X or -Z, or auto) for `what`.
void add_orientation_options(ArgParser* args, const std::string& prefix = "", const std::string& what = "the body");

/// Turns a body read from `path` into posekit's frame (Y up, facing +Z, left +X): the options are
/// axes or "auto" (detected from the body's shape). Announces the orientation on stderr from
/// `command`, with any doubt as warnings; normals turn too. Returns the orientation applied.
BodyOrientation orient_body_input(BodyInput* in, const std::string& up_option, const std::string& forward_option, const std::string& path,
                                  const std::string& command);

/// Points (#P x 3, rows) in posekit's frame written back in the file's frame.
Eigen::MatrixXd in_file_frame(const BodyOrientation& orientation, const Eigen::MatrixXd& P);
/// A single point back in the file's frame.
Eigen::Vector3d in_file_frame(const BodyOrientation& orientation, const Eigen::Vector3d& p);

/// {"up": "+X", "forward": "-Z", "up_detected": .., "forward_detected": .., "posekit_from_file": [[..]], "warnings": []}.
nlohmann::ordered_json orientation_json(const BodyOrientation& orientation);

/// Where the CLI's readers and writers put their warnings (what was read with a caveat, what a
/// format cannot hold). flush_warnings() prints them as "warning: ..." on stderr; main calls it
/// after every command, failed or not, and commands call it after reading their inputs.
std::vector<std::string>* io_warnings();
void flush_warnings();

/// Prints JSON to stdout, pretty, with a trailing newline.
void print_json(const nlohmann::json& value);

/// Median, min and max of a sample (seconds or any unit).
struct Stats {
  double median = 0, min = 0, max = 0;
};
Stats stats_of(std::vector<double> values);

/// Two numbers written with a separator, as "A:B" or "WxH"; UsageError naming `option` otherwise.
std::pair<double, double> parse_number_pair(const std::string& text, char separator, const std::string& option);

/// Peak resident set size of this process so far, in MiB (from /proc/self/status).
double peak_rss_mib();

/// Resets that peak to the current resident size (Linux 4.0+, /proc/self/clear_refs), so that the
/// peak of one stage of a benchmark can be read; false where the kernel does not allow it.
bool reset_peak_rss();

}  // namespace posekit::cli
