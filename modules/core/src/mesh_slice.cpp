#include "posekit/core/mesh_slice.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdint>
#include <unordered_map>

namespace posekit {
namespace {
std::uint64_t edge_key(int a, int b) {
  const auto lo = static_cast<std::uint32_t>(std::min(a, b)), hi = static_cast<std::uint32_t>(std::max(a, b));
  return (static_cast<std::uint64_t>(lo) << 32) | hi;
}
}  // namespace

namespace {

/// Segments of one plane: each cut edge (key) with its point and its neighbouring cut edges.
struct PlaneCuts {
  std::unordered_map<std::uint64_t, Eigen::Vector3d> point_of_edge;
  std::unordered_map<std::uint64_t, std::vector<std::uint64_t>> neighbours;
};

/// Adds face f's segment for the plane at signed distances s (vertices with s >= 0 count as above).
void cut_face(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::Index f, const double* s, PlaneCuts& cuts) {
  std::uint64_t cut[2];
  int count = 0;
  for (int c = 0; c < 3; ++c) {
    const int a = F(f, c), b = F(f, (c + 1) % 3);
    const double sa = s[c], sb = s[(c + 1) % 3];
    if ((sa >= 0) == (sb >= 0)) continue;
    const std::uint64_t key = edge_key(a, b);
    if (!cuts.point_of_edge.count(key)) {
      const double t = sa / (sa - sb);
      // Interpolate from the smaller index so both faces of the edge compute the same point.
      cuts.point_of_edge[key] = a < b ? Eigen::Vector3d(V.row(a).transpose() + t * (V.row(b) - V.row(a)).transpose())
                                      : Eigen::Vector3d(V.row(b).transpose() + (1 - t) * (V.row(a) - V.row(b)).transpose());
    }
    if (count < 2) cut[count] = key;
    ++count;
  }
  if (count == 2) {
    cuts.neighbours[cut[0]].push_back(cut[1]);
    cuts.neighbours[cut[1]].push_back(cut[0]);
  }
}

std::vector<SectionLoop> chain_loops(PlaneCuts& cuts) {
  std::vector<SectionLoop> loops;
  std::unordered_map<std::uint64_t, bool> visited;
  // Start open chains at their ends first, then the closed loops; sorted keys make it deterministic.
  std::vector<std::uint64_t> starts;
  for (const auto& [key, nb] : cuts.neighbours)
    if (nb.size() == 1) starts.push_back(key);
  std::sort(starts.begin(), starts.end());
  std::vector<std::uint64_t> rest;
  for (const auto& kv : cuts.neighbours) rest.push_back(kv.first);
  std::sort(rest.begin(), rest.end());
  starts.insert(starts.end(), rest.begin(), rest.end());
  for (std::uint64_t start : starts) {
    if (visited[start]) continue;
    std::vector<Eigen::Vector3d> pts;
    std::uint64_t prev = start, cur = start;
    bool closed = false;
    while (true) {
      visited[cur] = true;
      pts.push_back(cuts.point_of_edge[cur]);
      std::uint64_t next = cur;
      for (std::uint64_t cand : cuts.neighbours[cur])
        if (cand != prev && !visited[cand]) {
          next = cand;
          break;
        }
      if (next == cur) {
        for (std::uint64_t cand : cuts.neighbours[cur])
          if (cand == start && pts.size() > 2) closed = true;
        break;
      }
      prev = cur;
      cur = next;
    }
    SectionLoop loop;
    loop.closed = closed;
    loop.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
    for (size_t i = 0; i < pts.size(); ++i) loop.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
    loops.push_back(std::move(loop));
  }
  return loops;
}

}  // namespace

std::vector<SectionLoop> slice_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& normal,
                                    double offset) {
  return slice_mesh_stack(V, F, normal, {offset}).front();
}

std::vector<std::vector<SectionLoop>> slice_mesh_stack(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                                       const Eigen::Vector3d& normal, const std::vector<double>& offsets) {
  const double scale = normal.norm();
  const Eigen::Vector3d n = normal / scale;
  const Eigen::VectorXd h = V * n;
  std::vector<std::pair<double, size_t>> order;
  for (size_t i = 0; i < offsets.size(); ++i) order.emplace_back(offsets[i] / scale, i);
  std::sort(order.begin(), order.end());
  std::vector<PlaneCuts> cuts(offsets.size());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const double h0 = h[F(f, 0)], h1 = h[F(f, 1)], h2 = h[F(f, 2)];
    const double lo = std::min({h0, h1, h2}), hi = std::max({h0, h1, h2});
    auto it = std::upper_bound(order.begin(), order.end(), std::make_pair(lo, size_t(0)),
                               [](const auto& a, const auto& b) { return a.first < b.first; });
    for (; it != order.end() && it->first <= hi; ++it) {
      const double s[3] = {h0 - it->first, h1 - it->first, h2 - it->first};
      cut_face(V, F, f, s, cuts[it->second]);
    }
  }
  std::vector<std::vector<SectionLoop>> out(offsets.size());
  for (size_t i = 0; i < offsets.size(); ++i) out[i] = chain_loops(cuts[i]);
  return out;
}

double polyline_length(const Eigen::MatrixXd& P, bool closed) {
  double len = 0;
  for (Eigen::Index i = 1; i < P.rows(); ++i) len += (P.row(i) - P.row(i - 1)).norm();
  if (closed && P.rows() > 2) len += (P.row(0) - P.row(P.rows() - 1)).norm();
  return len;
}

double convex_hull_perimeter(const Eigen::MatrixXd& P, const Eigen::Vector3d& normal) {
  if (P.rows() < 2) return 0.0;
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  std::vector<Eigen::Vector2d> q(static_cast<size_t>(P.rows()));
  for (Eigen::Index i = 0; i < P.rows(); ++i) q[i] = Eigen::Vector2d(P.row(i).dot(u), P.row(i).dot(w));
  std::sort(q.begin(), q.end(), [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y();
  });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Eigen::Vector2d> hull(2 * q.size());
  size_t k = 0;
  for (size_t i = 0; i < q.size(); ++i) {  // Andrew's monotone chain
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], q[i]) <= 0) --k;
    hull[k++] = q[i];
  }
  for (size_t i = q.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], q[i]) <= 0) --k;
    hull[k++] = q[i];
  }
  double perimeter = 0;
  for (size_t i = 1; i < k; ++i) perimeter += (hull[i] - hull[i - 1]).norm();
  return perimeter;
}

int nearest_loop(const std::vector<SectionLoop>& loops, const Eigen::Vector3d& point) {
  int best = -1;
  double best_d = 0;
  for (size_t i = 0; i < loops.size(); ++i) {
    if (loops[i].points.rows() == 0) continue;
    const double d = (loops[i].points.colwise().mean().transpose() - point).norm();
    if (best < 0 || d < best_d) {
      best = static_cast<int>(i);
      best_d = d;
    }
  }
  return best;
}

}  // namespace posekit
