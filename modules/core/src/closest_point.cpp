#include "posekit/core/closest_point.h"

#include <algorithm>
#include <cstdint>
#include <exception>
#include <numeric>
#include <thread>
#include <vector>

#include "posekit/core/error.h"

namespace posekit {

Eigen::Vector3d closest_point_on_triangle(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                                          const Eigen::Vector3d& c, Eigen::Vector3d* bary) {
  auto done = [&](double u, double v, double w) {
    if (bary) *bary = Eigen::Vector3d(u, v, w);
    return Eigen::Vector3d(u * a + v * b + w * c);
  };
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return done(1, 0, 0);
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return done(0, 1, 0);
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) {
    const double v = d1 / (d1 - d3);
    return done(1 - v, v, 0);
  }
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return done(0, 0, 1);
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) {
    const double w = d2 / (d2 - d6);
    return done(1 - w, 0, w);
  }
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) {
    const double w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
    return done(0, 1 - w, w);
  }
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0)) return done(1, 0, 0);  // degenerate: its first corner
  const double v = vb / denom, w = vc / denom;
  return done(1 - v - w, v, w);
}

void parallel_for_ranges(long n, int threads, const std::function<void(long, long)>& body, long min_items_per_thread) {
  if (threads <= 0) threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = static_cast<int>(std::min<long>(threads, std::max<long>(1, n / std::max<long>(1, min_items_per_thread))));
  if (threads <= 1) {
    body(0, n);
    return;
  }
  // An exception in any range is rethrown here after every thread has joined (never std::terminate).
  std::vector<std::thread> pool;
  std::vector<std::exception_ptr> errors(static_cast<size_t>(threads));
  auto guarded = [&](int t, long begin, long end) {
    try {
      body(begin, end);
    } catch (...) {
      errors[static_cast<size_t>(t)] = std::current_exception();
    }
  };
  const long chunk = (n + threads - 1) / threads;
  for (int t = 1; t < threads; ++t) {
    const long begin = t * chunk, end = std::min(n, begin + chunk);
    if (begin < end) pool.emplace_back(guarded, t, begin, end);
  }
  guarded(0, 0, std::min(n, chunk));
  for (auto& th : pool) th.join();
  for (const auto& e : errors)
    if (e) std::rethrow_exception(e);
}

struct TriangleTree::Impl {
  struct Node {
    Eigen::Vector3d lo, hi;
    int left = -1, right = -1;  // children, or -1 for a leaf
    int begin = 0, end = 0;     // leaf range in `order`
  };
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  std::vector<int> order;       // face of each leaf slot
  std::vector<int> slot_of;     // leaf slot of each face
  std::vector<double> corners;  // 9 per leaf slot: the triangle's corners, contiguous for the search
  std::vector<double> boxes;    // 6 per leaf slot: the triangle's box (lo, hi), a cheap lower bound
  std::vector<Node> nodes;

