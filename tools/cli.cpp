#include "cli.h"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/core/units.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"

namespace posekit::cli {

std::vector<std::string> split_commas(const std::string& list) {
  std::vector<std::string> out;
  std::stringstream ss(list);
  for (std::string item; std::getline(ss, item, ',');)
    if (!item.empty()) out.push_back(item);
  return out;
}
namespace {

/// Spaces between a name and its help in the 24-column layout; a name that does not fit gets the
/// help on its own line.
std::string help_gap(const std::string& name) {
  return name.size() + 2 <= 24 ? std::string(24 - name.size(), ' ') : "\n" + std::string(26, ' ');
}

}  // namespace

ArgParser& ArgParser::positional(const std::string& name, const std::string& help, bool required) {
  positional_specs_.push_back({name, help, required});
  return *this;
}
ArgParser& ArgParser::option(const std::string& name, const std::string& value_name, const std::string& help,
                             const std::string& default_value) {
  options_.push_back({name, value_name, help, default_value, false});
  return *this;
}
ArgParser& ArgParser::flag(const std::string& name, const std::string& help) {
  options_.push_back({name, "", help, "", true});
  return *this;
}
ArgParser& ArgParser::data_option(const std::string& purpose) {
  return option(
      "data", "DIR",
      "MakeHuman data root" + (purpose.empty() ? "" : " " + purpose) + " (default: $POSEKIT_DATA, else ../shared/datasets/makehuman)");
}
ArgParser& ArgParser::pose_model_option(const std::string& use) {
  return option("model", "FILE", "trained pose model (.pkm, posekit train)" + (use.empty() ? "" : ": " + use));
}
ArgParser& ArgParser::customization_model_option(const std::string& use) {
  return option("model", "FILE", "customization model (posekit customize train)" + (use.empty() ? "" : ": " + use), "customization.pkc");
}
ArgParser& ArgParser::body_model_option(const std::string& use) {
  return option("body-model", "FILE", "body model (.pks, posekit shape-space --ansur)" + (use.empty() ? "" : ": " + use));
}
ArgParser& ArgParser::example(const std::string& line) {
  examples_.push_back(line);
  return *this;
}
void ArgParser::add_mkdir_flag() {
  if (std::none_of(options_.begin(), options_.end(), [](const Option& o) { return o.name == "mkdir"; }))
    flag("mkdir", "create the missing folders of the output paths (without it a missing folder is an error)");
}
ArgParser& ArgParser::output(const std::string& name, const std::string& value_name, const std::string& help,
                             const std::string& default_value) {
  options_.push_back({name, value_name, help, default_value, false, Output::kFile});
  add_mkdir_flag();
  return *this;
}
ArgParser& ArgParser::output_folder(const std::string& name, const std::string& value_name, const std::string& help,
                                    const std::string& default_value) {
  options_.push_back({name, value_name, help, default_value, false, Output::kFolder});
  add_mkdir_flag();
  return *this;
}
ArgParser& ArgParser::positional_output(const std::string& name, const std::string& help) {
  positional_specs_.push_back({name, help, true, true});
  add_mkdir_flag();
  return *this;
}

/// The rule for output paths: an output file's folder, or an output folder's parent, must exist;
/// --mkdir creates what is missing. Output folders themselves are created by their commands.
void ArgParser::check_outputs() const {
  const bool mkdir = has("mkdir");
  auto check_file = [&](const std::string& path) {
    if (!path.empty()) require_output_folder(path, mkdir);
  };
  for (const auto& o : options_) {
    if (o.output == Output::kNone || !has(o.name)) continue;
    const std::string& value = get(o.name);
    if (o.output == Output::kFile) {
      check_file(value);
      continue;
    }
    std::error_code ec;
    if (std::filesystem::is_directory(value, ec)) continue;
    if (std::filesystem::exists(value, ec)) throw IoError(value + ": --" + o.name + " exists and is not a folder");
    // Its parent as for a file: the folder itself is the command's to create.
    std::filesystem::path folder(value);
    if (!folder.has_filename()) folder = folder.parent_path();  // "out/"
    check_file(folder.string());
  }
  for (size_t k = 0; k < positional_specs_.size() && k < positional_values_.size(); ++k)
    if (positional_specs_[k].is_output) check_file(positional_values_[k]);
}

std::string ArgParser::help() const {
  std::ostringstream out;
  out << "usage: posekit " << command_;
  for (const auto& p : positional_specs_) out << (p.required ? " <" : " [<") << p.name << (p.required ? ">" : ">]");
  out << " [options]\n\n" << summary_ << "\n";
  if (!positional_specs_.empty()) {
    out << "\narguments:\n";
    for (const auto& p : positional_specs_) out << "  " << p.name << help_gap(p.name) << p.help << "\n";
  }
  out << "\noptions:\n";
  for (const auto& o : options_) {
    std::string lhs = "--" + o.name + (o.is_flag ? "" : " " + o.value_name);
    out << "  " << lhs << help_gap(lhs) << o.help;
    if (!o.default_value.empty()) out << " (default: " << o.default_value << ")";
    out << "\n";
  }
  out << "  --help" << std::string(18, ' ') << "show this help\n";
  if (!examples_.empty()) {
    out << "\nexamples:\n";
    for (const auto& e : examples_) out << "  " << e << "\n";
  }
  return out.str();
}

bool ArgParser::parse(int argc, char** argv) {
  for (int i = 0; i < argc; ++i) {
    std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << help();
      return false;
    }
    if (a.rfind("--", 0) == 0 && a.size() > 2) {
      std::string name = a.substr(2), value;
      const size_t eq = name.find('=');
      const bool inline_value = eq != std::string::npos;
      if (inline_value) {
        value = name.substr(eq + 1);
        name = name.substr(0, eq);
      }
      auto it = std::find_if(options_.begin(), options_.end(), [&](const Option& o) { return o.name == name; });
      if (it == options_.end()) throw UsageError("unknown option --" + name + " (see posekit " + command_ + " --help)");
      if (it->is_flag) {
        if (inline_value) throw UsageError("--" + name + " takes no value");
        values_[name] = "1";
      } else {
        if (!inline_value) {
          if (i + 1 >= argc) throw UsageError("--" + name + " needs a value <" + it->value_name + ">");
          value = argv[++i];
        }
        values_[name] = value;
      }
    } else {
      positional_values_.push_back(a);
    }
  }
  size_t required = 0;
  for (const auto& p : positional_specs_) required += p.required;
  if (positional_values_.size() < required)
    throw UsageError("missing argument <" + positional_specs_[positional_values_.size()].name + "> (see posekit " + command_ + " --help)");
  if (positional_values_.size() > positional_specs_.size())
    throw UsageError("unexpected argument '" + positional_values_[positional_specs_.size()] + "' (see posekit " + command_ + " --help)");
  for (const auto& o : options_)
    if (!o.is_flag && !o.default_value.empty() && !values_.count(o.name)) values_[o.name] = o.default_value;
  check_outputs();
  return true;
}

