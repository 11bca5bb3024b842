// posekit bench all: every benchmark in one run, one table with its date and machine.
#include <sys/utsname.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "cli.h"
#include "commands.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/io/atomic_file.h"
#include "posekit/version.h"

namespace posekit::cli {
namespace fs = std::filesystem;
namespace {

std::string shell_quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

/// The first line of `path` that starts with `key`, the text after the key's separator.
std::string field_of(const std::string& path, const std::string& key, char separator) {
  std::ifstream in(path);
  for (std::string line; std::getline(in, line);) {
    if (line.rfind(key, 0) != 0) continue;
    const auto at = line.find(separator);
    if (at == std::string::npos) continue;
    std::string value = line.substr(at + 1);
    while (!value.empty() && (value.front() == ' ' || value.front() == '\t' || value.front() == '"')) value.erase(0, 1);
    while (!value.empty() && (value.back() == '"' || value.back() == ' ')) value.pop_back();
    return value;
  }
  return "";
}

nlohmann::ordered_json machine() {
  nlohmann::ordered_json m;
  m["cpu"] = field_of("/proc/cpuinfo", "model name", ':');
  m["cores"] = std::thread::hardware_concurrency();
  const std::string mem = field_of("/proc/meminfo", "MemTotal", ':');
  m["memory_gib"] = mem.empty() ? 0.0 : std::stod(mem) / 1048576.0;
  m["os"] = field_of("/etc/os-release", "PRETTY_NAME", '=');
  utsname u{};
  if (uname(&u) == 0) m["kernel"] = std::string(u.release);
  m["posekit"] = version();
  return m;
}

/// One row per timed quantity of a benchmark's JSON: objects holding median/min/max (or
/// median_s/_ms with min and max), named by their "case"/"method" or their path.
void collect_rows(const std::string& bench, const std::string& path, const nlohmann::ordered_json& j, const std::string& unit,
                  nlohmann::ordered_json* rows) {
  if (j.is_array()) {
    for (size_t i = 0; i < j.size(); ++i) collect_rows(bench, path + "[" + std::to_string(i) + "]", j[i], unit, rows);
    return;
  }
  if (!j.is_object()) return;
  const std::string label = j.contains("case")     ? j["case"].get<std::string>()
                            : j.contains("method") ? j["method"].get<std::string>()
                            : path.empty()         ? "total"
                                                   : path;
  for (const auto& [suffix, u] : {std::pair<std::string, std::string>{"", unit}, {"_s", "s"}, {"_ms", "ms"}}) {
    if (!j.contains("median" + suffix) || !j["median" + suffix].is_number()) continue;
    nlohmann::ordered_json row = {{"benchmark", bench}, {"case", label}, {"unit", u}, {"median", j["median" + suffix]}};
    row["min"] = j.contains("min" + suffix) ? j["min" + suffix] : nlohmann::ordered_json();
    row["max"] = j.contains("max" + suffix) ? j["max" + suffix] : nlohmann::ordered_json();
    if (j.contains("peak_rss_mib") && j["peak_rss_mib"].is_number()) row["peak_rss_mib"] = j["peak_rss_mib"];
    rows->push_back(row);
  }
  if (j.contains("compute_median_s") && j["compute_median_s"].is_number() && j["compute_median_s"].get<double>() >= 0)
    rows->push_back({{"benchmark", bench},
                     {"case", "peer: " + j.value("name", path) + " (" + j.value("what", "") + ")"},
                     {"unit", "s"},
                     {"median", j["compute_median_s"]},
                     {"min", nullptr},
                     {"max", nullptr}});
  for (const auto& [key, value] : j.items()) {
    if (value.is_object() || value.is_array()) {
      // The unit in the key: train_s, pose_ms_learned, stages_median_s.
      const std::string k = key + "_";
      const std::string unit_of_child = k.find("_ms_") != std::string::npos ? "ms" : k.find("_s_") != std::string::npos ? "s" : unit;
      collect_rows(bench, path.empty() ? key : path + "/" + key, value, unit_of_child, rows);
    }
  }
}

std::string cell(const nlohmann::ordered_json& v) {
  if (!v.is_number()) return "";
  std::ostringstream s;
  const double x = v.get<double>();
  s << std::setprecision(x >= 100 ? 0 : x >= 1 ? 3 : 4) << (x >= 100 ? std::fixed : std::defaultfloat) << x;
  return s.str();
}

std::string markdown(const nlohmann::ordered_json& report) {
  std::ostringstream md;
  const auto& m = report["machine"];
  md << "Made by `" << report["command"].get<std::string>() << "` on " << report["date"].get<std::string>() << ".\n\n"
     << "Machine: " << m["cpu"].get<std::string>() << ", " << m["cores"].get<unsigned>() << " cores, " << std::fixed << std::setprecision(1)
     << m["memory_gib"].get<double>() << " GiB, " << m["os"].get<std::string>() << " (Linux " << m.value("kernel", "") << "), posekit "
     << m["posekit"].get<std::string>() << ".\n\n"
     << "| benchmark | case | median | min | max | unit | peak RSS MiB |\n|---|---|---|---|---|---|---|\n";
  for (const auto& b : report["benchmarks"]) {
    if (!b["ok"].get<bool>()) {
      md << "| " << b["name"].get<std::string>() << " | not run: " << b["note"].get<std::string>() << " | | | | | |\n";
      continue;
    }
    for (const auto& r : b["rows"])
      md << "| " << b["name"].get<std::string>() << " | " << r["case"].get<std::string>() << " | " << cell(r["median"]) << " | "
         << cell(r["min"]) << " | " << cell(r["max"]) << " | " << r["unit"].get<std::string>() << " | "
         << cell(r.contains("peak_rss_mib") ? r["peak_rss_mib"] : b["peak_rss_mib"]) << " |\n";
  }
  // Whole commands beside the peers, as `posekit bench commands` prints them.
  for (const auto& b : report["benchmarks"])
    if (b["ok"].get<bool>() && b.contains("result") && b["result"].contains("table"))
      md << "\nWhole commands (process start to exit), median seconds (peak MiB) of `posekit bench commands`:\n\n"
         << b["result"]["table"].get<std::string>();
  md << "\nEach benchmark runs in its own process (`posekit bench <name> --json`, its options in `benchmarks.json`); "
        "medians over its runs. Shared machines are noisy: compare figures of one run.\n";
  return md.str();
}

struct Spec {
  std::string name, options;
  bool needs_dataset;
};

/// One benchmark (`posekit bench <name> --json`) in its own process: its rows and peak memory, or
/// why it failed (counted in `failed`).
nlohmann::ordered_json run_benchmark(const std::string& exe, const Spec& s, const fs::path& out, int* failed) {
  nlohmann::ordered_json b = {{"name", s.name}, {"options", s.options}};
  std::cerr << "bench all: " << s.name << " (" << s.options << ")\n";
  const std::string json_path = (out / ("." + s.name + ".json")).string(), log = (out / (s.name + ".log")).string();
  const Stopwatch t0;
  const int status = std::system(
      (shell_quote(exe) + " bench " + s.name + " " + s.options + " --json >" + shell_quote(json_path) + " 2>" + shell_quote(log)).c_str());
  b["wall_s"] = t0.seconds();
  nlohmann::ordered_json result;
  try {
    if (status != 0) throw IoError("exit status " + std::to_string(status));
    result = nlohmann::ordered_json::parse(read_file_bytes(json_path));
  } catch (const std::exception& e) {
    b["ok"] = false;
    b["note"] = std::string("failed (") + e.what() + "; see " + log + ")";
    ++*failed;
    std::cerr << "bench all: " << s.name << ": " << b["note"].get<std::string>() << "\n";
    return b;
  }
  fs::remove(json_path);
  b["ok"] = true;
  nlohmann::ordered_json rows = nlohmann::ordered_json::array();
  collect_rows(s.name, "", result, result.value("units", "s"), &rows);
  b["rows"] = rows;
  const auto& peak =
      result.contains("peak_rss_mib") ? result["peak_rss_mib"] : result.value("compare_peak_rss_mib", nlohmann::ordered_json());
  if (peak.is_number()) {
    b["peak_rss_mib"] = peak;
  } else if (peak.is_object()) {
    double most = 0;
    for (const auto& [k, v] : peak.items()) most = std::max(most, v.get<double>());
    b["peak_rss_mib"] = most;
  }
  b["result"] = result;
  return b;
}

/// batch measure: throughput over the dataset's rest subjects and rest scans on 2 jobs, median of 3
/// runs (1 when quick).
nlohmann::ordered_json bench_batch(const std::string& exe, const std::string& dataset, const fs::path& out, bool quick, int* failed) {
  std::cerr << "bench all: batch\n";
  nlohmann::ordered_json b = {{"name", "batch"}, {"options", "measure, rest subjects and rest scans of the dataset, --jobs 2"}};
  const fs::path list = out / ".batch_inputs.txt";
  long inputs = 0;
  write_file_atomically(
      list.string(),
      [&](std::ostream& os) {
        for (const char* kind : {"subjects", "scans"}) {
          if (!fs::is_directory(fs::path(dataset) / kind)) continue;
          std::vector<std::string> paths;
          for (const auto& e : fs::directory_iterator(fs::path(dataset) / kind)) {
            const fs::path rest = e.path() / (std::string(kind) == "subjects" ? "rest.ply" : "rest.pcd");
            if (fs::is_regular_file(rest)) paths.push_back(rest.string());
          }
          std::sort(paths.begin(), paths.end());
          for (const auto& p : paths) os << p << "\n", ++inputs;
        }
      },
      false);
  std::vector<double> rate, seconds, peak;
  std::string note;
  for (int run = 0; run < (quick ? 1 : 3) && note.empty(); ++run) {
    const fs::path dir = out / ".batch_run";
    fs::remove_all(dir);
    const std::string json_path = (out / ".batch.json").string(), log = (out / "batch.log").string();
    const int status = std::system((shell_quote(exe) + " batch measure --inputs " + shell_quote(list.string()) + " --out " +
                                    shell_quote(dir.string()) + " --jobs 2 --json >" + shell_quote(json_path) + " 2>" + shell_quote(log))
                                       .c_str());
    try {
      if (status != 0) throw IoError("exit status " + std::to_string(status));
      const auto r = nlohmann::ordered_json::parse(read_file_bytes(json_path));
      rate.push_back(r["inputs_per_second"].get<double>());
      seconds.push_back(r["seconds"].get<double>());
      peak.push_back(r["peak_rss_mib"].get<double>());
    } catch (const std::exception& e) {
      note = std::string("failed (") + e.what() + "; see " + log + ")";
    }
    fs::remove_all(dir);
    fs::remove(json_path);
  }
  fs::remove(list);
  if (!note.empty() || inputs == 0) {
    b["ok"] = false;
    b["note"] = inputs == 0 ? std::string("no rest subjects or scans in the dataset") : note;
    ++*failed;
  } else {
    const Stats r = stats_of(rate), t = stats_of(seconds);
    b["ok"] = true;
    b["rows"] = {
        {{"benchmark", "batch"},
         {"case", "measure " + std::to_string(inputs) + " meshes and scans, 2 jobs: throughput"},
         {"unit", "inputs/s"},
         {"median", r.median},
         {"min", r.min},
         {"max", r.max}},
        {{"benchmark", "batch"}, {"case", "the same: wall time"}, {"unit", "s"}, {"median", t.median}, {"min", t.min}, {"max", t.max}}};
    b["peak_rss_mib"] = stats_of(peak).max;
  }
  return b;
}

}  // namespace

int bench_all(int argc, char** argv) {
  ArgParser args("bench all",
                 "Runs every benchmark (io, body, measure, compare, commands, and with --dataset pose, registration and a\n"
                 "batch measure of its rest subjects and scans), each in its own process, and writes one table with the date and the "
                 "machine: OUT/benchmarks.json (every\n"
                 "benchmark's full output) and OUT/benchmarks.md (the table, for docs/). --quick runs each once on\n"
                 "smaller inputs (a smoke test, not figures to report).");
  args.option("dataset", "DIR", "a posekit dataset, for the pose and registration benchmarks (left out without it)")
      .output_folder("out", "DIR", "folder for benchmarks.json and benchmarks.md", "bench")
      .option("only", "LIST", "benchmarks to run, comma-separated (default: all)")
      .flag("peers", "also time CloudCompare and Open3D in the compare and commands benchmarks")
      .flag("quick", "one run each, small inputs")
      .flag("json", "the report as JSON on stdout")
      .example("posekit bench all --dataset out/dataset --peers --out docs/bench");
  if (!args.parse(argc, argv)) return 0;
  const bool quick = args.flag_set("quick");
  const std::string dataset = args.has("dataset") ? args.get("dataset") : "";
  if (!dataset.empty() && !fs::is_regular_file(fs::path(dataset) / "manifest.json"))
    throw InvalidInput(dataset + ": not a posekit dataset (no manifest.json; make one with posekit dataset make)");
  const std::string ds = shell_quote(dataset);
  const std::vector<Spec> specs = {
      {"io", quick ? "--runs 1 --triangles 100000 --points 100000" : "--runs 5", false},
      {"body", quick ? "--runs 3" : "--runs 50", false},
      {"measure", quick ? "--runs 1 --vertices 30000 --points 100000" : "--runs 5", false},
      {"compare", std::string(quick ? "--runs 1 --points 100000" : "--runs 5") + (args.flag_set("peers") ? " --peers" : ""), false},
      {"commands", std::string(quick ? "--runs 1 --points 100000" : "--runs 5") + (args.flag_set("peers") ? " --peers" : ""), false},
      {"pose", "--dataset " + ds + (quick ? " --runs 1 --poses 5 --subjects 2 --frames 20" : " --runs 5"), true},
      {"registration", "--dataset " + ds + (quick ? " --runs 1 --subjects 2 --nicp-runs 1" : " --runs 5 --nicp-runs 1"), true}};
  std::vector<std::string> only;
  if (args.has("only")) {
    std::stringstream list(args.get("only"));
    for (std::string name; std::getline(list, name, ',');) {
      bool known = false;
      for (const auto& s : specs) known = known || s.name == name;
      if (!known && name != "batch")
        throw UsageError("--only: unknown benchmark '" + name + "' (io, body, measure, compare, commands, pose, registration, batch)");
      only.push_back(name);
    }
  }
  const fs::path out = args.get("out");
  create_folders(out.string());
  const std::string exe = fs::read_symlink("/proc/self/exe").string();
  std::ostringstream command;
  command << "posekit bench all";
  for (int i = 0; i < argc; ++i) command << " " << argv[i];
  const std::time_t now = std::time(nullptr);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
  nlohmann::ordered_json report = {{"command", command.str()}, {"date", date}, {"machine", machine()}, {"quick", quick}};
  report["benchmarks"] = nlohmann::ordered_json::array();
  int failed = 0;
  for (const auto& s : specs) {
    if (!only.empty() && std::find(only.begin(), only.end(), s.name) == only.end()) continue;
    nlohmann::ordered_json b = {{"name", s.name}, {"options", s.options}};
    if (s.needs_dataset && dataset.empty()) {
      b["ok"] = false;
      b["note"] = "no --dataset";
      report["benchmarks"].push_back(b);
      continue;
    }
    report["benchmarks"].push_back(run_benchmark(exe, s, out, &failed));
  }
  if (!dataset.empty() && (only.empty() || std::find(only.begin(), only.end(), "batch") != only.end())) {
    report["benchmarks"].push_back(bench_batch(exe, dataset, out, quick, &failed));
  }
  write_file_atomically((out / "benchmarks.json").string(), [&](std::ostream& os) { os << report.dump(2) << "\n"; }, false);
  const std::string md = markdown(report);
  write_file_atomically((out / "benchmarks.md").string(), [&](std::ostream& os) { os << md; }, false);
  if (args.flag_set("json")) print_json(report);
  else std::cout << md << "\nwrote " << (out / "benchmarks.json").string() << " and " << (out / "benchmarks.md").string() << "\n";
  return failed > 0 ? 1 : 0;
}

}  // namespace posekit::cli
