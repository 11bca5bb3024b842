// posekit batch: one command over many bodies, on several cores and, by shards, several machines.
#include <algorithm>
#include <atomic>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/timer.h"
#include "posekit/core/units.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/evaluation/scan_comparison.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/checksum.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/registration/registration.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/measurements.h"

namespace posekit::cli {
namespace fs = std::filesystem;
namespace {

const char* const kGirthNames[] = {"bust", "underbust", "waist", "hip", "thigh", "knee", "calf", "ankle", "upper_arm", "wrist", "neck"};

bool is_body_file(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".ply" || ext == ".obj" || ext == ".off" || ext == ".stl" || ext == ".pcd" || ext == ".xyz";
}

/// The inputs in a stable order: a folder's body files (recursively, sorted by path), or a list
/// file's lines (blank lines and # comments skipped), as given.
std::vector<std::string> list_inputs(const std::string& inputs) {
  std::vector<std::string> out;
  if (fs::is_directory(inputs)) {
    for (const auto& e : fs::recursive_directory_iterator(inputs))
      if (e.is_regular_file() && is_body_file(e.path())) out.push_back(e.path().string());
    std::sort(out.begin(), out.end());
  } else {
    std::istringstream lines(read_file_bytes(inputs));
    for (std::string line; std::getline(lines, line);) {
      while (!line.empty() && (line.back() == '\r' || line.back() == ' ')) line.pop_back();
      if (!line.empty() && line[0] != '#') out.push_back(line);
    }
  }
  if (out.empty()) throw InvalidInput(inputs + ": no body files (PLY, OBJ, OFF, STL, PCD, XYZ) to process");
  return out;
}

/// Result name of an input (its result is results/<name>.json): its path with separators and
/// spaces as "_", readable, then 8 hex digits of the CRC-32 of the input as given, so that inputs
/// whose readable names coincide (x_y/body.ply and x/y_body.ply) never share a result.
std::string result_name(const std::string& input) {
  std::string name = fs::path(input).lexically_normal().relative_path().string();
  for (char& c : name)
    if (c == '/' || c == '\\' || c == ':' || c == ' ' || c == '\t' || c == ',') c = '_';
  char hash[16];
  std::snprintf(hash, sizeof hash, "-%08x", static_cast<unsigned>(crc32(input.data(), input.size())));
  return name + hash;
}

/// What a result depends on besides the command's settings: each file the input names, by size and
/// CRC-32 of its bytes (the modification time is recorded, not compared: a copy or a touch that
/// keeps the bytes keeps the result; another body under the same name does not).
nlohmann::ordered_json input_content(const std::vector<std::string>& files) {
  nlohmann::ordered_json content = nlohmann::ordered_json::array();
  for (const std::string& file : files) {
    std::error_code ec;
    const auto bytes = fs::file_size(file, ec);
    if (ec) throw IoError(file + ": cannot read (" + ec.message() + ")");
    const auto mtime = fs::last_write_time(file, ec);
    content.push_back({{"file", file},
                       {"bytes", bytes},
                       {"crc32", file_crc32(file)},
                       {"mtime_ns", ec ? 0LL : static_cast<long long>(mtime.time_since_epoch().count())}});
  }
  return content;
}

/// Whether two input_content() records name the same bytes.
bool same_content(const nlohmann::ordered_json& a, const nlohmann::ordered_json& b) {
  if (!a.is_array() || !b.is_array() || a.size() != b.size()) return false;
  for (size_t k = 0; k < a.size(); ++k)
    if (a[k].value("file", "") != b[k].value("file", "") || a[k].value("bytes", -1LL) != b[k].value("bytes", -2LL) ||
        a[k].value("crc32", -1LL) != b[k].value("crc32", -2LL))
      return false;
  return true;
}

/// A body file read quietly into posekit's frame (Y up, facing +Z) and metres: the unit from
/// `unit_option` or the body's extent, the orientation detected.
struct PreparedBody {
  BodyInput in;
  Unit unit = Unit::kMetre;
  BodyOrientation orientation;
  std::vector<std::string> warnings;
};

PreparedBody prepare_body(const std::string& path, const std::string& unit_option) {
  PreparedBody b;
  b.in = read_body_input(path, Unit::kMetre, &b.warnings);
  Eigen::MatrixXd& P = b.in.is_cloud ? b.in.cloud.P : b.in.mesh.V;
  if (unit_option == "auto") {
    const double extent = robust_largest_extent(P);
    if (!guess_body_unit(extent, &b.unit))
      throw InvalidInput(path + ": its largest extent is " + std::to_string(extent) +
                         " units, which no unit (m, dm, cm, mm) makes a body; give the unit");
  } else {
    b.unit = parse_unit(unit_option);
  }
  P *= metres_per_unit(b.unit);
  b.orientation = b.in.is_cloud ? detect_body_orientation(P) : detect_mesh_orientation(b.in.mesh.V, b.in.mesh.F);
  if (!b.orientation.is_identity()) {
    P = (P * b.orientation.rotation.transpose()).eval();
    Eigen::MatrixXd& N = b.in.is_cloud ? b.in.cloud.N : b.in.mesh.N;
    if (N.rows() > 0) N = (N * b.orientation.rotation.transpose()).eval();
  }
  b.warnings.insert(b.warnings.end(), b.orientation.warnings.begin(), b.orientation.warnings.end());
  return b;
}

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

nlohmann::ordered_json measure_one(const std::string& path) {
  PreparedBody b = prepare_body(path, "auto");
  const bool is_cloud = b.in.is_cloud;
  const Eigen::MatrixXd& P = is_cloud ? b.in.cloud.P : b.in.mesh.V;
  const BodyMeasurements m = is_cloud ? measure_point_cloud(P) : measure_body(b.in.mesh.V, b.in.mesh.F);
  nlohmann::ordered_json r;
  r["kind"] = is_cloud ? "point cloud" : "mesh";
  r["unit"] = unit_name(b.unit);
  r["up"] = axis_name(b.orientation.up());
  r["forward"] = axis_name(b.orientation.forward());
  r["stature"] = m.stature;
  r["stature_measured"] = m.stature_measured;
  for (const Girth& g : m.girths) {
    nlohmann::ordered_json e = {{"measured", g.measured}};
    if (g.measured) e["value"] = g.value;
    else e["note"] = g.note;
    r["girths"][g.name] = e;
  }
  std::vector<std::string> all = b.warnings;
  all.insert(all.end(), m.features.warnings.begin(), m.features.warnings.end());
  r["warnings"] = all;
  return r;
}

/// JSON text of a result or summary; bytes that are not UTF-8 (a Latin-1 file name in an error
/// message) are replaced rather than failing the write.
std::string dump_json(const nlohmann::ordered_json& j) { return j.dump(2, ' ', false, nlohmann::ordered_json::error_handler_t::replace); }

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string number(const nlohmann::json& value, int digits) {
  if (value.is_null()) return "";
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << value.get<double>();
  return s.str();
}

/// summary.json (no timings: shards merge into exactly the unsharded run's file) and summary.csv,
/// one row per input in input order.
void write_summary(const fs::path& out, const std::string& stem, const nlohmann::ordered_json& summary,
                   const std::vector<BatchColumn>& columns) {
  write_file_atomically((out / (stem + ".json")).string(), [&](std::ostream& os) { os << dump_json(summary) << "\n"; }, false);
  write_file_atomically((out / (stem + ".csv")).string(),
                        [&](std::ostream& os) {
                          os << "index,input,status,error";
                          for (const auto& c : columns) os << "," << c.header;
                          os << ",warnings\n";
                          for (const auto& r : summary["results"]) {
                            const bool ok = r["ok"].get<bool>();
                            os << r["index"].get<long>() << "," << csv_field(r["input"].get<std::string>()) << "," << (ok ? "ok" : "failed")
                               << "," << csv_field(r.value("error", ""));
                            for (const auto& c : columns) os << "," << (ok ? csv_field(c.value(r)) : "");
                            os << "," << (ok ? std::to_string(r.value("warnings", nlohmann::ordered_json::array()).size()) : "") << "\n";
                          }
                        },
                        false);
}

std::vector<BatchColumn> measure_columns() {
  std::vector<BatchColumn> c = {
      {"kind", [](const auto& r) { return r["kind"].template get<std::string>(); }},
      {"unit", [](const auto& r) { return r["unit"].template get<std::string>(); }},
      {"up", [](const auto& r) { return r["up"].template get<std::string>(); }},
      {"forward", [](const auto& r) { return r["forward"].template get<std::string>(); }},
      {"stature_m", [](const auto& r) { return number(r["stature"], 6); }},
      {"stature_measured", [](const auto& r) { return std::string(r["stature_measured"].template get<bool>() ? "1" : "0"); }}};
  for (const char* g : kGirthNames)
    c.push_back({std::string(g) + "_m", [g](const auto& r) {
                   const auto& girth = r["girths"][g];
                   return girth["measured"].template get<bool>() ? number(girth["value"], 6) : std::string();
                 }});
  return c;
}

std::pair<long, long> parse_shard(const std::string& text) {
  const auto slash = text.find('/');
  long i = -1, n = 0;
  try {
    if (slash != std::string::npos) i = std::stol(text.substr(0, slash)), n = std::stol(text.substr(slash + 1));
  } catch (const std::exception&) {
    i = -1;
  }
  if (slash == std::string::npos || n < 1 || i < 0 || i >= n)
    throw UsageError("--shard expects I/N with 0 <= I < N (e.g. 3/16: every 16th input from the 4th), got '" + text + "'");
  return {i, n};
}

std::string shard_stem(long i, long n) { return n == 1 ? "summary" : "summary.shard-" + std::to_string(i) + "-of-" + std::to_string(n); }

std::uint32_t list_checksum(const std::vector<std::string>& inputs) {
  std::uint32_t crc = 0;
  for (const auto& s : inputs) crc = crc32(s.data(), s.size() + 1, crc);  // with the terminating NUL
  return crc;
}

/// The options every batch command shares.
void add_batch_options(ArgParser* args) {
  args->output_folder("out", "DIR", "output folder (created; its parent must exist unless --mkdir; shared by all shards)")
      .option("jobs", "N", "inputs processed at once (default: the number of cores)")
      .option("shard", "I/N", "only the inputs I, I+N, I+2N, ... (0 <= I < N)", "0/1")
      .flag("json", "the run's statistics as JSON on stdout");
}

const char* const kBatchCommon =
    " A bad input never stops the batch: it is listed with\n"
    "its message. Resumable: an input whose result exists (made with the same settings, and\n"
    "successful) is not processed again. --shard I/N takes the inputs I, I+N, I+2N ... of the list, so\n"
    "that a scheduler (a Slurm job array, a Kubernetes indexed Job, GNU parallel over hosts) spreads a\n"
    "collection over machines that share OUT; 'posekit batch merge --out OUT' then joins the shards'\n"
    "summaries into the one an unsharded run writes. Throughput and peak memory go to OUT/run*.json\n"
    "and stdout. Exit status 1 when any input failed.";

/// Runs `job` over the shard's inputs on --jobs threads: results/<name>.json per input, the summary,
/// run*.json. Returns the exit status.
int run_batch_job(const ArgParser& args, const BatchJob& job, const std::vector<std::string>& all) {
  const auto [shard, shards] = parse_shard(args.get("shard"));
  const long jobs_option = args.has("jobs") ? args.get_int("jobs") : static_cast<long>(std::max(1u, std::thread::hardware_concurrency()));
  if (jobs_option < 1) throw UsageError("--jobs must be at least 1");
  std::vector<long> mine;
  for (long i = shard; i < static_cast<long>(all.size()); i += shards) mine.push_back(i);
  const fs::path out = args.get("out");
  create_folders((out / "results").string());
  // Temporaries of runs that were killed (this host's dead processes, other hosts' after a day).
  // Every folder of OUT: batch pose writes its meshes two levels down (posed/<input>/).
  int stale = remove_stale_temporaries(out.string());
  for (const auto& e : fs::recursive_directory_iterator(out))
    if (e.is_directory()) stale += remove_stale_temporaries(e.path().string());
  if (stale > 0) std::cerr << "batch " << job.command << ": removed " << stale << " temporary file(s) of killed runs\n";

  std::vector<nlohmann::ordered_json> results(mine.size());
  std::atomic<size_t> next{0};
  std::atomic<long> done{0}, reused{0}, failed{0};
  std::atomic<bool> stop{false};  // a write failed: no input is started after it
  std::string write_error;        // the first failed write (under progress_mutex)
  std::mutex progress_mutex;
  auto stop_on = [&](const WriteError& e) {
    std::lock_guard<std::mutex> lock(progress_mutex);
    if (!stop.exchange(true)) write_error = e.what();
  };
  Progress progress("batch " + job.command, static_cast<long>(mine.size()));
  const Stopwatch t0;
  auto worker = [&] {
    for (size_t k = next++; k < mine.size() && !stop; k = next++) {
      const std::string& input = all[static_cast<size_t>(mine[k])];
      const std::string name = result_name(input);
      const fs::path result_path = out / "results" / (name + ".json");
      nlohmann::ordered_json content;
      try {
        content = input_content(job.files ? job.files(input) : std::vector<std::string>{input});
      } catch (const std::exception&) {
        content = nullptr;  // unreadable or missing: processing says why
      }
      nlohmann::ordered_json r;
      bool have = false;
      if (!content.is_null() && fs::exists(result_path)) {
        try {
          r = nlohmann::ordered_json::parse(read_file_bytes(result_path.string()));
          have = r.value("ok", false) && r.value("input", "") == input && r.value("command", "") == job.command &&
                 r.value("settings", nlohmann::ordered_json()) == job.settings &&
                 same_content(r.value("input_content", nlohmann::ordered_json()), content);
        } catch (const std::exception&) {
          have = false;  // unreadable: made again
        }
      }
      if (have) {
        ++reused;
      } else {
        r = nlohmann::ordered_json{{"input", input}, {"command", job.command}, {"settings", job.settings}, {"input_content", content}};
        try {
          const nlohmann::ordered_json m = job.process(input, name);
          r["ok"] = true;
          for (const auto& [key, value] : m.items()) r[key] = value;
        } catch (const WriteError& e) {
          stop_on(e);
          continue;
        } catch (const std::exception& e) {
          r["ok"] = false;
          r["error"] = e.what();
        }
        try {
          write_file_atomically(
              result_path.string(), [&](std::ostream& os) { os << dump_json(r) << "\n"; }, false);
        } catch (const WriteError& e) {
          stop_on(e);
          continue;
        } catch (const std::exception& e) {
          r["ok"] = false;
          r["error"] = std::string("result not written: ") + e.what();
        }
      }
      if (!r["ok"].get<bool>()) ++failed;
      nlohmann::ordered_json row = {{"index", mine[k]}};
      for (const auto& [key, value] : r.items())
        if (key != "index" && key != "command" && key != "settings" && key != "input_content") row[key] = value;
      results[k] = std::move(row);
      const long d = ++done;
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress.update(d);
    }
  };
  const int jobs = static_cast<int>(std::min<long>(jobs_option, std::max<long>(1, static_cast<long>(mine.size()))));
  std::vector<std::thread> pool;
  for (int t = 0; t < jobs; ++t) pool.emplace_back(worker);
  for (auto& t : pool) t.join();
  if (stop)
    throw WriteError("batch " + job.command + " stopped at the first failed write (" + std::to_string(done.load()) + " of " +
                     std::to_string(mine.size()) + " inputs done; rerun to resume): " + write_error);
  progress.finish();
  const double seconds = t0.seconds();

  nlohmann::ordered_json summary;
  summary["command"] = job.command;
  summary["settings"] = job.settings;
  summary["inputs_total"] = all.size();
  summary["inputs_checksum"] = list_checksum(all);
  summary["shard"] = shard;
  summary["shards"] = shards;
  summary["inputs"] = mine.size();
  summary["ok"] = static_cast<long>(mine.size()) - failed.load();
  summary["failed"] = failed.load();
  summary["results"] = results;
  write_summary(out, shard_stem(shard, shards), summary, job.columns);
  const long processed = static_cast<long>(mine.size()) - reused.load();
  nlohmann::ordered_json run = {{"command", job.command},
                                {"inputs", mine.size()},
                                {"processed", processed},
                                {"reused", reused.load()},
                                {"failed", failed.load()},
                                {"jobs", jobs},
                                {"seconds", seconds},
                                {"inputs_per_second", processed > 0 ? processed / seconds : 0.0},
                                {"peak_rss_mib", peak_rss_mib()}};
  const std::string run_stem = shards == 1 ? "run" : "run.shard-" + std::to_string(shard) + "-of-" + std::to_string(shards);
  write_file_atomically((out / (run_stem + ".json")).string(), [&](std::ostream& os) { os << run.dump(2) << "\n"; }, false);
  if (args.flag_set("json")) {
    print_json(run);
  } else {
    std::cout << "batch " << job.command << ": " << mine.size() << " inputs" << (shards > 1 ? " (shard " + args.get("shard") + ")" : "")
              << ", " << processed << " processed, " << reused.load() << " done earlier, " << failed.load() << " failed, in " << std::fixed
              << std::setprecision(1) << seconds << " s on " << jobs << " jobs (" << std::setprecision(2)
              << (processed > 0 ? processed / seconds : 0.0) << " inputs/s), peak RSS " << std::setprecision(0) << peak_rss_mib()
              << " MiB; wrote " << (out / (shard_stem(shard, shards) + ".csv")).string() << "\n";
    for (const auto& r : results)
      if (!r["ok"].get<bool>()) std::cout << "  failed: " << r["input"].get<std::string>() << ": " << r["error"].get<std::string>() << "\n";
  }
  return failed.load() > 0 ? 1 : 0;
}

int run_batch_measure(int argc, char** argv) {
  ArgParser args("batch measure",
                 std::string("Measures many bodies (meshes or scans; unit from each file's extent, orientation detected) on\n"
                             "--jobs cores: one result file per input in OUT/results, then OUT/summary.json and summary.csv\n"
                             "(girths in metres, one row per input in input order).") +
                     kBatchCommon);
  args.option("inputs", "DIR|LIST", "a folder (its body files, recursively, in sorted order) or a text file of paths, one per line");
  add_batch_options(&args);
  args.example("posekit batch measure --inputs scans/ --out measured --jobs 2")
      .example("posekit batch measure --inputs list.txt --out measured --shard $SLURM_ARRAY_TASK_ID/16");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("inputs") || !args.has("out")) throw UsageError("--inputs and --out are required");
  BatchJob job{"measure", nlohmann::ordered_json::object(), [](const std::string& input, const std::string&) { return measure_one(input); },
               measure_columns(), nullptr};
  return run_batch_job(args, job, list_inputs(args.get("inputs")));
}

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

std::vector<BatchColumn> pose_columns() {
  return {{"unit", [](const auto& r) { return r["unit"].template get<std::string>(); }},
          {"up", [](const auto& r) { return r["up"].template get<std::string>(); }},
          {"forward", [](const auto& r) { return r["forward"].template get<std::string>(); }},
          {"vertices", [](const auto& r) { return std::to_string(r["vertices"].template get<long>()); }},
          {"poses", [](const auto& r) { return std::to_string(r["poses"].template get<long>()); }},
          {"first_file", [](const auto& r) { return r["files"].empty() ? std::string() : r["files"][0].template get<std::string>(); }}};
}

std::vector<BatchColumn> register_columns() {
  auto quality = [](const char* key, int digits) {
    return [key, digits](const nlohmann::ordered_json& r) { return number(r["quality"][key], digits); };
  };
  return {{"unit", [](const auto& r) { return r["unit"].template get<std::string>(); }},
          {"target_triangles", [](const auto& r) { return std::to_string(r["target_triangles"].template get<long>()); }},
          {"seconds", [](const auto& r) { return number(r["seconds"], 4); }},
          {"mean_distance_mm", quality("mean_distance_mm", 2)},
          {"p95_distance_mm", quality("p95_distance_mm", 2)},
          {"target_covered", quality("target_covered", 4)},
          {"normals_agree", quality("normals_agree", 4)},
          {"folded_triangles", [](const auto& r) { return std::to_string(r["quality"]["folded_triangles"].template get<long>()); }},
          {"shape_space_kept", [](const auto& r) {
             return r.contains("shape_space_kept") ? std::string(r["shape_space_kept"].template get<bool>() ? "1" : "0") : std::string();
           }}};
}

/// The summary columns of a command run with these settings (for merge).
std::vector<BatchColumn> columns_of(const std::string& command, const nlohmann::ordered_json& settings) {
  if (command == "measure") return measure_columns();
  if (command == "register") return register_columns();
  if (command == "compare") return compare_columns(settings.value("measure", false));
  if (command == "pose") return pose_columns();
  throw InvalidInput("a batch summary of an unknown command '" + command + "'");
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

int run_batch_pose(int argc, char** argv) {
  ArgParser args(
      "batch pose",
      std::string(
          "Poses many bodies with one trained model (posekit pose): each subject mesh is segmented and\n"
          "set up once, then put into every pose of --pose (a pose JSON, or the frames of a BVH: MakeHuman's\n"
          "skeleton, or any humanoid one retargeted to each subject's joints). The posed meshes go to OUT/posed/<input>/<pose>.<format> "
          "(listed relative to OUT), in\n"
          "the subject file's frame and unit, with the vertex scalar 'part'. One result per subject in OUT/results, OUT/summary.json\n"
          "and summary.csv; set-up and posing times in OUT/run*.json.") +
          kBatchCommon);
  args.option("inputs", "DIR|LIST", "a folder of subject meshes (recursively, in sorted order) or a text file of paths")
      .pose_model_option()
      .option("pose", "FILE", "pose.json (16-part pose) or a motion capture .bvh (any humanoid skeleton, retargeted; see --joint-map)")
      .option("method", "M", "learned (the paper's), rigid (parts only) or lbs (16-part skinning)", "learned")
      .option("frames", "A:B", "BVH frames A to B-1 (default: all)")
      .option("format", "EXT", "posed mesh format: ply, obj or off", "ply")
      .data_option("for the BVH skeleton")
      .option("joint-map", "FILE", "JSON {\"left_shoulder\": \"<BVH joint>\", ...} for BVH joints the names do not tell")
      .option("root-motion", "M", "a retargeted BVH's root translation: none, vertical (feet stay down) or all", "vertical");
  add_batch_options(&args);
  args.example("posekit batch pose --inputs subjects.txt --model model.pkm --pose squat.json --out posed --jobs 2");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"inputs", "model", "pose", "out"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  const std::string format = args.get("format");
  if (format != "ply" && format != "obj" && format != "off") throw UsageError("--format expects ply, obj or off, got '" + format + "'");
  const PoseMethod method = parse_pose_method(args.get("method"));
  const auto model = std::make_shared<const PoseModel>(read_pose_model(args.get("model")));
  const std::uint32_t model_crc = file_crc32(args.get("model"));  // a retrained model redoes every subject
  const std::string pose_path = args.get("pose");
  const std::string frames = args.has("frames") ? args.get("frames") : "", data = args.has("data") ? args.get("data") : "";
  const std::string joint_map = args.has("joint-map") ? args.get("joint-map") : "", root_motion = args.get("root-motion");
  // Pose JSONs and MakeHuman's BVHs are the same for every subject: loaded once. Other BVHs are
  // retargeted to each subject's own joints.
  std::string ext = fs::path(pose_path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  BvhMotion motion;
  if (ext == ".bvh") motion = read_bvh(pose_path, Unit::kMetre, io_warnings());
  const bool per_subject = ext == ".bvh" && motion.find_joint("upperarm01.L") < 0;
  LoadedPoses shared;
  if (!per_subject) shared = load_poses(pose_path, frames, data, Eigen::MatrixXd(), "", root_motion, ext == ".bvh" ? &motion : nullptr);
  else
    (void)load_poses(pose_path, frames, data, Eigen::MatrixXd::Zero(kNumJoints, 3), joint_map, root_motion,
                     &motion);  // bad input fails once, not per subject
  const fs::path posed_dir = fs::path(args.get("out")) / "posed";
  std::mutex timing_mutex;
  std::vector<double> setup_seconds, pose_ms;
  BatchJob job;
  job.command = "pose";
  job.settings = {
      {"model", args.get("model")}, {"model_checksum", model_crc},        {"pose", pose_path}, {"frames", frames}, {"joint_map", joint_map},
      {"root_motion", root_motion}, {"method", pose_method_name(method)}, {"format", format}};
  job.process = [&](const std::string& input, const std::string& stem) {
    PreparedBody subject = prepare_body(input, "auto");
    if (subject.in.is_cloud) throw InvalidInput(input + ": the subject must be a mesh (triangles); this file has only points");
    const TriangleMesh& mesh = subject.in.mesh;
    const MeshReport report = validate_mesh(mesh);
    if (report.components != 1)
      throw InvalidInput(input + ": the subject mesh has " + std::to_string(report.components) +
                         " connected components; posing needs one connected body");
    std::vector<std::string> warnings = subject.warnings;
    if (report.boundary_loops > 0) warnings.push_back(std::to_string(report.boundary_loops) + " holes: features near them may be off");
    const Stopwatch t0;
    const PoseSynthesizer synth = set_up_subject(model, mesh, input);
    const double setup = t0.seconds();
    for (const auto& problem : synth.info().skeleton_problems) warnings.push_back("the skeleton looks wrong: " + problem);
    const fs::path dir = posed_dir / stem;
    create_folders(dir.string());
    TriangleMesh posed;
    posed.F = mesh.F;
    posed.vertex_scalars["part"] = vertex_labels_from_triangles(mesh.V, mesh.F, synth.info().triangle_part).cast<double>();
    nlohmann::ordered_json files = nlohmann::ordered_json::array();
    const Stopwatch t1;
    const LoadedPoses own =
        per_subject ? load_poses(pose_path, frames, data, synth.info().joint_centres, joint_map, root_motion, &motion) : LoadedPoses{};
    const LoadedPoses& poses = per_subject ? own : shared;
    for (size_t k = 0; k < poses.poses.size(); ++k) {
      const std::string& name = poses.names[k];
      const PartPose& pose = poses.poses[k];
      synth.pose(pose, method, &posed.V);
      if (!subject.orientation.is_identity()) posed.V = in_file_frame(subject.orientation, posed.V);
      const std::string path = (dir / (name + "." + format)).string();
      std::vector<std::string> io;
      write_mesh(path, posed, {subject.unit, MeshFormat::kAuto, true, &io});
      warnings.insert(warnings.end(), io.begin(), io.end());
      files.push_back((fs::path("posed") / stem / (name + "." + format)).string());  // relative to OUT: the summary moves with it
    }
    const double posing = t1.seconds();
    {
      std::lock_guard<std::mutex> lock(timing_mutex);
      setup_seconds.push_back(setup);
      pose_ms.push_back(1000 * posing / static_cast<double>(poses.poses.size()));
    }
    nlohmann::ordered_json r = {{"unit", unit_name(subject.unit)},
                                {"up", axis_name(subject.orientation.up())},
                                {"forward", axis_name(subject.orientation.forward())},
                                {"vertices", mesh.V.rows()},
                                {"poses", poses.poses.size()},
                                {"normal_failures", synth.info().normal_failures},
                                {"files", files},
                                {"warnings", warnings}};
    return r;
  };
  job.columns = pose_columns();
  const int status = run_batch_job(args, job, list_inputs(args.get("inputs")));
  if (!setup_seconds.empty() && !args.flag_set("json")) {
    const Stats s = stats_of(setup_seconds), p = stats_of(pose_ms);
    std::cout << "  per subject: set-up median " << std::setprecision(3) << s.median << " s (" << s.min << " to " << s.max
              << "), posing median " << std::setprecision(2) << p.median << " ms per pose\n";
  }
  return status;
}

int run_batch_register(int argc, char** argv) {
  ArgParser args("batch register",
                 std::string("Registers one source body (e.g. the dataset's template) to many targets (posekit register):\n"
                             "the source's side of ct-FFD and the shape space are made once and shared by the jobs. Per\n"
                             "target: OUT/correspondence/<input>.json (each target triangle's source triangle, Eq. 2b/2c),\n"
                             "with --deformed the source on the target (OUT/deformed/<input>.ply, in the target file's frame\n"
                             "and unit), and the quality judged without ground truth in the summary. Units and\n"
                             "orientations are detected.") +
                     kBatchCommon);
  args.option("source", "FILE", "the source mesh registered to every target")
      .option("inputs", "DIR|LIST", "a folder of target meshes (recursively, in sorted order) or a text file of paths")
      .option("method", "M", "ctffd, icp or nicp", "ctffd")
      .option("shape-space", "N|FILE", "ctffd: refine by a shape space of N MakeHuman bodies or a .pks file (0: not)", "0")
      .data_option("for --shape-space N")
      .flag("refine", "ctffd: refine by soft non-rigid ICP steps")
      .flag("deformed", "also write the source deformed onto each target");
  add_batch_options(&args);
  args.example("posekit batch register --source dataset/template/rest.ply --inputs scans/ --shape-space makehuman300.pks --out registered");
  if (!args.parse(argc, argv)) return 0;
  for (const char* required : {"source", "inputs", "out"})
    if (!args.has(required)) throw UsageError(std::string("--") + required + " is required");
  RegistrationOptions o;
  o.method = parse_registration_method(args.get("method"));
  o.refine = args.flag_set("refine");
  const std::string shape_arg = args.get("shape-space");
  if ((o.refine || shape_arg != "0") && o.method != RegistrationMethod::kCtffd)
    throw UsageError("--refine and --shape-space apply to --method ctffd");
  PreparedBody source = prepare_body(args.get("source"), "auto");
  if (source.in.is_cloud) throw InvalidInput(args.get("source") + ": the source must be a mesh (triangles); this file has only points");
  for (const std::string& w : source.warnings) std::cerr << "posekit batch register: " << args.get("source") << ": " << w << "\n";
  const TriangleMesh& source_mesh = source.in.mesh;
  o.shape_space = shape_space_option(shape_arg, "none", args.has("data") ? args.get("data") : "");
  if (o.shape_space && (o.shape_space->vertices() != source_mesh.num_vertices() ||
                        (o.shape_space->faces.size() > 0 && o.shape_space->faces != source_mesh.F)))
    throw InvalidInput(args.get("source") + ": the shape space is of another topology (" + std::to_string(o.shape_space->vertices()) +
                       " vertices; the source has " + std::to_string(source_mesh.num_vertices()) + ")");
  std::unique_ptr<const CtffdSource> prepared;
  if (o.method == RegistrationMethod::kCtffd) prepared = std::make_unique<const CtffdSource>(source_mesh, o.points_per_layer);
  const std::uint32_t space_crc = is_shape_space_file(shape_arg) ? file_crc32(shape_arg) : 0;
  const fs::path out = args.get("out"), corr_dir = out / "correspondence", deformed_dir = out / "deformed";
  const bool deformed = args.flag_set("deformed");
  create_folders(corr_dir.string());
  if (deformed) create_folders(deformed_dir.string());
  BatchJob job;
  job.command = "register";
  // A changed source or space file redoes every target.
  job.settings = {{"source", args.get("source")},
                  {"source_checksum", file_crc32(args.get("source"))},
                  {"method", args.get("method")},
                  {"shape_space", shape_arg},
                  {"shape_space_checksum", space_crc},
                  {"refine", o.refine},
                  {"deformed", deformed}};
  job.process = [&](const std::string& input, const std::string& stem) {
    PreparedBody target = prepare_body(input, "auto");
    if (target.in.is_cloud) throw InvalidInput(input + ": register needs a mesh (triangles); this file has only points");
    const TriangleMesh& mesh = target.in.mesh;
    const RegistrationResult r = prepared ? register_bodies(*prepared, mesh, o) : register_bodies(source_mesh, mesh, o);
    const RegistrationQuality q = assess_registration(source_mesh, r.deformed_source, mesh);
    nlohmann::json corr = {
        {"source", args.get("source")},
        {"target", input},
        {"method", args.get("method")},
        {"meaning", "target_to_source[k] is the source triangle matched to target triangle k"},
        {"target_to_source", std::vector<int>(r.correspondence.data(), r.correspondence.data() + r.correspondence.size())}};
    const std::string text = corr.dump() + "\n";
    write_file_atomically((corr_dir / (stem + ".json")).string(), [&](std::ostream& os) { os << text; }, false);
    std::vector<std::string> warnings = target.warnings;
    for (const std::string& w : r.warnings) warnings.push_back(w);
    for (const std::string& w : q.warnings) warnings.push_back(w);
    nlohmann::ordered_json result = {{"unit", unit_name(target.unit)},
                                     {"up", axis_name(target.orientation.up())},
                                     {"forward", axis_name(target.orientation.forward())},
                                     {"target_triangles", mesh.num_faces()},
                                     {"seconds", r.seconds},
                                     {"normal_failures", r.normal_failures},
                                     {"quality", registration_quality_json(q, false)},
                                     {"correspondence", (fs::path("correspondence") / (stem + ".json")).string()}};
    if (o.shape_space) {
      result["shape_space_kept"] = r.shape_fit.plausible;
      result["shape_space_median_distance_mm"] = 1000 * r.shape_fit.median_distance;
    }
    if (deformed) {
      TriangleMesh d;
      d.V = in_file_frame(target.orientation, r.deformed_source);
      d.F = source_mesh.F;
      std::vector<std::string> io;
      write_mesh((deformed_dir / (stem + ".ply")).string(), d, {target.unit, MeshFormat::kPly, true, &io});
      warnings.insert(warnings.end(), io.begin(), io.end());
      result["deformed"] = (fs::path("deformed") / (stem + ".ply")).string();
    }
    result["warnings"] = warnings;
    return result;
  };
  job.columns = register_columns();
  return run_batch_job(args, job, list_inputs(args.get("inputs")));
}

int run_batch_merge(int argc, char** argv) {
  ArgParser args("batch merge",
                 "Joins the summaries of a sharded batch run (OUT/summary.shard-I-of-N.json, every I from 0 to N-1)\n"
                 "into OUT/summary.json and summary.csv, the files one unsharded run over the same inputs writes.");
  args.option("out", "DIR", "the batch's output folder").example("posekit batch merge --out measured");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("out")) throw UsageError("--out is required");
  const fs::path out = args.get("out");
  if (!fs::is_directory(out)) throw InvalidInput(out.string() + ": no such folder (the --out of the sharded batch runs)");
  std::vector<fs::path> parts;
  for (const auto& e : fs::directory_iterator(out)) {
    const std::string name = e.path().filename().string();
    if (name.rfind("summary.shard-", 0) == 0 && e.path().extension() == ".json") parts.push_back(e.path());
  }
  if (parts.empty()) throw InvalidInput(out.string() + ": no shard summaries (summary.shard-I-of-N.json) to merge");
  long shards = -1;
  nlohmann::ordered_json first;
  std::vector<bool> seen;
  std::vector<nlohmann::ordered_json> rows;
  for (const auto& p : parts) {
    const auto s = nlohmann::ordered_json::parse(read_file_bytes(p.string()));
    if (shards < 0) {
      shards = s["shards"].get<long>();
      first = s;
      seen.assign(static_cast<size_t>(shards), false);
    }
    if (s["shards"].get<long>() != shards || s["inputs_checksum"] != first["inputs_checksum"] || s["command"] != first["command"] ||
        s.value("settings", nlohmann::ordered_json()) != first.value("settings", nlohmann::ordered_json()))
      throw InvalidInput(p.string() + ": a shard of another run (other inputs, shard count or command) than " + parts.front().string());
    seen[static_cast<size_t>(s["shard"].get<long>())] = true;
    for (const auto& r : s["results"]) rows.push_back(r);
  }
  std::string missing;
  for (long i = 0; i < shards; ++i)
    if (!seen[static_cast<size_t>(i)]) missing += (missing.empty() ? "" : ", ") + std::to_string(i);
  if (!missing.empty()) throw InvalidInput(out.string() + ": shards " + missing + " of " + std::to_string(shards) + " have no summary yet");
  std::sort(rows.begin(), rows.end(),
            [](const auto& a, const auto& b) { return a["index"].template get<long>() < b["index"].template get<long>(); });
  long failed = 0;
  for (const auto& r : rows) failed += !r["ok"].get<bool>();
  nlohmann::ordered_json summary;
  summary["command"] = first["command"];
  summary["settings"] = first.value("settings", nlohmann::ordered_json::object());
  summary["inputs_total"] = first["inputs_total"];
  summary["inputs_checksum"] = first["inputs_checksum"];
  summary["shard"] = 0;
  summary["shards"] = 1;
  summary["inputs"] = rows.size();
  summary["ok"] = static_cast<long>(rows.size()) - failed;
  summary["failed"] = failed;
  summary["results"] = rows;
  write_summary(out, "summary", summary, columns_of(summary["command"].get<std::string>(), summary["settings"]));
  std::cout << "batch merge: " << shards << " shards, " << rows.size() << " inputs (" << failed << " failed) -> "
            << (out / "summary.csv").string() << "\n";
  return 0;
}

}  // namespace

int run_batch(int argc, char** argv) {
  const std::string sub = argc >= 1 ? argv[0] : "";
  if (sub == "measure") return run_batch_measure(argc - 1, argv + 1);
  if (sub == "compare") return run_batch_compare(argc - 1, argv + 1);
  if (sub == "pose") return run_batch_pose(argc - 1, argv + 1);
  if (sub == "register") return run_batch_register(argc - 1, argv + 1);
  if (sub == "merge") return run_batch_merge(argc - 1, argv + 1);
  std::cout << "usage: posekit batch measure --inputs DIR|LIST --out DIR [--jobs N] [--shard I/N]\n"
               "       posekit batch compare --inputs PAIRS | --model FILE --inputs DIR|LIST --out DIR [--measure] [--heatmaps] ...\n"
               "       posekit batch pose --inputs DIR|LIST --model FILE --pose FILE --out DIR [--method M] [--frames A:B] ...\n"
               "       posekit batch register --source FILE --inputs DIR|LIST --out DIR [--shape-space N|FILE] [--deformed] ...\n"
               "       posekit batch merge --out DIR\n\n"
               "  measure  measure many bodies, one result per input, a CSV + JSON summary (resumable, shardable)\n"
               "  compare  compare many models with their scans (distances, coverage, girth discrepancies)\n"
               "  pose     pose many subjects with one trained model into a pose or a BVH's frames\n"
               "  register register one source (the template) to many targets, its side made once\n"
               "  merge    join the summaries of a sharded run\n";
  return sub == "--help" || sub == "-h" ? 0 : 2;
}

}  // namespace posekit::cli
