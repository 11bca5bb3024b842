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

#include "batch.h"
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
namespace batch {
namespace fs = std::filesystem;

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

PreparedBody prepare_body(const std::string& path, const std::string& unit_option) {
  PreparedBody b;
  b.in = read_body_input(path, Unit::kMetre, &b.warnings);
  // The library's one rule (bring_to_posekit_frame), as measure, the Python module and its Dask recipe read bodies.
  Eigen::MatrixXd& P = b.in.is_cloud ? b.in.cloud.P : b.in.mesh.V;
  Eigen::MatrixXd& N = b.in.is_cloud ? b.in.cloud.N : b.in.mesh.N;
  const BodyFrame frame = bring_to_posekit_frame(&P, b.in.is_cloud ? nullptr : &b.in.mesh.F, &N, unit_option, "auto", "auto");
  b.unit = parse_unit(frame.unit);
  b.orientation = frame.orientation;
  b.warnings.insert(b.warnings.end(), b.orientation.warnings.begin(), b.orientation.warnings.end());
  return b;
}

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
  for (const std::string& g : girth_names())
    c.push_back({g + "_m", [g](const auto& r) {
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

const char* const kBatchCommon =
    " A bad input never stops the batch: it is listed with\n"
    "its message. Resumable: an input whose result exists (made with the same settings, and\n"
    "successful) is not processed again. --shard I/N takes the inputs I, I+N, I+2N ... of the list, so\n"
    "that a scheduler (a Slurm job array, a Kubernetes indexed Job, GNU parallel over hosts) spreads a\n"
    "collection over machines that share OUT; 'posekit batch merge --out OUT' then joins the shards'\n"
    "summaries into the one an unsharded run writes. Throughput and peak memory go to OUT/run*.json\n"
    "and stdout. Exit status 1 when any input failed.";

/// The options every batch command shares.
void add_batch_options(ArgParser* args) {
  args->output_folder("out", "DIR", "output folder (created; its parent must exist unless --mkdir; shared by all shards)")
      .option("jobs", "N", "inputs processed at once (default: the number of cores)")
      .option("shard", "I/N", "only the inputs I, I+N, I+2N, ... (0 <= I < N)", "0/1")
      .flag("json", "the run's statistics as JSON on stdout");
}

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

}  // namespace batch

int run_batch(int argc, char** argv) {
  using namespace batch;
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
