#include "posekit/paper/registration_table.h"

#include <algorithm>
#include <filesystem>
#include <iterator>
#include <nlohmann/json.hpp>
#include <numeric>
#include <random>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/datasets/dataset.h"
#include "posekit/datasets/remesh.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"
#include "posekit/population/makehuman_shape_space.h"
#include "posekit/registration/registration.h"
#include "posekit/registration/shape_space.h"

namespace fs = std::filesystem;

namespace posekit {
namespace {

struct SampleStats {
  double mean = 0, p95 = 0, max = 0;
};

SampleStats sample_stats(std::vector<double> d) {
  SampleStats s;
  if (d.empty()) return s;
  for (double x : d) s.mean += x / static_cast<double>(d.size());
  std::sort(d.begin(), d.end());
  s.p95 = d[static_cast<size_t>(0.95 * static_cast<double>(d.size() - 1))];
  s.max = d.back();
  return s;
}

/// Triangle match error (mm): for each subject triangle, the distance on the template between the
/// centroid of its matched template triangle and the true point of its centroid.
SampleStats triangle_match_error_mm(const TriangleMesh& templ, const Eigen::MatrixXd& true_centroids, const Eigen::VectorXi& match) {
  const Eigen::MatrixXd source_centroids = face_centroids(templ.V, templ.F);
  std::vector<double> d(static_cast<size_t>(match.size()));
  for (Eigen::Index k = 0; k < match.size(); ++k)
    d[static_cast<size_t>(k)] = 1000 * (source_centroids.row(match[k]) - true_centroids.row(k)).norm();
  return sample_stats(std::move(d));
}

/// Point correspondence error (mm): each subject vertex's closest point on the registered source,
/// taken back to the template by its triangle and barycentric coordinates, against its true point.
SampleStats point_error_mm(const TriangleMesh& templ, const Eigen::MatrixXd& deformed, const TriangleMesh& subject,
                           const Eigen::MatrixXd& true_points) {
  TriangleMesh registered;
  registered.V = deformed;
  registered.F = templ.F;
  const SurfacePoints found = closest_surface_points(registered, subject.V);
  const Eigen::MatrixXd on_template = evaluate_surface_points(templ.V, templ.F, found);
  std::vector<double> d(static_cast<size_t>(subject.V.rows()));
  for (Eigen::Index k = 0; k < subject.V.rows(); ++k) d[static_cast<size_t>(k)] = 1000 * (on_template.row(k) - true_points.row(k)).norm();
  return sample_stats(std::move(d));
}

/// The triangle match error of the true correspondence itself: each subject triangle matched to the
/// template triangle holding its true centroid point. No registration can go below it.
SampleStats triangle_match_floor_mm(const TriangleMesh& templ, const Eigen::MatrixXd& true_centroids) {
  return triangle_match_error_mm(templ, true_centroids, closest_surface_points(templ, true_centroids).face);
}

/// Mean vertex error (mm) of the subject posed by the learned method, with the given correspondence
/// (subject triangle -> template triangle), against its posed ground truth; -1 without posed truth.
double pose_transfer_error_mm(const std::shared_ptr<const PoseModel>& model, const std::string& dir, const nlohmann::json& subject_entry,
                              const TriangleMesh& subject, const Eigen::VectorXi& template_triangle) {
  SubjectSetupOptions so;
  so.template_triangle = template_triangle;
  const PoseSynthesizer synth(model, subject, so);
  double sum = 0;
  long count = 0;
  for (const auto& p : subject_entry.value("posed", nlohmann::json::array())) {
    const TriangleMesh truth = read_mesh((fs::path(dir) / p.at("mesh").get<std::string>()).string());
    if (truth.V.rows() != subject.V.rows()) continue;
    const Eigen::MatrixXd X =
        synth.pose(read_part_pose((fs::path(dir) / p.at("pose_json").get<std::string>()).string()), PoseMethod::kLearned);
    sum += (X - truth.V).rowwise().norm().sum();
    count += X.rows();
  }
  return count ? 1000 * sum / static_cast<double>(count) : -1.0;
}

struct Target {
  TriangleMesh mesh;
  Eigen::MatrixXd true_points;  ///< #V x 3: each vertex's true point on the template
};

/// The subject remeshed to about `vertices` vertices (another topology and resolution), with
/// `holes` holes of 2-6 cm punched at seeded random vertices (a scan's gaps); truth carried over.
Target remeshed_target(const TriangleMesh& subject, const Eigen::MatrixXd& true_points, int vertices, int holes, unsigned seed) {
  SurfacePoints on_subject;
  TriangleMesh mesh = remesh_body(subject, vertices, &on_subject);
  Eigen::MatrixXd truth(mesh.V.rows(), 3);
  for (Eigen::Index v = 0; v < mesh.V.rows(); ++v) {
    truth.row(v).setZero();
    for (int c = 0; c < 3; ++c) truth.row(v) += on_subject.bary(v, c) * true_points.row(subject.F(on_subject.face[v], c));
  }
  if (holes > 0) {
    std::mt19937 rng(seed);
    std::uniform_int_distribution<Eigen::Index> pick(0, mesh.V.rows() - 1);
    std::uniform_real_distribution<double> radius(0.01, 0.03);
    std::vector<bool> keep(static_cast<size_t>(mesh.F.rows()), true);
    const Eigen::MatrixXd centroids = face_centroids(mesh.V, mesh.F);
    for (int h = 0; h < holes; ++h) {
      const Eigen::RowVector3d centre = mesh.V.row(pick(rng));
      const double r = radius(rng);
      for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
        if ((centroids.row(f) - centre).norm() < r) keep[static_cast<size_t>(f)] = false;
    }
    std::vector<int> new_index(static_cast<size_t>(mesh.V.rows()), -1);
    std::vector<Eigen::Vector3i> faces;
    int next = 0;
    for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
      if (!keep[static_cast<size_t>(f)]) continue;
      Eigen::Vector3i t;
      for (int c = 0; c < 3; ++c) {
        int& k = new_index[static_cast<size_t>(mesh.F(f, c))];
        if (k < 0) k = next++;
        t[c] = k;
      }
      faces.push_back(t);
    }
    Target out;
    out.mesh.V.resize(next, 3);
    out.true_points.resize(next, 3);
    for (Eigen::Index v = 0; v < mesh.V.rows(); ++v)
      if (new_index[static_cast<size_t>(v)] >= 0) {
        out.mesh.V.row(new_index[static_cast<size_t>(v)]) = mesh.V.row(v);
        out.true_points.row(new_index[static_cast<size_t>(v)]) = truth.row(v);
      }
    out.mesh.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
    for (size_t f = 0; f < faces.size(); ++f) out.mesh.F.row(static_cast<Eigen::Index>(f)) = faces[f].transpose();
    return out;
  }
  return {std::move(mesh), std::move(truth)};
}

}  // namespace

