#include "posekit/core/mesh_topology.h"

#include <algorithm>
#include <cstdint>
#include <map>
#include <numeric>
#include <unordered_map>

#include "edge_key.h"

namespace posekit {
using core_detail::undirected_edge_key;
namespace {

struct HalfEdge {
  std::uint64_t key;  // (min << 32) | max
  int face;
  int corner;  // edge (F(face,corner), F(face,corner+1))
};

std::vector<HalfEdge> sorted_half_edges(const Eigen::MatrixXi& F) {
  std::vector<HalfEdge> h;
  h.reserve(static_cast<size_t>(F.rows()) * 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) h.push_back({undirected_edge_key(F(f, c), F(f, (c + 1) % 3)), static_cast<int>(f), c});
  std::sort(h.begin(), h.end(), [](const HalfEdge& a, const HalfEdge& b) { return a.key != b.key ? a.key < b.key : a.face < b.face; });
  return h;
}

int find_root(std::vector<int>& parent, int x) {
  while (parent[x] != x) {
    parent[x] = parent[parent[x]];
    x = parent[x];
  }
  return x;
}

}  // namespace

Eigen::MatrixXi unique_edges(const Eigen::MatrixXi& F) {
  const auto h = sorted_half_edges(F);
  std::vector<std::uint64_t> keys;
  keys.reserve(h.size());
  for (const auto& e : h)
    if (keys.empty() || keys.back() != e.key) keys.push_back(e.key);
  Eigen::MatrixXi E(static_cast<Eigen::Index>(keys.size()), 2);
  for (size_t i = 0; i < keys.size(); ++i) {
    E(i, 0) = static_cast<int>(keys[i] >> 32);
    E(i, 1) = static_cast<int>(keys[i] & 0xffffffffu);
  }
  return E;
}

Eigen::MatrixXi face_adjacency(const Eigen::MatrixXi& F, int* non_manifold_edges) {
  Eigen::MatrixXi TT = Eigen::MatrixXi::Constant(F.rows(), 3, -1);
  const auto h = sorted_half_edges(F);
  int non_manifold = 0;
  for (size_t i = 0; i < h.size();) {
    size_t j = i;
    while (j < h.size() && h[j].key == h[i].key) ++j;
    const size_t count = j - i;
    if (count >= 2) {
      if (count > 2) ++non_manifold;
      TT(h[i].face, h[i].corner) = h[i + 1].face;
      TT(h[i + 1].face, h[i + 1].corner) = h[i].face;
    }
    i = j;
  }
  if (non_manifold_edges) *non_manifold_edges = non_manifold;
  return TT;
}

namespace {

/// Half-edges a->b bucketed by a (a counting sort, linear time): cheaper than sorting every
/// half-edge where only "does another face have this edge" is asked.
struct OutEdges {
  std::vector<int> first_out, head;
  int vertices = 0;

  explicit OutEdges(const Eigen::MatrixXi& F) {
    for (Eigen::Index i = 0; i < F.size(); ++i) vertices = std::max(vertices, F.data()[i] + 1);
    first_out.assign(static_cast<size_t>(vertices) + 1, 0);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) ++first_out[static_cast<size_t>(F(f, c)) + 1];
    for (int v = 0; v < vertices; ++v) first_out[v + 1] += first_out[v];
    head.resize(static_cast<size_t>(first_out[vertices]));
    std::vector<int> fill(first_out.begin(), first_out.end() - 1);
    for (Eigen::Index f = 0; f < F.rows(); ++f)
      for (int c = 0; c < 3; ++c) head[static_cast<size_t>(fill[F(f, c)]++)] = F(f, (c + 1) % 3);
  }
  int count(int a, int b) const {
    int n = 0;
    for (int k = first_out[a]; k < first_out[a + 1]; ++k) n += head[k] == b;
    return n;
  }
  /// One face alone has the edge a-b (a->b and b->a counted together); an interior edge is told
  /// by its twin alone.
  bool on_border(int a, int b) const { return count(b, a) == 0 && count(a, b) == 1; }
};

}  // namespace

