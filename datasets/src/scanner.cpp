#include "posekit/datasets/scanner.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <unordered_map>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"

namespace posekit {

SimulatedScan simulate_scan(const TriangleMesh& mesh, const ScannerOptions& o) {
  if (o.views_around < 1 || o.heights.empty()) throw InvalidInput("simulate_scan: need at least one camera");
  const BoundingBox box = bounding_box(mesh.V);
  const double floor = box.min.y();
  const Eigen::Vector3d axis(box.center().x(), 0, box.center().z());
  const Eigen::MatrixXd N = face_normals(mesh.V, mesh.F);
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> noise(0.0, o.noise_sigma);
  SimulatedScan scan;
  std::vector<Eigen::Vector3d> points;
  std::vector<double> view_of;
  for (size_t h = 0; h < o.heights.size(); ++h)
    for (int a = 0; a < o.views_around; ++a) {
      const double angle = (45.0 + 360.0 * a / o.views_around) * M_PI / 180.0;
      const double y = floor + o.heights[h];
      const Eigen::Vector3d eye = axis + Eigen::Vector3d(o.distance * std::sin(angle), y, o.distance * std::cos(angle));
      const Eigen::Vector3d target = axis + Eigen::Vector3d(0, y, 0);
      const PinholeCamera cam = PinholeCamera::look_at(eye, target, Eigen::Vector3d::UnitY(), o.width, o.height, o.focal_px);
      const RenderBuffers buf = render_mesh(mesh, cam);
      const int view = static_cast<int>(scan.cameras.size());
      scan.cameras.push_back(cam);
      for (int py = 0; py < buf.height; ++py)
        for (int px = 0; px < buf.width; ++px) {
          const int f = buf.face[static_cast<size_t>(py) * buf.width + px];
          if (f < 0) continue;
          const Eigen::Vector3d d = cam.ray(px + 0.5, py + 0.5);
          const Eigen::Vector3d n = N.row(f).transpose();
          const double cosine = n.dot(d);
          if (std::abs(cosine) < o.min_incidence_cos) continue;
          const double s = n.dot(mesh.V.row(mesh.F(f, 0)).transpose() - eye) / cosine;  // exact ray hit
          points.push_back(eye + (s + noise(rng)) * d);
          view_of.push_back(view);
        }
    }
  const size_t hits = points.size();
  scan.outliers = static_cast<int>(std::lround(o.outlier_fraction * static_cast<double>(hits)));
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const Eigen::Vector3d lo = box.min.array() - 0.2, span = box.extent().array() + 0.4;
  for (int i = 0; i < scan.outliers; ++i) {
    // Drawn in sequence, z first: a constructor's arguments are evaluated in an unspecified order
    // (GCC right to left, clang left to right), and the scans must not depend on the compiler.
    const double z = unit(rng), y = unit(rng), x = unit(rng);
    points.push_back(lo + Eigen::Vector3d(x, y, z).cwiseProduct(span));
    view_of.push_back(-1);
  }
  scan.cloud.P.resize(static_cast<Eigen::Index>(points.size()), 3);
  Eigen::VectorXd view(points.size()), outlier(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    scan.cloud.P.row(static_cast<Eigen::Index>(i)) = points[i].transpose();
    view[static_cast<Eigen::Index>(i)] = view_of[i];
    outlier[static_cast<Eigen::Index>(i)] = i >= hits ? 1.0 : 0.0;
  }
  scan.cloud.point_scalars["view"] = view;
  scan.cloud.point_scalars["outlier"] = outlier;
  return scan;
}

namespace {

/// Triangles binned by the cells their xy bounding box overlaps, for rays along +Z.
class ColumnGrid {
 public:
  ColumnGrid(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double cell) : V_(V), F_(F), cell_(cell) {
    lo_ = V.leftCols(2).colwise().minCoeff().transpose();
    const Eigen::Vector2d hi = V.leftCols(2).colwise().maxCoeff().transpose();
    nx_ = static_cast<int>((hi.x() - lo_.x()) / cell) + 1;
    ny_ = static_cast<int>((hi.y() - lo_.y()) / cell) + 1;
    cells_.resize(static_cast<size_t>(nx_) * ny_);
    for (int f = 0; f < F.rows(); ++f) {
      Eigen::Vector2d a = V.row(F(f, 0)).head<2>().transpose(), b = a;
      for (int c = 1; c < 3; ++c)
        a = a.cwiseMin(V.row(F(f, c)).head<2>().transpose()), b = b.cwiseMax(V.row(F(f, c)).head<2>().transpose());
      for (int i = index(a.x(), lo_.x(), nx_); i <= index(b.x(), lo_.x(), nx_); ++i)
        for (int j = index(a.y(), lo_.y(), ny_); j <= index(b.y(), lo_.y(), ny_); ++j)
          cells_[static_cast<size_t>(i) * ny_ + j].push_back(f);
    }
  }

