// posekit batch: one command over many bodies, on several cores and, by shards, several machines.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "cli.h"
#include "commands.h"
#include "posekit/core/error.h"
#include "posekit/core/units.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/checksum.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
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

/// Result file name of an input: its path with separators as "__", so inputs of the same name in
/// different folders do not collide.
std::string result_name(const std::string& input) {
  std::string name = fs::path(input).lexically_normal().relative_path().string();
  for (char& c : name)
    if (c == '/' || c == '\\' || c == ':') c = '_';
  return name + ".json";
}

/// Measures one file quietly (the unit from its extent, the orientation detected): the result
/// object of the summary. Throws on failure.
nlohmann::ordered_json measure_one(const std::string& path) {
  std::vector<std::string> warnings;
  BodyInput in = read_body_input(path, Unit::kMetre, &warnings);
  const bool is_cloud = in.is_cloud;
  TriangleMesh& mesh = in.mesh;
  PointCloud& cloud = in.cloud;
  Eigen::MatrixXd& P = is_cloud ? cloud.P : mesh.V;
  const double extent = robust_largest_extent(P);
  Unit unit = Unit::kMetre;
  if (!guess_body_unit(extent, &unit))
    throw InvalidInput(path + ": its largest extent is " + std::to_string(extent) + " units, which no unit (m, dm, cm, mm) makes a body");
  P *= metres_per_unit(unit);
  const BodyOrientation o = is_cloud ? detect_body_orientation(P) : detect_mesh_orientation(mesh.V, mesh.F);
  if (!o.is_identity()) P = (P * o.rotation.transpose()).eval();
  const BodyMeasurements m = is_cloud ? measure_point_cloud(P) : measure_body(mesh.V, mesh.F);
  nlohmann::ordered_json r;
  r["kind"] = is_cloud ? "point cloud" : "mesh";
  r["unit"] = unit_name(unit);
  r["up"] = axis_name(o.up());
  r["forward"] = axis_name(o.forward());
  r["stature"] = m.stature;
  r["stature_measured"] = m.stature_measured;
  for (const Girth& g : m.girths) {
    nlohmann::ordered_json e = {{"measured", g.measured}};
    if (g.measured) e["value"] = g.value;
    else e["note"] = g.note;
    r["girths"][g.name] = e;
  }
  std::vector<std::string> all = warnings;
  all.insert(all.end(), o.warnings.begin(), o.warnings.end());
  all.insert(all.end(), m.features.warnings.begin(), m.features.warnings.end());
  r["warnings"] = all;
  return r;
}

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) quoted += c == '"' ? std::string("\"\"") : std::string(1, c);
  return quoted + "\"";
}

std::string metres(const nlohmann::json& value) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(6) << value.get<double>();
  return s.str();
}