std::vector<char> border_edges(const Eigen::MatrixXi& F) {
  const OutEdges out(F);
  std::vector<char> border(static_cast<size_t>(F.size()), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) border[static_cast<size_t>(3 * f + c)] = out.on_border(F(f, c), F(f, (c + 1) % 3));
  return border;
}

std::vector<std::vector<int>> boundary_loops(const Eigen::MatrixXi& F) {
  const OutEdges out(F);
  const int nv = out.vertices;
  const std::vector<int>& first_out = out.first_out;
  const std::vector<int>& head = out.head;
  // Boundary half-edges a->b in face orientation; a loop follows them head to tail.
  std::unordered_multimap<int, int> next;
  for (int a = 0; a < nv; ++a)
    for (int k = first_out[a]; k < first_out[a + 1]; ++k)
      if (out.on_border(a, head[k])) next.emplace(a, head[k]);
  std::vector<std::vector<int>> loops;
  while (!next.empty()) {
    auto it = next.begin();
    const int start = it->first;
    std::vector<int> loop{start};
    int to = it->second;
    next.erase(it);
    while (to != start) {
      loop.push_back(to);
      auto n = next.find(to);
      if (n == next.end()) break;  // open chain on a non-manifold boundary
      to = n->second;
      next.erase(n);
    }
    loops.push_back(std::move(loop));
  }
  return loops;
}

int connected_components(const Eigen::MatrixXi& F, int num_vertices, Eigen::VectorXi* face_labels) {
  std::vector<int> parent(num_vertices);
  std::iota(parent.begin(), parent.end(), 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int a = find_root(parent, F(f, 0));
    for (int c = 1; c < 3; ++c) {
      const int b = find_root(parent, F(f, c));
      if (a != b) parent[b] = a;
    }
  }
  std::vector<int> label_of_root(num_vertices, -1);
  Eigen::VectorXi labels(F.rows());
  int count = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int r = find_root(parent, F(f, 0));
    if (label_of_root[r] < 0) label_of_root[r] = count++;
    labels[f] = label_of_root[r];
  }
  if (face_labels) *face_labels = std::move(labels);
  return count;
}

VertexFaces vertex_faces(const Eigen::MatrixXi& F, int num_vertices) {
  VertexFaces vf;
  vf.offsets.assign(num_vertices + 1, 0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) ++vf.offsets[F(f, c) + 1];
  std::partial_sum(vf.offsets.begin(), vf.offsets.end(), vf.offsets.begin());
  vf.face_index.resize(vf.offsets.back());
  std::vector<int> fill(vf.offsets.begin(), vf.offsets.end() - 1);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) vf.face_index[fill[F(f, c)]++] = static_cast<int>(f);
  return vf;
}

TriangleMesh subdivide_midpoints(const TriangleMesh& mesh) {
  const Eigen::MatrixXi E = unique_edges(mesh.F);
  std::map<std::pair<int, int>, int> midpoint;
  TriangleMesh out;
  out.V.resize(mesh.V.rows() + E.rows(), 3);
  out.V.topRows(mesh.V.rows()) = mesh.V;
  for (Eigen::Index e = 0; e < E.rows(); ++e) {
    out.V.row(mesh.V.rows() + e) = 0.5 * (mesh.V.row(E(e, 0)) + mesh.V.row(E(e, 1)));
    midpoint[{E(e, 0), E(e, 1)}] = static_cast<int>(mesh.V.rows() + e);
  }
  auto mid = [&](int a, int b) { return midpoint.at({std::min(a, b), std::max(a, b)}); };
  out.F.resize(4 * mesh.F.rows(), 3);
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
    const int a = mesh.F(f, 0), b = mesh.F(f, 1), c = mesh.F(f, 2), ab = mid(a, b), bc = mid(b, c), ca = mid(c, a);
    out.F.row(4 * f) << a, ab, ca;
    out.F.row(4 * f + 1) << ab, b, bc;
    out.F.row(4 * f + 2) << ca, bc, c;
    out.F.row(4 * f + 3) << ab, bc, ca;
  }
  return out;
}

}  // namespace posekit
