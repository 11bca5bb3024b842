#include "bench_tools.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <vector>

#include "posekit/core/mesh_geometry.h"
#include "posekit/core/timer.h"
#include "posekit/io/atomic_file.h"

namespace posekit::cli {

ProcessRun run_process(const std::string& command, const std::string& log) {
  const std::string line = command + " >" + log + " 2>&1";
  const Stopwatch t0;
  const pid_t pid = fork();
  if (pid == 0) {
    execl("/bin/sh", "sh", "-c", line.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  ProcessRun r;
  if (pid < 0) return r;
  int status = 0;
  struct rusage usage {};
  if (wait4(pid, &status, 0, &usage) != pid) return r;
  const double seconds = t0.seconds();
  if (WIFEXITED(status) && WEXITSTATUS(status) == 0) r.seconds = seconds;
  r.peak_mib = static_cast<double>(usage.ru_maxrss) / 1024.0;
  return r;
}

std::string open3d_python() {
  for (const char* candidate : {"python3", "/usr/bin/python3"})
    if (std::system((std::string(candidate) + " -c 'import open3d' >/dev/null 2>&1").c_str()) == 0) return candidate;
  return {};
}

std::string write_open3d_compare_script(const std::string& dir) {
  const std::string path = dir + "/o3d_compare.py";
  write_file_atomically(path, [](std::ostream& out) {
    out << "import sys\nimport numpy as np\nimport open3d as o3d\n"
           "mesh = o3d.t.geometry.TriangleMesh.from_legacy(o3d.io.read_triangle_mesh(sys.argv[1]))\n"
           "pts = o3d.core.Tensor(np.asarray(o3d.io.read_point_cloud(sys.argv[2]).points, dtype=np.float32))\n"
           "scene = o3d.t.geometry.RaycastingScene()\nscene.add_triangles(mesh)\n"
           "print(float(scene.compute_distance(pts).numpy().mean()))\n";
  });
  return path;
}

bool have_program(const std::string& program) { return std::system(("command -v " + program + " >/dev/null 2>&1").c_str()) == 0; }

PointCloud sample_surface(const TriangleMesh& mesh, long n, double sigma, unsigned seed) {
  const Eigen::VectorXd area = face_areas(mesh.V, mesh.F);
  const Eigen::MatrixXd normals = face_normals(mesh.V, mesh.F);
  std::vector<double> cdf(static_cast<size_t>(area.size()));
  double acc = 0;
  for (Eigen::Index f = 0; f < area.size(); ++f) cdf[static_cast<size_t>(f)] = acc += area[f];
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::normal_distribution<double> noise(0, sigma);
  PointCloud scan;
  scan.P.resize(n, 3);
  for (long i = 0; i < n; ++i) {
    const size_t f = std::min(cdf.size() - 1, static_cast<size_t>(std::lower_bound(cdf.begin(), cdf.end(), u(rng) * acc) - cdf.begin()));
    double a = u(rng), b = u(rng);
    if (a + b > 1) a = 1 - a, b = 1 - b;
    const auto F = mesh.F.row(static_cast<Eigen::Index>(f));
    scan.P.row(i) = (1 - a - b) * mesh.V.row(F[0]) + a * mesh.V.row(F[1]) + b * mesh.V.row(F[2]) +
                    noise(rng) * normals.row(static_cast<Eigen::Index>(f));
  }
  return scan;
}

ScratchDir::ScratchDir() : path((std::filesystem::temp_directory_path() / ("posekit-bench-" + std::to_string(::getpid()))).string()) {
  create_folders(path);
}

ScratchDir::~ScratchDir() {
  std::error_code ec;
  std::filesystem::remove_all(path, ec);
}

}  // namespace posekit::cli