  int build(int begin, int end, const Eigen::MatrixXd& centroid, const Eigen::MatrixXd& lo, const Eigen::MatrixXd& hi) {
    Node node;
    node.lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
    node.hi = -node.lo;
    for (int i = begin; i < end; ++i) {
      node.lo = node.lo.cwiseMin(lo.row(order[static_cast<size_t>(i)]).transpose());
      node.hi = node.hi.cwiseMax(hi.row(order[static_cast<size_t>(i)]).transpose());
    }
    const int id = static_cast<int>(nodes.size());
    nodes.push_back(node);
    if (end - begin <= 4) {
      nodes[static_cast<size_t>(id)].begin = begin;
      nodes[static_cast<size_t>(id)].end = end;
      return id;
    }
    int axis;
    (node.hi - node.lo).maxCoeff(&axis);
    const int mid = (begin + end) / 2;
    std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                     [&](int a, int b) { return centroid(a, axis) < centroid(b, axis); });
    const int left = build(begin, mid, centroid, lo, hi);
    const int right = build(mid, end, centroid, lo, hi);
    nodes[static_cast<size_t>(id)].left = left;
    nodes[static_cast<size_t>(id)].right = right;
    return id;
  }

  static double box_sq_distance(const Node& n, const Eigen::Vector3d& p) {
    const Eigen::Vector3d d = (n.lo - p).cwiseMax(p - n.hi).cwiseMax(0.0);
    return d.squaredNorm();
  }

  Eigen::Vector3d corner(int slot, int c) const {
    return Eigen::Map<const Eigen::Vector3d>(&corners[static_cast<size_t>(9 * slot + 3 * c)]);
  }

  struct Hit {
    double sq_distance;
    int slot;
    Eigen::Vector3d point, bary;
  };

  /// Branch and bound from an initial hit (slot -1: none); exact whatever the start.
  void search(const Eigen::Vector3d& p, Hit& best) const {
    int stack[128];
    int top = 0;
    stack[top++] = 0;
    Eigen::Vector3d bary;
    while (top > 0) {
      const Node& n = nodes[static_cast<size_t>(stack[--top])];
      if (box_sq_distance(n, p) >= best.sq_distance) continue;
      if (n.left < 0) {
        for (int i = n.begin; i < n.end; ++i) {
          if (i == best.slot) continue;
          const double* box = &boxes[static_cast<size_t>(6 * i)];
          double gap = 0;
          for (int k = 0; k < 3; ++k) {
            const double g = std::max({box[k] - p[k], p[k] - box[3 + k], 0.0});
            gap += g * g;
          }
          if (gap >= best.sq_distance) continue;
          const Eigen::Vector3d q = closest_point_on_triangle(p, corner(i, 0), corner(i, 1), corner(i, 2), &bary);
          const double d = (q - p).squaredNorm();
          if (d < best.sq_distance) best = {d, i, q, bary};
        }
        continue;
      }
      const double dl = box_sq_distance(nodes[static_cast<size_t>(n.left)], p);
      const double dr = box_sq_distance(nodes[static_cast<size_t>(n.right)], p);
      // Push the farther child first so that the nearer one is searched first.
      if (dl < dr) {
        if (dr < best.sq_distance) stack[top++] = n.right;
        if (dl < best.sq_distance) stack[top++] = n.left;
      } else {
        if (dl < best.sq_distance) stack[top++] = n.left;
        if (dr < best.sq_distance) stack[top++] = n.right;
      }
    }
  }

  /// The hit of `slot` itself: a bound to start the search from.
  Hit hit_of(const Eigen::Vector3d& p, int slot) const {
    Hit h{std::numeric_limits<double>::infinity(), -1, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
    if (slot < 0) return h;
    h.slot = slot;
    h.point = closest_point_on_triangle(p, corner(slot, 0), corner(slot, 1), corner(slot, 2), &h.bary);
    h.sq_distance = (h.point - p).squaredNorm();
    return h;
  }
};

namespace {

/// Spreads the low 10 bits of x to every third bit.
std::uint32_t spread_bits(std::uint32_t x) {
  x &= 0x3FFu;
  x = (x | (x << 16)) & 0x030000FFu;
  x = (x | (x << 8)) & 0x0300F00Fu;
  x = (x | (x << 4)) & 0x030C30C3u;
  x = (x | (x << 2)) & 0x09249249u;
  return x;
}

/// Rows of P in Morton (Z-curve) order of a 1024^3 grid over their box, by a radix sort: nearby
/// queries follow one another, so each starts from a tight bound and touches warm memory.
std::vector<int> morton_order(const Eigen::MatrixXd& P) {
  const Eigen::Index n = P.rows();
  std::vector<int> out(static_cast<size_t>(n));
  std::iota(out.begin(), out.end(), 0);
  if (n < 2) return out;
  const Eigen::RowVector3d lo = P.colwise().minCoeff(), span = (P.colwise().maxCoeff() - lo).cwiseMax(1e-300);
  std::vector<std::uint32_t> code(static_cast<size_t>(n)), code2(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    std::uint32_t c = 0;
    for (int k = 0; k < 3; ++k)
      c |= spread_bits(static_cast<std::uint32_t>(std::min(1023.0, (P(i, k) - lo[k]) / span[k] * 1024.0))) << k;
    code[static_cast<size_t>(i)] = c;
  }
  std::vector<int> tmp(static_cast<size_t>(n));
  for (int shift = 0; shift < 30; shift += 10) {  // three passes of 10 bits
    std::vector<size_t> count(1025, 0);
    for (size_t i = 0; i < out.size(); ++i) ++count[((code[i] >> shift) & 1023u) + 1];
    for (size_t b = 1; b < count.size(); ++b) count[b] += count[b - 1];
    for (size_t i = 0; i < out.size(); ++i) {
      const size_t dst = count[(code[i] >> shift) & 1023u]++;
      tmp[dst] = out[i];
      code2[dst] = code[i];
    }
    out.swap(tmp);
    code.swap(code2);
  }
  return out;
}

}  // namespace

