// posekit batch merge: the summaries of a sharded run joined into the unsharded run's.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "batch.h"
#include "cli.h"
#include "commands.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/checksum.h"

namespace posekit::cli::batch {
namespace fs = std::filesystem;

/// The summary columns of a command run with these settings (for merge).
std::vector<BatchColumn> columns_of(const std::string& command, const nlohmann::ordered_json& settings) {
  if (command == "measure") return measure_columns();
  if (command == "register") return register_columns();
  if (command == "compare") return compare_columns(settings.value("measure", false));
  if (command == "pose") return pose_columns();
  throw InvalidInput("a batch summary of an unknown command '" + command + "'");
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

}  // namespace posekit::cli::batch