const std::string& ArgParser::get(const std::string& name) const {
  static const std::string empty;
  auto it = values_.find(name);
  return it == values_.end() ? empty : it->second;
}
bool ArgParser::has(const std::string& name) const { return values_.count(name) > 0; }

bool ArgParser::declares(const std::string& name) const {
  return std::any_of(options_.begin(), options_.end(), [&](const Option& o) { return o.name == name; });
}

double ArgParser::get_double(const std::string& name) const {
  const std::string& v = get(name);
  try {
    size_t used = 0;
    const double d = std::stod(v, &used);
    if (used == v.size()) return d;
  } catch (...) {
  }
  throw UsageError("--" + name + " expects a number, got '" + v + "'");
}
std::vector<double> ArgParser::get_double_list(const std::string& name) const {
  const std::string& v = get(name);
  std::vector<double> out;
  size_t begin = 0;
  while (begin <= v.size()) {
    const size_t end = std::min(v.find(',', begin), v.size());
    const std::string item = v.substr(begin, end - begin);
    try {
      size_t used = 0;
      out.push_back(std::stod(item, &used));
      if (used != item.size()) throw UsageError("");
    } catch (...) {
      throw UsageError("--" + name + " expects numbers separated by commas, got '" + v + "'");
    }
    begin = end + 1;
  }
  return out;
}
long ArgParser::get_int(const std::string& name) const {
  const std::string& v = get(name);
  try {
    size_t used = 0;
    const long d = std::stol(v, &used);
    if (used == v.size()) return d;
  } catch (...) {
  }
  throw UsageError("--" + name + " expects an integer, got '" + v + "'");
}

