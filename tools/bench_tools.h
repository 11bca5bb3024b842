#pragma once
// Helpers the benchmarks share (cmd_bench.cpp, cmd_bench_commands.cpp): timed child processes,
// the peer tools, synthetic scans, scratch folders.
#include <string>

#include "posekit/core/point_cloud.h"
#include "posekit/core/triangle_mesh.h"

namespace posekit::cli {

/// One process run to completion: its wall seconds (-1 when it fails) and peak resident memory.
struct ProcessRun {
  double seconds = -1, peak_mib = -1;
};

/// Runs `command` through /bin/sh (output to `log`); the peak is the largest of the shell and the
/// processes it waited for (wait4's rusage).
ProcessRun run_process(const std::string& command, const std::string& log);

/// The python with Debian's open3d, or empty (python3-open3d is for the system interpreter, which
/// another python3 first on PATH may hide).
std::string open3d_python();

/// Writes DIR/o3d_compare.py: Open3D's distance of every scan point (argv 2) to the mesh (argv 1)
/// by RaycastingScene, as a user would script it; prints the mean. Returns its path.
std::string write_open3d_compare_script(const std::string& dir);

/// Whether `program` is on PATH.
bool have_program(const std::string& program);

/// n points uniform by area on a mesh, with Gaussian noise of `sigma` (m) along the face normal: a
/// stand-in for a scanner's cloud.
PointCloud sample_surface(const TriangleMesh& mesh, long n, double sigma, unsigned seed);

/// A temporary folder removed on scope exit.
struct ScratchDir {
  std::string path;
  ScratchDir();
  ~ScratchDir();
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
};

}  // namespace posekit::cli