  /// Signed crossings of the ray from p along +Z (leaving an outward surface +1, entering -1):
  /// 1 where p lies inside the closed surface (2 where inside two overlapping parts), else 0.
  int winding(const Eigen::Vector3d& p) const {
    // Off the vertices and edges the ray would otherwise graze exactly.
    const double x = p.x() + 1.1e-7, y = p.y() + 0.7e-7;
    int w = 0;
    for (int f : cells_[static_cast<size_t>(index(x, lo_.x(), nx_)) * ny_ + index(y, lo_.y(), ny_)]) {
      const Eigen::Vector3d a = V_.row(F_(f, 0)), b = V_.row(F_(f, 1)), c = V_.row(F_(f, 2));
      const double d = (b.x() - a.x()) * (c.y() - a.y()) - (c.x() - a.x()) * (b.y() - a.y());
      if (d == 0) continue;
      const double u = ((b.x() - x) * (c.y() - y) - (c.x() - x) * (b.y() - y)) / d;
      const double v = ((c.x() - x) * (a.y() - y) - (a.x() - x) * (c.y() - y)) / d;
      const double t = 1 - u - v;
      if (u < 0 || v < 0 || t < 0) continue;
      if (u * a.z() + v * b.z() + t * c.z() > p.z()) w += d > 0 ? 1 : -1;
    }
    return w;
  }