TriangleTree::TriangleTree(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) : impl_(std::make_unique<Impl>()) {
  if (F.rows() == 0) throw InvalidInput("TriangleTree: the mesh has no triangles");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw InvalidInput("TriangleTree: a triangle index is outside the " + std::to_string(V.rows()) + " vertices");
  Impl& s = *impl_;
  s.V = V;
  s.F = F;
  Eigen::MatrixXd centroid(F.rows(), 3), lo(F.rows(), 3), hi(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::RowVector3d a = V.row(F(f, 0)), b = V.row(F(f, 1)), c = V.row(F(f, 2));
    centroid.row(f) = (a + b + c) / 3;
    lo.row(f) = a.cwiseMin(b).cwiseMin(c);
    hi.row(f) = a.cwiseMax(b).cwiseMax(c);
  }
  s.order.resize(static_cast<size_t>(F.rows()));
  std::iota(s.order.begin(), s.order.end(), 0);
  s.nodes.reserve(static_cast<size_t>(F.rows() / 2 + 16));
  s.build(0, static_cast<int>(F.rows()), centroid, lo, hi);
  s.slot_of.resize(s.order.size());
  s.corners.resize(9 * s.order.size());
  s.boxes.resize(6 * s.order.size());
  for (size_t i = 0; i < s.order.size(); ++i) {
    const int f = s.order[i];
    s.slot_of[static_cast<size_t>(f)] = static_cast<int>(i);
    for (int c = 0; c < 3; ++c)
      for (int k = 0; k < 3; ++k) s.corners[9 * i + 3 * c + k] = V(F(f, c), k);
    for (int k = 0; k < 3; ++k) {
      s.boxes[6 * i + k] = lo(f, k);
      s.boxes[6 * i + 3 + k] = hi(f, k);
    }
  }
}

TriangleTree::~TriangleTree() = default;

int TriangleTree::closest(const Eigen::Vector3d& p, Eigen::Vector3d* point, double* distance, double max_distance) const {
  const Impl& s = *impl_;
  Impl::Hit best{max_distance * max_distance, -1, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  s.search(p, best);
  if (point) *point = best.point;
  if (distance) *distance = best.slot >= 0 ? std::sqrt(best.sq_distance) : std::numeric_limits<double>::infinity();
  return best.slot >= 0 ? s.order[static_cast<size_t>(best.slot)] : -1;
}

ClosestPoints TriangleTree::closest(const Eigen::MatrixXd& P, int threads) const {
  const Impl& s = *impl_;
  ClosestPoints out;
  out.face.resize(P.rows());
  out.point.resize(P.rows(), 3);
  out.bary.resize(P.rows(), 3);
  out.distance.resize(P.rows());
  const std::vector<int> visit = morton_order(P);
  parallel_for_ranges(P.rows(), threads, [&](long begin, long end) {
    // Queries go in blocks: the block's points are gathered into a contiguous copy and the results
    // scattered back afterwards, so that the search loop itself never waits on a far-away row.
    constexpr long kBlock = 2048;
    struct Result {
      Eigen::Vector3d point, bary;
      double distance;
      int face;
    };
    std::vector<Eigen::Vector3d> points(static_cast<size_t>(kBlock));
    std::vector<Result> results(static_cast<size_t>(kBlock));
    int previous = -1;
    for (long block = begin; block < end; block += kBlock) {
      const long count = std::min(kBlock, end - block);
      for (long k = 0; k < count; ++k) points[static_cast<size_t>(k)] = P.row(visit[static_cast<size_t>(block + k)]).transpose();
      for (long k = 0; k < count; ++k) {
        const Eigen::Vector3d& p = points[static_cast<size_t>(k)];
        // The previous (nearby) query's triangle bounds the search from the start.
        Impl::Hit best = s.hit_of(p, previous);
        s.search(p, best);
        previous = best.slot;
        results[static_cast<size_t>(k)] = {best.point, best.bary, std::sqrt(best.sq_distance),
                                           s.order[static_cast<size_t>(best.slot)]};
      }
      for (long k = 0; k < count; ++k) {
        const int i = visit[static_cast<size_t>(block + k)];
        const Result& r = results[static_cast<size_t>(k)];
        out.face[i] = r.face;
        out.point.row(i) = r.point.transpose();
        out.distance[i] = r.distance;
        out.bary.row(i) = r.bary.transpose();
      }
    }
  });
  return out;
}

}  // namespace posekit
