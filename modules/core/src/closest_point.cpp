#include "posekit/core/closest_point.h"

#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/core/parallel.h"

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

}  // namespace

namespace {

/// Rows of P (#P x 3) in Morton (Z-curve) order of a 1024^3 grid over their box, by a radix sort:
/// points near each other in space come near each other in the order, so queries made in it start
/// from a tight bound and touch warm memory. `sorted_codes` (optional) receives their codes, ascending.
std::vector<int> morton_order(const Eigen::MatrixXd& P, std::vector<std::uint32_t>* sorted_codes = nullptr) {
  const Eigen::Index n = P.rows();
  std::vector<int> out(static_cast<size_t>(n));
  std::iota(out.begin(), out.end(), 0);
  if (n < 2) {
    if (sorted_codes) sorted_codes->assign(static_cast<size_t>(n), 0);
    return out;
  }
  const Eigen::RowVector3d lo = P.colwise().minCoeff(), span = (P.colwise().maxCoeff() - lo).cwiseMax(1e-300);
  std::vector<std::uint32_t> code(static_cast<size_t>(n)), code2(static_cast<size_t>(n));
  for (Eigen::Index i = 0; i < n; ++i) {
    std::uint32_t c = 0;
    for (int k = 0; k < 3; ++k) c |= spread_bits(static_cast<std::uint32_t>(std::min(1023.0, (P(i, k) - lo[k]) / span[k] * 1024.0))) << k;
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
  if (sorted_codes) *sorted_codes = std::move(code);
  return out;
}

}  // namespace

struct TriangleTree::Impl {
  struct Node {
    Eigen::Vector3d lo, hi;
    int left = -1, right = -1;  // children, or -1 for a leaf
    int begin = 0, end = 0;     // leaf range in `order`
  };
  std::vector<int> order;       // face of each leaf slot
  std::vector<int> slot_of;     // leaf slot of each face
  std::vector<double> corners;  // 9 per leaf slot: the triangle's corners, contiguous for the search
  std::vector<double> boxes;    // 6 per leaf slot: the triangle's box (lo, hi), a cheap lower bound
  std::vector<Node> nodes;

  /// Splits [begin, end) of `order` (faces along a Z-curve, `code` their Morton codes) where the
  /// highest bit in which the range's codes differ turns on, an octree's halving of space (Karras
  /// 2012); a range of up to kMedianSplit faces at the median of its centroids' longest axis, so that
  /// leaves hold 3 or 4. Boxes are set afterwards (set_boxes).
  int build(int begin, int end, const std::vector<std::uint32_t>& code, const Eigen::MatrixXd& centroid) {
    constexpr int kMedianSplit = 16;
    const int id = static_cast<int>(nodes.size());
    nodes.emplace_back();
    if (end - begin <= 4) {
      nodes[static_cast<size_t>(id)].begin = begin;
      nodes[static_cast<size_t>(id)].end = end;
      return id;
    }
    int mid = (begin + end) / 2;
    const std::uint32_t first = code[static_cast<size_t>(begin)], last = code[static_cast<size_t>(end - 1)];
    if (end - begin > kMedianSplit && first != last) {
      int bit = 31;
      while (!(((first ^ last) >> bit) & 1u)) --bit;
      const std::uint32_t split = ((first >> bit) | 1u) << bit;  // the common prefix, then bit set
      mid = static_cast<int>(std::lower_bound(code.begin() + begin, code.begin() + end, split) - code.begin());
    } else {
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      for (int i = begin; i < end; ++i) {
        lo = lo.cwiseMin(centroid.row(order[static_cast<size_t>(i)]).transpose());
        hi = hi.cwiseMax(centroid.row(order[static_cast<size_t>(i)]).transpose());
      }
      int axis;
      (hi - lo).maxCoeff(&axis);
      std::nth_element(order.begin() + begin, order.begin() + mid, order.begin() + end,
                       [&](int a, int b) { return centroid(a, axis) < centroid(b, axis); });
    }
    const int left = build(begin, mid, code, centroid);
    const int right = build(mid, end, code, centroid);
    nodes[static_cast<size_t>(id)].left = left;
    nodes[static_cast<size_t>(id)].right = right;
    return id;
  }