Progress::Progress(std::string label, long total)
    : label_(std::move(label)), total_(std::max(1L, total)), tty_(::isatty(2)), start_(std::chrono::steady_clock::now()) {}

void Progress::update(long done) {
  const double frac = std::min(1.0, static_cast<double>(done) / total_);
  const int decile = static_cast<int>(frac * 10);
  const double secs = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  if (tty_ && secs >= 0.3) {
    shown_ = true;
    const int width = 30, filled = static_cast<int>(frac * width);
    std::fprintf(stderr, "\r%s [%s%s] %3d%% %ld/%ld %.1fs", label_.c_str(), std::string(filled, '#').c_str(),
                 std::string(width - filled, '.').c_str(), static_cast<int>(frac * 100), done, total_, secs);
    std::fflush(stderr);
  } else if (decile > last_decile_ && secs >= 1.0) {  // quiet for work under a second
    last_decile_ = decile;
    std::fprintf(stderr, "%s: %d%% (%ld/%ld, %.1fs)\n", label_.c_str(), decile * 10, done, total_, secs);
  }
}

void Progress::finish() {
  if (finished_) return;
  finished_ = true;
  update(total_);
  if (tty_ && shown_) std::fprintf(stderr, "\n");
}

Progress::~Progress() {
  if (tty_ && shown_ && !finished_) std::fprintf(stderr, "\n");  // abandoned (an error): no 100%
}

std::vector<std::string>* io_warnings() {
  static std::vector<std::string> warnings;
  return &warnings;
}

void flush_warnings() {
  for (const std::string& w : *io_warnings()) std::cerr << "warning: " << w << "\n";
  io_warnings()->clear();
}

namespace {

/// Whether a PLY file's header declares no faces (a scan's points): read as a cloud at once, not
/// parsed as a mesh first (10M points took twice the time). False when the header cannot tell.
bool ply_header_has_no_faces(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string line;
  for (int lines = 0; lines < 1000 && std::getline(in, line); ++lines) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line == "end_header") return true;
    std::istringstream words(line);
    std::string keyword, name;
    long long count = -1;
    if (words >> keyword >> name >> count && keyword == "element" && name == "face") return count == 0;
  }
  return false;
}

}  // namespace

bool is_point_cloud_file(const std::string& path) {
  const CloudFormat cf = cloud_format_from_path(path);
  return cf == CloudFormat::kPcd || cf == CloudFormat::kXyz || (cf == CloudFormat::kPly && ply_header_has_no_faces(path));
}

BodyInput read_body_input(const std::string& path, Unit unit, std::vector<std::string>* warnings) {
  BodyInput in;
  in.is_cloud = is_point_cloud_file(path);
  if (!in.is_cloud) {
    const size_t before = warnings->size();
    try {
      in.mesh = read_mesh(path, {unit, MeshFormat::kAuto, warnings});
      return in;
    } catch (const IoError& e) {
      // A PLY, OBJ or OFF without faces is a point cloud.
      if (std::string(e.what()).find("no faces") == std::string::npos) throw;
      warnings->resize(before);
      in.is_cloud = true;
    }
  }
  in.cloud = read_point_cloud(path, {unit, CloudFormat::kAuto, warnings});
  return in;
}

BodyInput read_body_input(const std::string& path, Unit unit) {
  BodyInput in = read_body_input(path, unit, io_warnings());
  flush_warnings();
  return in;
}

std::string BodyUnit::describe() const {
  std::ostringstream text;
  text << unit_name(unit);
  if (detected) text << " (detected from the body's largest extent, " << std::setprecision(4) << extent << ")";
  else text << " (given)";
  return text.str();
}

BodyInput read_body_input(const std::string& path, const std::string& unit_option, const std::string& command, BodyUnit* chosen) {
  const bool automatic = unit_option == "auto";
  BodyUnit u;
  u.unit = automatic ? Unit::kMetre : parse_unit(unit_option);
  BodyInput in = read_body_input(path, u.unit);
  if (automatic) u = detect_body_unit(in.is_cloud ? &in.cloud.P : &in.mesh.V, path, command);
  if (chosen) *chosen = u;
  return in;
}