RegistrationTable measure_registration_table(const std::string& dir, const RegistrationTableOptions& o) {
  if (o.runs < 1) throw InvalidInput("registration table: runs must be at least 1");
  const nlohmann::json manifest = read_json_file((std::filesystem::path(dir) / "manifest.json").string());
  const TriangleMesh templ = read_mesh((fs::path(dir) / manifest.at("template").at("mesh").get<std::string>()).string());
  struct Method {
    std::string name;
    RegistrationOptions options;
    bool prepared = false;  ///< ct-FFD from the template's side made once (not timed per subject)
  };
  std::vector<Method> methods(5);
  methods[0].name = "ct-FFD";
  methods[1].name = "ct-FFD, template prepared once";
  methods[1].prepared = true;
  methods[2].name = "ct-FFD + NICP refinement";
  methods[2].options.refine = true;
  methods[3].name = "ICP (1 iteration)";
  methods[3].options.method = RegistrationMethod::kIcp;
  methods[3].options.icp_iterations = 1;
  methods[4].name = "ICP (6 iterations)";
  methods[4].options.method = RegistrationMethod::kIcp;
  methods[4].options.icp_iterations = 6;
  const CtffdSource prepared_template(templ, methods[1].options.points_per_layer);
  if (o.shape_space) {
    Method m;
    m.name = "ct-FFD + shape space";
    m.prepared = true;
    m.options.shape_space = o.shape_space;
    methods.push_back(std::move(m));
  }
  if (o.ctffd_threads > 1) {  // the same ct-FFD rows again on more threads
    const std::string on = " (" + std::to_string(o.ctffd_threads) + " threads)";
    std::vector<Method> threaded;
    for (const Method& m : methods)
      if (m.options.method == RegistrationMethod::kCtffd && !m.options.refine) {
        threaded.push_back(m);
        threaded.back().name += on;
        threaded.back().options.threads = o.ctffd_threads;
      }
    methods.insert(methods.end(), threaded.begin(), threaded.end());
  }
  if (o.nicp_runs > 0) {
    methods.push_back({"non-rigid ICP (optimal step)", {}});
    methods.back().options.method = RegistrationMethod::kNicp;
  }
  const auto& subjects = manifest.at("subjects");
  const int total = o.subjects > 0 ? std::min<int>(o.subjects, static_cast<int>(subjects.size())) : static_cast<int>(subjects.size());
  struct TargetKind {
    std::string name;
    int vertices, holes;  // 0 vertices: the subject as it is
  };
  std::vector<TargetKind> kinds = {{"the dataset's subjects", 0, 0}};
  if (o.other_topologies) {
    kinds.push_back({"the subjects remeshed to ~6,900 vertices", 6900, 0});
    kinds.push_back({"the subjects remeshed to ~50,000 vertices with 25 holes of 2-6 cm (scan-like)", 50000, 25});
  }
  std::vector<RegistrationTable> tables;
  int done = 0;
  for (const TargetKind& kind : kinds) {
    RegistrationTable table;
    table.targets = kind.name;
    table.ctffd_template_seconds = prepared_template.seconds();
    table.template_vertices = templ.num_vertices();
    table.template_triangles = templ.num_faces();
    table.rows.resize(methods.size());
    for (size_t m = 0; m < methods.size(); ++m) table.rows[m].method = methods[m].name;
    std::vector<std::vector<SampleStats>> point(methods.size()), match(methods.size());
    std::vector<SampleStats> floor;
    std::vector<std::vector<double>> pose_transfer(methods.size());
    std::vector<double> pose_transfer_true;
    long vertices = 0, triangles = 0;
    for (int si = 0; si < total; ++si) {
      const auto& s = subjects[static_cast<size_t>(si)];
      table.subject_ids.push_back(s.value("id", "?"));
      Target target;
      target.mesh = read_mesh((fs::path(dir) / s.at("rest").get<std::string>()).string());
      const SurfacePoints truth = load_correspondence((fs::path(dir) / s.at("correspondence").get<std::string>()).string());
      target.true_points = evaluate_surface_points(templ.V, templ.F, truth);
      if (kind.vertices > 0)
        target = remeshed_target(target.mesh, target.true_points, kind.vertices, kind.holes, static_cast<unsigned>(1000 + si));
      const TriangleMesh& subject = target.mesh;
      const Eigen::MatrixXd& true_points = target.true_points;
      const Eigen::MatrixXd true_centroids = face_centroids(true_points, subject.F);
      floor.push_back(triangle_match_floor_mm(templ, true_centroids));
      if (o.model && kind.vertices == 0) {
        const double e = pose_transfer_error_mm(o.model, dir, s, subject, closest_surface_points(templ, true_centroids).face);
        if (e >= 0) pose_transfer_true.push_back(e);
      }
      vertices += subject.num_vertices();
      triangles += subject.num_faces();
      for (size_t m = 0; m < methods.size(); ++m) {
        const bool nicp = methods[m].options.method == RegistrationMethod::kNicp;
        if (nicp && o.nicp_subjects > 0 && si >= o.nicp_subjects) continue;
        RegistrationResult r;
        for (int k = 0; k < (nicp ? o.nicp_runs : o.runs); ++k) {
          r = methods[m].prepared ? register_bodies(prepared_template, subject, methods[m].options)
                                  : register_bodies(templ, subject, methods[m].options);
          table.rows[m].seconds.push_back(r.seconds);
        }
        if (o.model && kind.vertices == 0) {
          const double e = pose_transfer_error_mm(o.model, dir, s, subject, r.correspondence);
          if (e >= 0) pose_transfer[m].push_back(e);
        }
        match[m].push_back(triangle_match_error_mm(templ, true_centroids, r.correspondence));
        point[m].push_back(point_error_mm(templ, r.deformed_source, subject, true_points));
        table.rows[m].subject_mean_error_mm.push_back(match[m].back().mean);
        table.rows[m].subject_point_mean_mm.push_back(point[m].back().mean);
        ++table.rows[m].subjects;
      }
      if (o.progress) o.progress(++done, total * static_cast<int>(kinds.size()));
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
      const double k = static_cast<double>(match[m].size());
      for (size_t s = 0; s < match[m].size(); ++s) {
        row.mean_error_mm += match[m][s].mean / k;
        row.p95_error_mm += match[m][s].p95 / k;
        row.point_mean_mm += point[m][s].mean / k;
        row.point_p95_mm += point[m][s].p95 / k;
        row.point_max_mm += point[m][s].max / k;
      }
      row.worst_subject_mean_error_mm = *std::max_element(row.subject_mean_error_mm.begin(), row.subject_mean_error_mm.end());
      row.worst_subject_point_mean_mm = *std::max_element(row.subject_point_mean_mm.begin(), row.subject_point_mean_mm.end());
      if (!pose_transfer[m].empty())
        row.pose_transfer_mm =
            std::accumulate(pose_transfer[m].begin(), pose_transfer[m].end(), 0.0) / static_cast<double>(pose_transfer[m].size());
    }
    for (const SampleStats& f : floor) {
      table.triangle_floor_mean_mm += f.mean / static_cast<double>(floor.size());
      table.triangle_floor_p95_mm += f.p95 / static_cast<double>(floor.size());
    }
    if (!pose_transfer_true.empty())
      table.pose_transfer_true_mm =
          std::accumulate(pose_transfer_true.begin(), pose_transfer_true.end(), 0.0) / static_cast<double>(pose_transfer_true.size());
    tables.push_back(std::move(table));
  }
  RegistrationTable result = std::move(tables.front());
  result.other_targets.assign(std::make_move_iterator(tables.begin() + 1), std::make_move_iterator(tables.end()));
  return result;
}

}  // namespace posekit