/// summary.json (no timings: shards merge into exactly the unsharded run's file) and summary.csv,
/// one row per input in input order.
void write_summary(const fs::path& out, const std::string& stem, const nlohmann::ordered_json& summary) {
  write_file_atomically((out / (stem + ".json")).string(), [&](std::ostream& os) { os << summary.dump(2) << "\n"; }, false);
  write_file_atomically((out / (stem + ".csv")).string(), [&](std::ostream& os) {
    os << "index,input,status,error,kind,unit,up,forward,stature_m,stature_measured";
    for (const char* g : kGirthNames) os << "," << g << "_m";
    os << ",warnings\n";
    for (const auto& r : summary["results"]) {
      os << r["index"].get<long>() << "," << csv_field(r["input"].get<std::string>()) << "," << (r["ok"].get<bool>() ? "ok" : "failed")
         << "," << csv_field(r.value("error", ""));
      if (r["ok"].get<bool>()) {
        os << "," << r["kind"].get<std::string>() << "," << r["unit"].get<std::string>() << "," << r["up"].get<std::string>() << ","
           << r["forward"].get<std::string>() << "," << metres(r["stature"]) << "," << (r["stature_measured"].get<bool>() ? 1 : 0);
        for (const char* g : kGirthNames) {
          const auto& girth = r["girths"][g];
          os << "," << (girth["measured"].get<bool>() ? metres(girth["value"]) : "");
        }
        os << "," << r["warnings"].size();
      } else {
        os << ",,,,,,";
        for (size_t g = 0; g < std::size(kGirthNames); ++g) os << ",";
        os << ",";
      }
      os << "\n";
    }
  }, false);
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

int run_batch_measure(int argc, char** argv) {
  ArgParser args("batch measure",
                 "Measures many bodies (meshes or scans; unit from each file's extent, orientation detected) on\n"
                 "--jobs cores: one result file per input in OUT/results, then OUT/summary.json and summary.csv\n"
                 "(girths in metres, one row per input in input order, failures with their messages). A bad file\n"
                 "never stops the batch. Resumable: an input whose result exists (and succeeded) is not measured\n"
                 "again. --shard I/N takes the inputs I, I+N, I+2N ... of the list, so that a scheduler (a Slurm job\n"
                 "array, a Kubernetes indexed Job, GNU parallel over hosts) spreads a collection over machines that\n"
                 "share OUT; 'posekit batch merge --out OUT' then joins the shards' summaries into the one an\n"
                 "unsharded run writes. Throughput and peak memory go to OUT/run*.json and stdout. Exit status 1\n"
                 "when any input failed.");
  args.option("inputs", "DIR|LIST", "a folder (its body files, recursively, in sorted order) or a text file of paths, one per line")
      .option("out", "DIR", "output folder (created; shared by all shards)")
      .option("jobs", "N", "bodies measured at once (default: the number of cores)")
      .option("shard", "I/N", "only the inputs I, I+N, I+2N, ... (0 <= I < N)", "0/1")
      .flag("json", "the run's statistics as JSON on stdout")
      .example("posekit batch measure --inputs scans/ --out measured --jobs 2")
      .example("posekit batch measure --inputs list.txt --out measured --shard $SLURM_ARRAY_TASK_ID/16");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("inputs") || !args.has("out")) throw UsageError("--inputs and --out are required");
  const auto [shard, shards] = parse_shard(args.get("shard"));
  const long jobs_option = args.has("jobs") ? args.get_int("jobs") : static_cast<long>(std::max(1u, std::thread::hardware_concurrency()));
  if (jobs_option < 1) throw UsageError("--jobs must be at least 1");
  const std::vector<std::string> all = list_inputs(args.get("inputs"));
  std::vector<long> mine;
  for (long i = shard; i < static_cast<long>(all.size()); i += shards) mine.push_back(i);
  const fs::path out = args.get("out");
  fs::create_directories(out / "results");

  std::vector<nlohmann::ordered_json> results(mine.size());
  std::atomic<size_t> next{0};
  std::atomic<long> done{0}, reused{0}, failed{0};
  std::mutex progress_mutex;
  Progress progress("batch measure", static_cast<long>(mine.size()));
  const auto t0 = std::chrono::steady_clock::now();
  auto worker = [&] {
    for (size_t k = next++; k < mine.size(); k = next++) {
      const std::string& input = all[static_cast<size_t>(mine[k])];
      const fs::path result_path = out / "results" / result_name(input);
      nlohmann::ordered_json r;
      bool have = false;
      if (fs::exists(result_path)) {
        try {
          r = nlohmann::ordered_json::parse(read_file_bytes(result_path.string()));
          have = r.value("ok", false) && r.value("input", "") == input;
        } catch (const std::exception&) {
          have = false;  // unreadable: measured again
        }
      }
      if (have) {
        ++reused;
      } else {
        r = nlohmann::ordered_json{{"input", input}};
        try {
          const nlohmann::ordered_json m = measure_one(input);
          r["ok"] = true;
          for (const auto& [key, value] : m.items()) r[key] = value;
        } catch (const std::exception& e) {
          r["ok"] = false;
          r["error"] = e.what();
        }
        try {
          write_file_atomically(result_path.string(), [&](std::ostream& os) { os << r.dump(2) << "\n"; }, false);
        } catch (const std::exception& e) {
          r["ok"] = false;
          r["error"] = std::string("result not written: ") + e.what();
        }
      }
      if (!r["ok"].get<bool>()) ++failed;
      r.erase("index");
      nlohmann::ordered_json row = {{"index", mine[k]}};
      for (const auto& [key, value] : r.items()) row[key] = value;
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
  progress.finish();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  nlohmann::ordered_json summary;
  summary["command"] = "measure";
  summary["inputs_total"] = all.size();
  summary["inputs_checksum"] = list_checksum(all);
  summary["shard"] = shard;
  summary["shards"] = shards;
  summary["inputs"] = mine.size();
  summary["ok"] = static_cast<long>(mine.size()) - failed.load();
  summary["failed"] = failed.load();
  summary["results"] = results;
  write_summary(out, shard_stem(shard, shards), summary);
  const long processed = static_cast<long>(mine.size()) - reused.load();
  nlohmann::ordered_json run = {{"inputs", mine.size()},   {"processed", processed},
                                {"reused", reused.load()}, {"failed", failed.load()},
                                {"jobs", jobs},            {"seconds", seconds},
                                {"bodies_per_second", processed > 0 ? processed / seconds : 0.0},
                                {"peak_rss_mib", peak_rss_mib()}};
  const std::string run_stem = shards == 1 ? "run" : "run.shard-" + std::to_string(shard) + "-of-" + std::to_string(shards);
  write_file_atomically((out / (run_stem + ".json")).string(), [&](std::ostream& os) { os << run.dump(2) << "\n"; }, false);
  if (args.flag_set("json")) {
    print_json(run);
  } else {
    std::cout << "batch measure: " << mine.size() << " inputs" << (shards > 1 ? " (shard " + args.get("shard") + ")" : "") << ", "
              << processed << " processed, " << reused.load() << " done earlier, " << failed.load() << " failed, in " << std::fixed
              << std::setprecision(1) << seconds << " s on " << jobs << " jobs (" << std::setprecision(2)
              << (processed > 0 ? processed / seconds : 0.0) << " bodies/s), peak RSS " << std::setprecision(0) << peak_rss_mib()
              << " MiB; wrote " << (out / (shard_stem(shard, shards) + ".csv")).string() << "\n";
    for (const auto& r : results)
      if (!r["ok"].get<bool>()) std::cout << "  failed: " << r["input"].get<std::string>() << ": " << r["error"].get<std::string>() << "\n";
  }
  return failed.load() > 0 ? 1 : 0;
}

int run_batch_merge(int argc, char** argv) {
  ArgParser args("batch merge",
                 "Joins the summaries of a sharded batch run (OUT/summary.shard-I-of-N.json, every I from 0 to N-1)\n"
                 "into OUT/summary.json and summary.csv, the files one unsharded run over the same inputs writes.");
  args.option("out", "DIR", "the batch's output folder").example("posekit batch merge --out measured");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("out")) throw UsageError("--out is required");
  const fs::path out = args.get("out");
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
    if (s["shards"].get<long>() != shards || s["inputs_checksum"] != first["inputs_checksum"] || s["command"] != first["command"])
      throw InvalidInput(p.string() + ": a shard of another run (other inputs, shard count or command) than " + parts.front().string());
    seen[static_cast<size_t>(s["shard"].get<long>())] = true;
    for (const auto& r : s["results"]) rows.push_back(r);
  }
  std::string missing;
  for (long i = 0; i < shards; ++i)
    if (!seen[static_cast<size_t>(i)]) missing += (missing.empty() ? "" : ", ") + std::to_string(i);
  if (!missing.empty()) throw InvalidInput(out.string() + ": shards " + missing + " of " + std::to_string(shards) + " have no summary yet");
  std::sort(rows.begin(), rows.end(), [](const auto& a, const auto& b) { return a["index"].template get<long>() < b["index"].template get<long>(); });
  long failed = 0;
  for (const auto& r : rows) failed += !r["ok"].get<bool>();
  nlohmann::ordered_json summary;
  summary["command"] = first["command"];
  summary["inputs_total"] = first["inputs_total"];
  summary["inputs_checksum"] = first["inputs_checksum"];
  summary["shard"] = 0;
  summary["shards"] = 1;
  summary["inputs"] = rows.size();
  summary["ok"] = static_cast<long>(rows.size()) - failed;
  summary["failed"] = failed;
  summary["results"] = rows;
  write_summary(out, "summary", summary);
  std::cout << "batch merge: " << shards << " shards, " << rows.size() << " inputs (" << failed << " failed) -> "
            << (out / "summary.csv").string() << "\n";
  return 0;
}

}  // namespace

int run_batch(int argc, char** argv) {
  const std::string sub = argc >= 1 ? argv[0] : "";
  if (sub == "measure") return run_batch_measure(argc - 1, argv + 1);
  if (sub == "merge") return run_batch_merge(argc - 1, argv + 1);
  std::cout << "usage: posekit batch measure --inputs DIR|LIST --out DIR [--jobs N] [--shard I/N]\n"
               "       posekit batch merge --out DIR\n\n"
               "  measure  measure many bodies, one result per input, a CSV + JSON summary (resumable, shardable)\n"
               "  merge    join the summaries of a sharded run\n";
  return sub == "--help" || sub == "-h" ? 0 : 2;
}

}  // namespace posekit::cli
