#include "posekit/core/closest_point.h"

#include <algorithm>
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
  std::vector<int> order;
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
};

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
}

TriangleTree::~TriangleTree() = default;

int TriangleTree::closest(const Eigen::Vector3d& p, Eigen::Vector3d* point, double* distance, double max_distance) const {
  const Impl& s = *impl_;
  double best = max_distance * max_distance;
  int best_face = -1;
  Eigen::Vector3d best_point = Eigen::Vector3d::Zero();
  int stack[128];
  int top = 0;
  stack[top++] = 0;
  while (top > 0) {
    const Impl::Node& n = s.nodes[static_cast<size_t>(stack[--top])];
    if (Impl::box_sq_distance(n, p) >= best) continue;
    if (n.left < 0) {
      for (int i = n.begin; i < n.end; ++i) {
        const int f = s.order[static_cast<size_t>(i)];
        const Eigen::Vector3d q = closest_point_on_triangle(p, s.V.row(s.F(f, 0)), s.V.row(s.F(f, 1)), s.V.row(s.F(f, 2)));
        const double d = (q - p).squaredNorm();
        if (d < best) {
          best = d;
          best_face = f;
          best_point = q;
        }
      }
      continue;
    }
    const double dl = Impl::box_sq_distance(s.nodes[static_cast<size_t>(n.left)], p);
    const double dr = Impl::box_sq_distance(s.nodes[static_cast<size_t>(n.right)], p);
    // Push the farther child first so that the nearer one is searched first.
    if (dl < dr) {
      if (dr < best) stack[top++] = n.right;
      if (dl < best) stack[top++] = n.left;
    } else {
      if (dl < best) stack[top++] = n.left;
      if (dr < best) stack[top++] = n.right;
    }
  }
  if (point) *point = best_point;
  if (distance) *distance = best_face >= 0 ? std::sqrt(best) : std::numeric_limits<double>::infinity();
  return best_face;
}

ClosestPoints TriangleTree::closest(const Eigen::MatrixXd& P, int threads) const {
  const Impl& s = *impl_;
  ClosestPoints out;
  out.face.resize(P.rows());
  out.point.resize(P.rows(), 3);
  out.bary.resize(P.rows(), 3);
  out.distance.resize(P.rows());
  parallel_for_ranges(P.rows(), threads, [&](long begin, long end) {
    for (long i = begin; i < end; ++i) {
      Eigen::Vector3d q;
      double d;
      const Eigen::Vector3d p = P.row(i).transpose();
      const int f = closest(p, &q, &d);
      out.face[i] = f;
      out.point.row(i) = q.transpose();
      out.distance[i] = d;
      Eigen::Vector3d b;
      closest_point_on_triangle(p, s.V.row(s.F(f, 0)), s.V.row(s.F(f, 1)), s.V.row(s.F(f, 2)), &b);
      out.bary.row(i) = b.transpose();
    }
  });
  return out;
}

}  // namespace posekit