  /// Node boxes from the leaves' triangles up (a child's id is above its parent's).
  void set_boxes() {
    for (size_t id = nodes.size(); id-- > 0;) {
      Node& node = nodes[id];
      if (node.left >= 0) {
        node.lo = nodes[static_cast<size_t>(node.left)].lo.cwiseMin(nodes[static_cast<size_t>(node.right)].lo);
        node.hi = nodes[static_cast<size_t>(node.left)].hi.cwiseMax(nodes[static_cast<size_t>(node.right)].hi);
        continue;
      }
      node.lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
      node.hi = -node.lo;
      for (int i = node.begin; i < node.end; ++i) {
        node.lo = node.lo.cwiseMin(Eigen::Map<const Eigen::Vector3d>(&boxes[static_cast<size_t>(6 * i)]));
        node.hi = node.hi.cwiseMax(Eigen::Map<const Eigen::Vector3d>(&boxes[static_cast<size_t>(6 * i + 3)]));
      }
    }
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

TriangleTree::TriangleTree(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) : impl_(std::make_unique<Impl>()) {
  if (F.rows() == 0) throw InvalidInput("TriangleTree: the mesh has no triangles");
  if (F.minCoeff() < 0 || F.maxCoeff() >= V.rows())
    throw InvalidInput("TriangleTree: a triangle index is outside the " + std::to_string(V.rows()) + " vertices");
  Impl& s = *impl_;
  Eigen::MatrixXd centroid(F.rows(), 3);
  for (Eigen::Index f = 0; f < F.rows(); ++f) centroid.row(f) = (V.row(F(f, 0)) + V.row(F(f, 1)) + V.row(F(f, 2))) / 3;
  std::vector<std::uint32_t> code;
  s.order = morton_order(centroid, &code);
  s.nodes.reserve(s.order.size() / 2 + 16);
  s.build(0, static_cast<int>(F.rows()), code, centroid);
  s.corners.resize(9 * s.order.size());
  s.boxes.resize(6 * s.order.size());
  for (size_t i = 0; i < s.order.size(); ++i) {
    const int f = s.order[i];
    const Eigen::Vector3d a = V.row(F(f, 0)).transpose(), b = V.row(F(f, 1)).transpose(), c = V.row(F(f, 2)).transpose();
    Eigen::Map<Eigen::Matrix<double, 3, 3>>(&s.corners[9 * i]) << a, b, c;
    Eigen::Map<Eigen::Vector3d>(&s.boxes[6 * i]) = a.cwiseMin(b).cwiseMin(c);
    Eigen::Map<Eigen::Vector3d>(&s.boxes[6 * i + 3]) = a.cwiseMax(b).cwiseMax(c);
  }
  s.set_boxes();
  s.slot_of.resize(s.order.size());
  for (size_t i = 0; i < s.order.size(); ++i) s.slot_of[static_cast<size_t>(s.order[i])] = static_cast<int>(i);
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

ClosestPoints TriangleTree::closest(const Eigen::MatrixXd& P, int threads, const Eigen::VectorXi* start_faces) const {
  ClosestPoints out;
  out.face.resize(P.rows());
  out.point.resize(P.rows(), 3);
  out.bary.resize(P.rows(), 3);
  out.distance.resize(P.rows());
  for_each_closest(
      P, threads,
      [&](Eigen::Index i, const ClosestHit& h) {
        out.face[i] = h.face;
        out.point.row(i) = h.point.transpose();
        out.distance[i] = h.distance;
        out.bary.row(i) = h.bary.transpose();
      },
      start_faces);
  return out;
}

void TriangleTree::for_each_closest(const Eigen::MatrixXd& P, int threads,
                                    const std::function<void(Eigen::Index, const ClosestHit&)>& visit,
                                    const Eigen::VectorXi* start_faces) const {
  const Impl& s = *impl_;
  if (start_faces && start_faces->size() != P.rows())
    throw InvalidInput("TriangleTree::closest: " + std::to_string(start_faces->size()) + " start faces for " + std::to_string(P.rows()) +
                       " points");
  const std::vector<int> order = morton_order(P);
  parallel_for_ranges(P.rows(), threads, [&](long begin, long end) {
    // Queries go in blocks: the block's points are gathered into a contiguous copy and the results
    // handed out afterwards, so that the search loop itself never waits on a far-away row.
    constexpr long kBlock = 2048;
    std::vector<Eigen::Vector3d> points(static_cast<size_t>(kBlock));
    std::vector<ClosestHit> results(static_cast<size_t>(kBlock));
    int previous = -1;
    for (long block = begin; block < end; block += kBlock) {
      const long count = std::min(kBlock, end - block);
      for (long k = 0; k < count; ++k) points[static_cast<size_t>(k)] = P.row(order[static_cast<size_t>(block + k)]).transpose();
      for (long k = 0; k < count; ++k) {
        const Eigen::Vector3d& p = points[static_cast<size_t>(k)];
        // The previous (nearby) query's triangle bounds the search from the start, or the given
        // face's when that is nearer.
        Impl::Hit best = s.hit_of(p, previous);
        if (start_faces) {
          const int f = (*start_faces)[order[static_cast<size_t>(block + k)]];
          if (f >= 0 && f < static_cast<int>(s.slot_of.size()) && s.slot_of[static_cast<size_t>(f)] != previous) {
            const Impl::Hit hint = s.hit_of(p, s.slot_of[static_cast<size_t>(f)]);
            if (hint.sq_distance < best.sq_distance) best = hint;
          }
        }
        s.search(p, best);
        previous = best.slot;
        results[static_cast<size_t>(k)] = {s.order[static_cast<size_t>(best.slot)], best.point, best.bary, std::sqrt(best.sq_distance)};
      }
      for (long k = 0; k < count; ++k) visit(order[static_cast<size_t>(block + k)], results[static_cast<size_t>(k)]);
    }
  });
}

}  // namespace posekit
