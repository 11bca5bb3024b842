// posekit bench commands: whole commands as a user times them, process start to exit, beside the
// tools users would pick instead on the same files: read, measure, compare and convert a scan.
#include <algorithm>
#include <fstream>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "bench_tools.h"
#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"

namespace posekit::cli {
namespace {

/// A scanner's file: binary little-endian PLY of float x, y, z in metres.
void write_float_ply(const std::string& path, const Eigen::MatrixXd& P) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << "ply\nformat binary_little_endian 1.0\nelement vertex " << P.rows()
        << "\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    std::vector<float> row(3 * static_cast<size_t>(std::min<Eigen::Index>(P.rows(), 1 << 16)));
    for (Eigen::Index first = 0; first < P.rows(); first += 1 << 16) {
      const Eigen::Index count = std::min<Eigen::Index>(1 << 16, P.rows() - first);
      for (Eigen::Index i = 0; i < count; ++i)
        for (int k = 0; k < 3; ++k) row[static_cast<size_t>(3 * i + k)] = static_cast<float>(P(first + i, k));
      out.write(reinterpret_cast<const char*>(row.data()), static_cast<std::streamsize>(12 * count));
    }
  });
}

std::string points_label(long n) {
  return n % 1000000 == 0 ? std::to_string(n / 1000000) + "M" : n % 1000 == 0 ? std::to_string(n / 1000) + "k" : std::to_string(n);
}

struct Tool {
  std::string name, command, note;  ///< command empty: not run (note says why)
  std::vector<double> seconds;
  double peak_mib = 0;
};

}  // namespace