 private:
  int index(double v, double lo, int n) const { return std::clamp(static_cast<int>((v - lo) / cell_), 0, n - 1); }
  const Eigen::MatrixXd& V_;
  const Eigen::MatrixXi& F_;
  double cell_;
  Eigen::Vector2d lo_;
  int nx_ = 0, ny_ = 0;
  std::vector<std::vector<int>> cells_;
};

constexpr double kFuseProbe = 0.001;  ///< m outside a triangle where its winding number is taken
constexpr size_t kSmallPatch = 8;     ///< triangles: a patch this small is a contact's ragged edge

std::uint64_t edge_key(int a, int b) {
  return (static_cast<std::uint64_t>(static_cast<std::uint32_t>(a)) << 32) | static_cast<std::uint32_t>(b);
}

}  // namespace

TriangleMesh fuse_interpenetrating_surfaces(const TriangleMesh& mesh, const Eigen::AlignedBox3d& region, std::vector<int>* face_origin) {
  const Eigen::MatrixXd& V = mesh.V;
  const Eigen::MatrixXi& F = mesh.F;
  const ColumnGrid grid(V, F, 0.01);
  std::vector<char> inside(static_cast<size_t>(F.rows()), 0);
  for (int f = 0; f < F.rows(); ++f) {
    // Just outside the triangle (1 mm along its normal): there the winding number is 0 unless
    // the triangle lies inside another part of the body.
    const Eigen::Vector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    const Eigen::Vector3d normal = (b - a).cross(c - a);
    inside[static_cast<size_t>(f)] =
        region.contains((a + b + c) / 3) && normal.norm() > 0 && grid.winding((a + b + c) / 3 + kFuseProbe * normal.normalized()) >= 1;
  }
  // Ragged edges of a contact patch: a few triangles inside (or outside) cut off from the rest of
  // their kind join their surroundings, so each patch leaves one clean hole.
  const Eigen::MatrixXi TT = face_adjacency(F);
  for (const char kind : {char(1), char(0)}) {
    std::vector<char> visited(static_cast<size_t>(F.rows()), 0);
    for (int seed = 0; seed < F.rows(); ++seed) {
      if (inside[static_cast<size_t>(seed)] != kind || visited[static_cast<size_t>(seed)]) continue;
      std::vector<int> members{seed};
      visited[static_cast<size_t>(seed)] = 1;
      for (size_t k = 0; k < members.size(); ++k)
        for (int e = 0; e < 3; ++e) {
          const int g = TT(members[k], e);
          if (g >= 0 && inside[static_cast<size_t>(g)] == kind && !visited[static_cast<size_t>(g)])
            visited[static_cast<size_t>(g)] = 1, members.push_back(g);
        }
      if (members.size() <= kSmallPatch)
        for (int g : members) inside[static_cast<size_t>(g)] = static_cast<char>(1 - kind);
    }
  }
  std::vector<int> kept;
  for (int f = 0; f < F.rows(); ++f)
    if (!inside[static_cast<size_t>(f)]) kept.push_back(f);
  std::vector<int> origin = kept;
  std::vector<Eigen::Vector3i> faces;
  faces.reserve(kept.size());
  for (int f : kept) faces.emplace_back(F(f, 0), F(f, 1), F(f, 2));
  if (static_cast<Eigen::Index>(kept.size()) < F.rows()) {
    Eigen::MatrixXi K(static_cast<Eigen::Index>(faces.size()), 3);
    for (size_t k = 0; k < faces.size(); ++k) K.row(static_cast<Eigen::Index>(k)) = faces[k].transpose();
    std::unordered_map<std::uint64_t, int> owner;  // directed edge -> kept face
    for (Eigen::Index k = 0; k < K.rows(); ++k)
      for (int c = 0; c < 3; ++c) owner[edge_key(K(k, c), K(k, (c + 1) % 3))] = kept[static_cast<size_t>(k)];
    std::vector<std::vector<int>> loops = boundary_loops(K);
    for (auto& loop : loops)  // each loop along its faces' edge direction
      if (loop.size() > 1 && !owner.count(edge_key(loop[0], loop[1]))) std::reverse(loop.begin(), loop.end());
    auto point = [&](int v) { return Eigen::Vector3d(V.row(v).transpose()); };
    auto nearest = [&](const std::vector<int>& loop, const Eigen::Vector3d& p, double* distance) {
      int best = 0;
      double d = 1e300;
      for (size_t k = 0; k < loop.size(); ++k)
        if ((point(loop[k]) - p).squaredNorm() < d) d = (point(loop[k]) - p).squaredNorm(), best = static_cast<int>(k);
      if (distance) *distance = std::sqrt(d);
      return best;
    };
    auto mean_gap = [&](const std::vector<int>& a, const std::vector<int>& b) {
      double sum = 0, d = 0;
      for (int v : a) nearest(b, point(v), &d), sum += d;
      return sum / static_cast<double>(a.size());
    };
    std::vector<int> partner(loops.size(), -1);
    for (size_t a = 0; a < loops.size(); ++a) {
      // Facing holes run along the same curve, within about an edge of each other.
      double edge = 0;
      for (size_t k = 0; k < loops[a].size(); ++k) edge += (point(loops[a][k]) - point(loops[a][(k + 1) % loops[a].size()])).norm();
      double best = 2 * edge / static_cast<double>(loops[a].size());
      for (size_t b = 0; b < loops.size(); ++b) {
        const double gap = b == a ? best : mean_gap(loops[a], loops[b]);
        if (gap < best) best = gap, partner[a] = static_cast<int>(b);
      }
      if (partner[a] < 0)
        throw InvalidInput("fuse_interpenetrating_surfaces: a hole of " + std::to_string(loops[a].size()) +
                           " edges left where the surface ran inside the body has no facing hole within two edge lengths");
    }
    for (size_t a = 0; a < loops.size(); ++a) {
      const size_t b = static_cast<size_t>(partner[a]);
      if (partner[b] != static_cast<int>(a)) throw InvalidInput("fuse_interpenetrating_surfaces: more than two holes meet along one curve");
      if (b < a) continue;
      // Zip: A forward, B backward (the facing holes run round their common curve in opposite senses).
      const std::vector<int>& A = loops[a];
      const std::vector<int>& B = loops[b];
      const int n = static_cast<int>(A.size()), m = static_cast<int>(B.size());
      const int j0 = nearest(B, point(A[0]), nullptr);
      // Following A forward, the nearest point of B must move backward round B.
      int drift = 0;
      for (int k = 0, previous = j0; k < n; ++k) {
        const int jk = nearest(B, point(A[static_cast<size_t>(k)]), nullptr);
        int step = ((jk - previous) % m + m) % m;
        if (step > m / 2) step -= m;
        drift += step;
        previous = jk;
      }
      if (drift > 0)
        throw InvalidInput("fuse_interpenetrating_surfaces: two facing holes run round their curve the same way (not an interpenetration)");
      auto at_b = [&](int j) { return B[static_cast<size_t>(((j0 - j) % m + m) % m)]; };
      int i = 0, j = 0;
      while (i < n || j < m) {
        const int ai = A[static_cast<size_t>(i % n)], ai1 = A[static_cast<size_t>((i + 1) % n)], bj = at_b(j), bj1 = at_b(j + 1);
        const bool advance_a = j == m || (i < n && (point(ai1) - point(bj)).squaredNorm() <= (point(ai) - point(bj1)).squaredNorm());
        if (advance_a) {
          faces.emplace_back(ai1, ai, bj);
          origin.push_back(owner.at(edge_key(ai, ai1)));
          ++i;
        } else {
          faces.emplace_back(bj, bj1, ai);
          origin.push_back(owner.at(edge_key(bj1, bj)));
          ++j;
        }
      }
    }
  }
  // Drop the vertices no face uses any more.
  std::vector<int> remap(static_cast<size_t>(V.rows()), -1);
  int count = 0;
  for (const auto& t : faces)
    for (int c = 0; c < 3; ++c)
      if (remap[static_cast<size_t>(t[c])] < 0) remap[static_cast<size_t>(t[c])] = count++;
  TriangleMesh out;
  out.V.resize(count, 3);
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    if (remap[static_cast<size_t>(v)] >= 0) out.V.row(remap[static_cast<size_t>(v)]) = V.row(v);
  out.F.resize(static_cast<Eigen::Index>(faces.size()), 3);
  for (size_t k = 0; k < faces.size(); ++k)
    for (int c = 0; c < 3; ++c) out.F(static_cast<Eigen::Index>(k), c) = remap[static_cast<size_t>(faces[k][c])];
  // Closed and consistently oriented: every directed edge once, its reverse once.
  std::unordered_map<std::uint64_t, int> directed;
  for (Eigen::Index k = 0; k < out.F.rows(); ++k)
    for (int c = 0; c < 3; ++c) ++directed[edge_key(out.F(k, c), out.F(k, (c + 1) % 3))];
  for (const auto& [key, uses] : directed) {
    const int a = static_cast<int>(key >> 32), b = static_cast<int>(key & 0xffffffffu);
    const auto reverse = directed.find(edge_key(b, a));
    if (uses != 1 || reverse == directed.end() || reverse->second != 1)
      throw InvalidInput("fuse_interpenetrating_surfaces: the fused surface is not a closed manifold at edge " + std::to_string(a) + "-" +
                         std::to_string(b));
  }
  if (face_origin) *face_origin = std::move(origin);
  return out;
}

}  // namespace posekit
