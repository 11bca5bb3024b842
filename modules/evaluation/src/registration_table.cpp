#include "posekit/evaluation/registration_table.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "manifest.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/datasets/dataset.h"
#include "posekit/datasets/remesh.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/registration/registration.h"

namespace fs = std::filesystem;

namespace posekit {
namespace {

std::pair<double, double> correspondence_error_mm(const TriangleMesh& templ, const TriangleMesh& subject,
                                                  const SurfacePoints& truth, const Eigen::VectorXi& match) {
  const Eigen::MatrixXd true_points = face_centroids(evaluate_surface_points(templ.V, templ.F, truth), subject.F);
  const Eigen::MatrixXd source_centroids = face_centroids(templ.V, templ.F);
  std::vector<double> d(static_cast<size_t>(match.size()));
  for (Eigen::Index k = 0; k < match.size(); ++k)
    d[static_cast<size_t>(k)] = 1000 * (source_centroids.row(match[k]) - true_points.row(k)).norm();
  double mean = 0;
  for (double x : d) mean += x;
  mean /= static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  return {mean, d[static_cast<size_t>(0.95 * static_cast<double>(d.size() - 1))]};
}

}  // namespace

RegistrationTable measure_registration_table(const std::string& dir, const RegistrationTableOptions& o) {
  if (o.runs < 1) throw InvalidInput("registration table: runs must be at least 1");
  const nlohmann::json manifest = read_dataset_manifest(dir);
  const TriangleMesh templ = read_mesh((fs::path(dir) / manifest.at("template").at("mesh").get<std::string>()).string());
  struct Method {
    std::string name;
    RegistrationOptions options;
  };
  std::vector<Method> methods(3);
  methods[0].name = "ct-FFD";
  methods[1].name = "ICP (1 iteration)";
  methods[1].options.method = RegistrationMethod::kIcp;
  methods[1].options.icp_iterations = 1;
  methods[2].name = "ICP (6 iterations)";
  methods[2].options.method = RegistrationMethod::kIcp;
  methods[2].options.icp_iterations = 6;
  if (o.nicp_runs > 0) {
    methods.push_back({"non-rigid ICP (optimal step)", {}});
    methods.back().options.method = RegistrationMethod::kNicp;
  }
  RegistrationTable table;
  table.template_vertices = templ.num_vertices();
  table.template_triangles = templ.num_faces();
  table.rows.resize(methods.size());
  for (size_t m = 0; m < methods.size(); ++m) table.rows[m].method = methods[m].name;
  std::vector<std::vector<double>> p95(methods.size());
  const auto& subjects = manifest.at("subjects");
  const int total = o.subjects > 0 ? std::min<int>(o.subjects, static_cast<int>(subjects.size())) : static_cast<int>(subjects.size());
  long vertices = 0, triangles = 0;
  for (int si = 0; si < total; ++si) {
    const auto& s = subjects[static_cast<size_t>(si)];
    table.subject_ids.push_back(s.value("id", "?"));
    const TriangleMesh subject = read_mesh((fs::path(dir) / s.at("rest").get<std::string>()).string());
    const SurfacePoints truth = load_correspondence((fs::path(dir) / s.at("correspondence").get<std::string>()).string());
    vertices += subject.num_vertices();
    triangles += subject.num_faces();
    for (size_t m = 0; m < methods.size(); ++m) {
      const bool nicp = methods[m].options.method == RegistrationMethod::kNicp;
      if (nicp && o.nicp_subjects > 0 && si >= o.nicp_subjects) continue;
      RegistrationResult r;
      for (int k = 0; k < (nicp ? o.nicp_runs : o.runs); ++k) {
        r = register_bodies(templ, subject, methods[m].options);
        table.rows[m].seconds.push_back(r.seconds);
      }
      const auto [mean, p] = correspondence_error_mm(templ, subject, truth, r.correspondence);
      table.rows[m].subject_mean_error_mm.push_back(mean);
      p95[m].push_back(p);
      ++table.rows[m].subjects;
    }
    if (o.progress) o.progress(si + 1, total);
  }
  table.mean_subject_vertices = vertices / std::max(total, 1);
  table.mean_subject_triangles = triangles / std::max(total, 1);
  for (size_t m = 0; m < methods.size(); ++m) {
    RegistrationTableRow& row = table.rows[m];
    if (row.seconds.empty()) continue;
    std::vector<double> t = row.seconds;
    std::sort(t.begin(), t.end());
    row.median_s = t.size() % 2 ? t[t.size() / 2] : 0.5 * (t[t.size() / 2 - 1] + t[t.size() / 2]);
    row.min_s = t.front();
    row.max_s = t.back();
    for (double e : row.subject_mean_error_mm) row.mean_error_mm += e / static_cast<double>(row.subject_mean_error_mm.size());
    for (double e : p95[m]) row.p95_error_mm += e / static_cast<double>(p95[m].size());
    row.worst_subject_mean_error_mm = *std::max_element(row.subject_mean_error_mm.begin(), row.subject_mean_error_mm.end());
  }
  return table;
}

}  // namespace posekit