int bench_commands(int argc, char** argv) {
  ArgParser args("bench commands",
                 "Times whole commands as a user does, from process start to exit, on a synthetic scan of the\n"
                 "default body (float binary PLY in metres, a scanner's file) at each size: reading it (posekit\n"
                 "info), measuring it (posekit measure), comparing it with the body (posekit compare) and\n"
                 "converting it to ASCII XYZ (posekit convert). With --peers, CloudCompare and Open3D (a Python\n"
                 "script: interpreter, import, the work) do the same on the same files where they can, and the\n"
                 "MeshLab server where installed; the runs are interleaved so that the tools share the machine's\n"
                 "noise. Peak memory is each process's.");
  args.data_option()
      .option("points", "LIST", "scan sizes, comma-separated", "1000000,10000000")
      .option("runs", "R", "runs of every command (median reported)", "5")
      .option("only", "LIST", "commands to time, comma-separated: read, measure, compare, convert", "read,measure,compare,convert")
      .flag("peers", "also time CloudCompare, Open3D and the MeshLab server")
      .flag("json", "machine-readable results on stdout");
  if (!args.parse(argc, argv)) return 0;
  const int runs = static_cast<int>(args.get_int("runs"));
  if (runs < 1) throw UsageError("--runs must be at least 1");
  std::vector<long> sizes;
  std::stringstream list(args.get("points"));
  for (std::string item; std::getline(list, item, ',');) {
    long n = 0;
    try {
      n = std::stol(item);
    } catch (const std::exception&) {
    }
    if (n < 1000) throw UsageError("--points: each size must be a number of at least 1000, got '" + item + "'");
    sizes.push_back(n);
  }
  const auto model = load_makehuman_model(find_data_root(args.get("data")));
  const Body body = build_body(*model, BodySpec{});
  const ScratchDir scratch;
  const std::string& dir = scratch.path;
  write_mesh(dir + "/model.ply", body.mesh);
  std::error_code ec;
  const std::string self = std::filesystem::read_symlink("/proc/self/exe", ec).string();
  const bool peers = args.flag_set("peers");
  const std::string python = peers ? open3d_python() : "";
  const bool cloudcompare = peers && have_program("CloudCompare");
  const bool meshlab = peers && have_program("meshlabserver");
  const std::string cc = "QT_QPA_PLATFORM=offscreen CloudCompare -SILENT -NO_TIMESTAMP -AUTO_SAVE OFF";
  if (!python.empty()) {
    write_file_atomically(dir + "/o3d_read.py", [](std::ostream& o) {
      o << "import sys\nimport open3d as o3d\nprint(len(o3d.io.read_point_cloud(sys.argv[1]).points))\n";
    });
    write_file_atomically(dir + "/o3d_convert.py", [](std::ostream& o) {
      o << "import sys\nimport open3d as o3d\nassert o3d.io.write_point_cloud(sys.argv[2], o3d.io.read_point_cloud(sys.argv[1]))\n";
    });
    write_open3d_compare_script(dir);
  }
  std::vector<std::string> operations;
  std::stringstream only(args.get("only"));
  for (std::string op; std::getline(only, op, ',');) {
    if (op != "read" && op != "measure" && op != "compare" && op != "convert")
      throw UsageError("--only: unknown command '" + op + "' (read, measure, compare, convert)");
    operations.push_back(op);
  }
  nlohmann::ordered_json rows = nlohmann::ordered_json::array(), ratios = nlohmann::ordered_json::array();
  std::ostringstream table;
  table << "| command | points | posekit s (MiB) | CloudCompare s (MiB) | Open3D s (MiB) | MeshLab s (MiB) | posekit / best peer |\n"
        << "|---|---|---|---|---|---|---|\n";
  for (const long n : sizes) {
    const std::string label = points_label(n), scan = dir + "/scan.ply", model_ply = dir + "/model.ply";
    std::cerr << "bench commands: writing a " << label << "-point scan\n";
    write_float_ply(scan, sample_surface(body.mesh, n, 0.0015, 7).P);
    for (const std::string& o : operations) {
      const std::string out = dir + "/out.xyz";
      std::vector<Tool> tools(4);
      tools[0].name = "posekit", tools[1].name = "CloudCompare", tools[2].name = "Open3D", tools[3].name = "MeshLab";
      if (o == "read") tools[0].command = self + " info " + scan;
      if (o == "measure") tools[0].command = self + " measure " + scan + " --json";
      if (o == "compare") tools[0].command = self + " compare " + model_ply + " " + scan + " --json";
      if (o == "convert") tools[0].command = self + " convert " + scan + " " + out;
      if (cloudcompare) {
        if (o == "read") tools[1].command = cc + " -O " + scan;
        if (o == "compare") tools[1].command = cc + " -O " + scan + " -O " + model_ply + " -c2m_dist";
        if (o == "convert") tools[1].command = cc + " -O " + scan + " -C_EXPORT_FMT ASC -SAVE_CLOUDS FILE " + out;
      }
      if (!python.empty()) {
        if (o == "read") tools[2].command = python + " " + dir + "/o3d_read.py " + scan;
        if (o == "compare") tools[2].command = python + " " + dir + "/o3d_compare.py " + model_ply + " " + scan;
        if (o == "convert") tools[2].command = python + " " + dir + "/o3d_convert.py " + scan + " " + out;
      }
      if (meshlab && o == "convert") tools[3].command = "meshlabserver -i " + scan + " -o " + out;
      for (Tool& t : tools)
        if (t.command.empty())
          t.note = o == "measure" && t.name != "posekit"       ? "no girths"
                   : !peers                                    ? "not asked (--peers)"
                   : t.name == "CloudCompare" && !cloudcompare ? "not installed"
                   : t.name == "Open3D" && python.empty()      ? "not installed"
                   : t.name == "MeshLab"                       ? (meshlab ? "no such command" : "not installed")
                                                               : "no such command";
      std::cerr << "bench commands: " << o << " " << label << "\n";
      for (int k = 0; k < runs; ++k)
        for (Tool& t : tools) {
          if (t.command.empty()) continue;
          const ProcessRun r = run_process(t.command, dir + "/" + t.name + ".log");
          if (r.seconds < 0) {
            t.note = "failed: " + t.command;
            t.command.clear();
            continue;
          }
          t.seconds.push_back(r.seconds);
          t.peak_mib = std::max(t.peak_mib, r.peak_mib);
        }
      double mine = -1, best = -1;
      std::string best_name;
      table << "| " << o << " | " << label;
      for (const Tool& t : tools) {
        nlohmann::ordered_json row = {{"case", o + " " + label + ": " + t.name}, {"operation", o}, {"points", n}, {"tool", t.name}};
        if (t.seconds.empty()) {
          row["note"] = t.note;
          table << " | " << t.note;
        } else {
          const Stats st = stats_of(t.seconds);
          row["median_s"] = st.median, row["min_s"] = st.min, row["max_s"] = st.max, row["peak_rss_mib"] = t.peak_mib;
          row["command"] = t.command;
          std::ostringstream c;
          c << std::fixed << std::setprecision(st.median < 1 ? 3 : 2) << st.median << " (" << std::setprecision(0) << t.peak_mib << ")";
          table << " | " << c.str();
          if (t.name == "posekit") mine = st.median;
          else if (best < 0 || st.median < best) best = st.median, best_name = t.name;
        }
        rows.push_back(row);
      }
      std::ostringstream ratio;
      if (mine > 0 && best > 0) {
        ratio << std::fixed << std::setprecision(2) << mine / best << " (" << best_name << ")";
        ratios.push_back({{"case", o + " " + label}, {"posekit_over_best_peer", mine / best}, {"best_peer", best_name}});
      }
      table << " | " << ratio.str() << " |\n";
    }
  }
  if (args.flag_set("json")) {
    print_json(nlohmann::ordered_json{
        {"benchmark", "commands"}, {"points", sizes}, {"runs", runs}, {"commands", rows}, {"ratios", ratios}, {"table", table.str()}});
    return 0;
  }
  std::cout << "whole commands, median seconds over " << runs << " runs (peak MiB):\n\n" << table.str();
  return 0;
}

}  // namespace posekit::cli