BodyUnit detect_body_unit(Eigen::MatrixXd* points, const std::string& path, const std::string& command) {
  BodyFrame frame;
  try {
    frame = scale_body_to_metres(points, "auto");
  } catch (const InvalidInput& e) {
    throw InvalidInput(path + ": " + e.what() + " (e.g. --unit mm)");
  }
  BodyUnit u;
  u.unit = parse_unit(frame.unit);
  u.extent = frame.extent;
  u.detected = true;
  std::cerr << "posekit " << command << ": " << path << ": unit " << u.describe() << "\n";
  return u;
}

void add_orientation_options(ArgParser* args, const std::string& prefix, const std::string& what) {
  args->option(prefix + "up", "AXIS", "the axis " + what + " stands along (+X, -Y, ...) or auto (detected)", "auto")
      .option(prefix + "forward", "AXIS", "the axis " + what + " faces, or auto (the feet tell)", "auto");
}

BodyOrientation orient_body_input(BodyInput* in, const std::string& up_option, const std::string& forward_option, const std::string& path,
                                  const std::string& command) {
  if (up_option != "auto") parse_axis(up_option);  // a bad axis is a usage error, not the file's
  if (forward_option != "auto") parse_axis(forward_option);
  BodyOrientation orientation;
  try {
    const Eigen::MatrixXd& points = in->is_cloud ? in->cloud.P : in->mesh.V;  // read before any is turned
    orientation = turn_body_to_posekit_frame({&in->cloud.P, &in->cloud.N, &in->mesh.V, &in->mesh.N}, points,
                                             in->is_cloud ? nullptr : &in->mesh.F, up_option, forward_option);
  } catch (const InvalidInput& e) {
    throw InvalidInput(path + ": " + e.what());
  }
  std::cerr << "posekit " << command << ": " << path << ": " << orientation.describe()
            << (orientation.is_identity() ? ", posekit's own frame" : ": turned into posekit's frame (Y up, facing +Z)") << "\n";
  for (const auto& w : orientation.warnings) std::cerr << "warning: " << path << ": " << w << "\n";
  return orientation;
}

Eigen::MatrixXd in_file_frame(const BodyOrientation& orientation, const Eigen::MatrixXd& P) {
  return P * orientation.rotation;  // rows: (R^T p)^T = p^T R
}

Eigen::Vector3d in_file_frame(const BodyOrientation& orientation, const Eigen::Vector3d& p) { return orientation.rotation.transpose() * p; }

nlohmann::ordered_json orientation_json(const BodyOrientation& orientation) {
  nlohmann::ordered_json R = nlohmann::ordered_json::array();
  for (int r = 0; r < 3; ++r) R.push_back({orientation.rotation(r, 0), orientation.rotation(r, 1), orientation.rotation(r, 2)});
  return {{"up", axis_name(orientation.up())},
          {"forward", axis_name(orientation.forward())},
          {"up_detected", orientation.up_detected},
          {"forward_detected", orientation.forward_detected},
          {"posekit_from_file", R},
          {"warnings", orientation.warnings}};
}

void print_json(const nlohmann::json& value) { std::cout << value.dump(2) << std::endl; }

Stats stats_of(std::vector<double> v) {
  Stats s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.max = v.back();
  s.median = v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
  return s;
}

std::pair<double, double> parse_number_pair(const std::string& text, char separator, const std::string& option) {
  const auto at = text.find(separator);
  try {
    if (at == std::string::npos) throw std::invalid_argument(text);
    size_t used_a = 0, used_b = 0;
    const std::string a = text.substr(0, at), b = text.substr(at + 1);
    const double first = std::stod(a, &used_a), second = std::stod(b, &used_b);
    if (used_a != a.size() || used_b != b.size()) throw std::invalid_argument(text);
    return {first, second};
  } catch (const std::exception&) {
    throw UsageError(option + " expects two numbers as A" + std::string(1, separator) + "B, got '" + text + "'");
  }
}

bool reset_peak_rss() {
  std::ofstream clear("/proc/self/clear_refs");
  clear << "5";
  clear.flush();
  return static_cast<bool>(clear);
}

double peak_rss_mib() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line))
    if (line.rfind("VmHWM:", 0) == 0) return std::stod(line.substr(6)) / 1024.0;
  return 0.0;
}

}  // namespace posekit::cli
