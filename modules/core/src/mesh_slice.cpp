#include "posekit/core/mesh_slice.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <numeric>
#include <thread>

#include "edge_key.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/parallel.h"

namespace posekit {
using core_detail::undirected_edge_key;

namespace {

/// One segment of a plane's section on the smooth surface: it joins the cut points of two mesh edges
/// (keys) and passes through `middle`, halfway across the face.
struct SmoothSegment {
  std::uint64_t key[2];
  Eigen::Vector3d point[2];
  Eigen::Vector3d middle;
};

/// Chains the segments of one plane (count of them; key(i, e) the cut edge at end e of segment i)
/// into loops through their shared edge keys; emit(i, e, pts) appends the points of segment i
/// entered at end e, last(i, e, pts) the point it leaves by at an open end.
template <typename Key, typename Emit, typename Last>
std::vector<SectionLoop> chain_loops(size_t count, const Key& key, const Emit& emit, const Last& last) {
  // partner[2 * seg + end] = the other (segment, end) at the same key, or -1 at an open end. Ends
  // meet through an open-addressing table keyed by the cut edge; at a key shared by more than two
  // ends, consecutive ones pair up.
  std::vector<int> partner(count * 2, -1);
  int bits = 4;
  while ((size_t(1) << bits) < 4 * count) ++bits;
  const size_t capacity = size_t(1) << bits;
  const int shift = 64 - bits;
  constexpr int kEmpty = -2, kPaired = -1;
  std::vector<std::uint64_t> slot_key(capacity);
  std::vector<int> slot_end(capacity, kEmpty);  // the unpaired end waiting at this key, or kPaired
  for (size_t i = 0; i < count; ++i)
    for (int e = 0; e < 2; ++e) {
      const std::uint64_t k = key(i, e);
      size_t slot = static_cast<size_t>((k * 0x9E3779B97F4A7C15ull) >> shift);
      while (slot_end[slot] != kEmpty && slot_key[slot] != k) slot = (slot + 1) & (capacity - 1);
      const int end = 2 * static_cast<int>(i) + e;
      if (slot_end[slot] >= 0) {
        partner[slot_end[slot]] = end;
        partner[end] = slot_end[slot];
        slot_end[slot] = kPaired;
      } else {
        slot_key[slot] = k;
        slot_end[slot] = end;
      }
    }
  std::vector<bool> used(count, false);
  std::vector<SectionLoop> loops;
  std::vector<Eigen::Vector3d> pts;
  auto walk = [&](int seg, int start_end) {
    // Leaves through the end opposite start_end, collecting the point at each entry end.
    pts.clear();
    bool closed = false;
    const int first = seg;
    int end_in = start_end;
    while (true) {
      used[seg] = true;
      emit(seg, end_in, pts);
      const int out = 2 * seg + (1 - end_in);
      const int next = partner[out];
      if (next < 0) {
        last(seg, 1 - end_in, pts);
        break;
      }
      if (next / 2 == first) {
        closed = true;
        break;
      }
      if (used[next / 2]) break;
      seg = next / 2;
      end_in = next % 2;
    }
    SectionLoop loop;
    loop.closed = closed;
    loop.points.resize(static_cast<Eigen::Index>(pts.size()), 3);
    for (size_t i = 0; i < pts.size(); ++i) loop.points.row(static_cast<Eigen::Index>(i)) = pts[i].transpose();
    loops.push_back(std::move(loop));
  };
  // Open chains start at a segment end without a partner, so each is walked whole.
  for (size_t i = 0; i < count; ++i)
    for (int e = 0; e < 2; ++e)
      if (!used[i] && partner[2 * i + e] < 0) walk(static_cast<int>(i), e);
  for (size_t i = 0; i < count; ++i)
    if (!used[i]) walk(static_cast<int>(i), 0);
  return loops;
}

/// The segment of face f on the smooth surface (N: unit vertex normals): its cut points and the
/// point halfway across the face moved onto the Phong surface; false if none.
bool cut_face_smooth(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N, Eigen::Index f, const double* s,
                     SmoothSegment& seg) {
  double face_w[3] = {0, 0, 0};
  int count = 0;
  for (int c = 0; c < 3 && count < 2; ++c) {
    const int a = F(f, c), b = F(f, (c + 1) % 3);
    const double sa = s[c], sb = s[(c + 1) % 3];
    if ((sa >= 0) == (sb >= 0)) continue;
    // From the smaller index, so both faces of the edge compute the same point.
    const double t = a < b ? sa / (sa - sb) : sb / (sb - sa);
    seg.key[count] = undirected_edge_key(a, b);
    seg.point[count] = phong_surface_point(V, N, Eigen::Vector3i(std::min(a, b), std::max(a, b), a), Eigen::Vector3d(1 - t, t, 0));
    face_w[c] += 0.5 * (a < b ? 1 - t : t);
    face_w[(c + 1) % 3] += 0.5 * (a < b ? t : 1 - t);
    ++count;
  }
  if (count < 2) return false;
  seg.middle = phong_surface_point(V, N, F.row(f).transpose(), Eigen::Vector3d(face_w[0], face_w[1], face_w[2]));
  return true;
}

/// Sections at many parallel planes in one pass over the faces (each face only visits the planes
/// its extent spans); on the smooth surface when N is given. On `threads` threads the faces are
/// split into contiguous ranges and each plane's segments keep the faces' order, so the loops are
/// the same to the last bit on any count.
std::vector<std::vector<SectionLoop>> slice_stack(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd* N,
                                                  const Eigen::Vector3d& normal, const std::vector<double>& offsets, int threads) {
  const double scale = normal.norm();
  const Eigen::Vector3d n = normal / scale;
  const Eigen::VectorXd h = V * n;
  std::vector<size_t> order(offsets.size());
  std::iota(order.begin(), order.end(), size_t(0));
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return offsets[a] < offsets[b]; });
  std::vector<double> level(offsets.size());
  for (size_t k = 0; k < order.size(); ++k) level[k] = offsets[order[k]] / scale;
  // A face meets the (sorted) planes first[f] .. last[f]-1, those with lo < level <= hi; each gives
  // exactly one segment, so the segments of all planes fit one array, plane after plane, and
  // within a plane range after range of faces.
  constexpr long kFacesPerRange = 16384;
  const long faces = static_cast<long>(F.rows());
  threads = resolve_threads(threads);
  const int ranges = static_cast<int>(std::clamp<long>(faces / kFacesPerRange, 1, threads));
  const long range_size = (faces + ranges - 1) / ranges;
  const auto for_each_range = [&](const std::function<void(long, long, int)>& body) {
    parallel_for_ranges(
        ranges, ranges,
        [&](long r0, long r1) {
          for (long r = r0; r < r1; ++r) body(r * range_size, std::min(faces, (r + 1) * range_size), static_cast<int>(r));
        },
        1);
  };
  std::vector<int> first(static_cast<size_t>(F.rows())), last(static_cast<size_t>(F.rows()));
  std::vector<std::vector<size_t>> fill(static_cast<size_t>(ranges), std::vector<size_t>(level.size() + 1, 0));
  for_each_range([&](long f0, long f1, int r) {
    std::vector<size_t>& count = fill[static_cast<size_t>(r)];
    for (long f = f0; f < f1; ++f) {
      const double h0 = h[F(f, 0)], h1 = h[F(f, 1)], h2 = h[F(f, 2)];
      const double lo = std::min({h0, h1, h2}), hi = std::max({h0, h1, h2});
      first[f] = static_cast<int>(std::upper_bound(level.begin(), level.end(), lo) - level.begin());
      last[f] = static_cast<int>(std::upper_bound(level.begin() + first[f], level.end(), hi) - level.begin());
      for (int k = first[f]; k < last[f]; ++k) ++count[k];
    }
  });
  // start[k]: plane k's first segment; fill[r][k]: where range r writes its next one on plane k.
  std::vector<size_t> start(level.size() + 1, 0);
  for (size_t k = 0; k < level.size(); ++k) {
    size_t at = start[k];
    for (auto& range_fill : fill) {
      const size_t count = range_fill[k];
      range_fill[k] = at;
      at += count;
    }
    start[k + 1] = at;
  }
  std::vector<std::vector<SectionLoop>> out(offsets.size());
  const auto for_each_plane = [&](const std::function<void(size_t)>& body) {
    parallel_for_ranges(
        static_cast<long>(level.size()), ranges,
        [&](long k0, long k1) {
          for (long k = k0; k < k1; ++k) body(static_cast<size_t>(k));
        },
        1);
  };
  if (N) {
    std::vector<SmoothSegment> segs(start.back());
    for_each_range([&](long f0, long f1, int r) {
      std::vector<size_t>& at = fill[static_cast<size_t>(r)];
      for (long f = f0; f < f1; ++f)
        for (int k = first[f]; k < last[f]; ++k) {
          const double s[3] = {h[F(f, 0)] - level[k], h[F(f, 1)] - level[k], h[F(f, 2)] - level[k]};
          cut_face_smooth(V, F, *N, f, s, segs[at[k]++]);
        }
    });
    for_each_plane([&](size_t k) {
      const SmoothSegment* seg = segs.data() + start[k];
      out[order[k]] = chain_loops(
          start[k + 1] - start[k], [&](size_t i, int e) { return seg[i].key[e]; },
          [&](size_t i, int e, std::vector<Eigen::Vector3d>& pts) { pts.push_back(seg[i].point[e]), pts.push_back(seg[i].middle); },
          [&](size_t i, int e, std::vector<Eigen::Vector3d>& pts) { pts.push_back(seg[i].point[e]); });
    });
    return out;
  }
  // A flat section keeps only the two cut edges of each segment (16 bytes: a 50k-vertex body cut
  // at 340 heights makes half a million); the points follow from the edges and the level.
  std::vector<std::array<std::uint64_t, 2>> segs(start.back());
  for_each_range([&](long f0, long f1, int r) {
    std::vector<size_t>& at = fill[static_cast<size_t>(r)];
    for (long f = f0; f < f1; ++f)
      for (int k = first[f]; k < last[f]; ++k) {
        const double s[3] = {h[F(f, 0)] - level[k], h[F(f, 1)] - level[k], h[F(f, 2)] - level[k]};
        std::array<std::uint64_t, 2>& seg = segs[at[k]++];
        int count = 0;
        for (int c = 0; c < 3 && count < 2; ++c)
          if ((s[c] >= 0) != (s[(c + 1) % 3] >= 0)) seg[static_cast<size_t>(count++)] = undirected_edge_key(F(f, c), F(f, (c + 1) % 3));
      }
  });
  for_each_plane([&](size_t k) {
    const std::array<std::uint64_t, 2>* seg = segs.data() + start[k];
    const double at = level[k];
    // The cut point of an edge, interpolated from its smaller index: the same on both of its faces.
    auto point = [&](std::uint64_t key) {
      const auto a = static_cast<Eigen::Index>(key >> 32), b = static_cast<Eigen::Index>(key & 0xffffffffu);
      const double t = (h[a] - at) / (h[a] - h[b]);
      return Eigen::Vector3d(V.row(a).transpose() + t * (V.row(b) - V.row(a)).transpose());
    };
    auto emit = [&](size_t i, int e, std::vector<Eigen::Vector3d>& pts) { pts.push_back(point(seg[i][static_cast<size_t>(e)])); };
    out[order[k]] = chain_loops(
        start[k + 1] - start[k], [&](size_t i, int e) { return seg[i][static_cast<size_t>(e)]; }, emit, emit);
  });
  return out;
}

}  // namespace

std::vector<SectionLoop> slice_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& normal, double offset) {
  return slice_stack(V, F, nullptr, normal, {offset}, 1).front();
}

std::vector<std::vector<SectionLoop>> slice_mesh_stack(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::Vector3d& normal,
                                                       const std::vector<double>& offsets, int threads) {
  return slice_stack(V, F, nullptr, normal, offsets, threads);
}

std::vector<SectionLoop> slice_smooth_mesh(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N,
                                           const Eigen::Vector3d& normal, double offset) {
  return slice_stack(V, F, &N, normal, {offset}, 1).front();
}

std::vector<std::vector<SectionLoop>> slice_smooth_mesh_stack(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N,
                                                              const Eigen::Vector3d& normal, const std::vector<double>& offsets) {
  return slice_stack(V, F, &N, normal, offsets, 1);
}

double polyline_length(const Eigen::MatrixXd& P, bool closed) {
  double len = 0;
  for (Eigen::Index i = 1; i < P.rows(); ++i) len += (P.row(i) - P.row(i - 1)).norm();
  if (closed && P.rows() > 2) len += (P.row(0) - P.row(P.rows() - 1)).norm();
  return len;
}

namespace {

/// Sorts `v` by merging its monotone runs: a section loop's points, taken in loop order, rise and
/// fall along any direction in a few long runs, so this costs about linear time where std::sort
/// costs n log n. The same order as std::sort wherever `less` is a strict total order on the values.
template <typename T, typename Less>
void sort_by_runs(std::vector<T>& v, const Less& less) {
  std::vector<size_t> bounds{0};
  for (size_t i = 0; i < v.size();) {
    size_t j = i + 1;
    if (j < v.size() && less(v[j], v[i])) {
      while (j < v.size() && less(v[j], v[j - 1])) ++j;
      std::reverse(v.begin() + static_cast<long>(i), v.begin() + static_cast<long>(j));  // strictly descending
    } else {
      while (j < v.size() && !less(v[j], v[j - 1])) ++j;
    }
    bounds.push_back(i = j);
  }
  if (bounds.size() > 32) {  // many short runs (a jagged loop): no gain from merging
    std::sort(v.begin(), v.end(), less);
    return;
  }
  std::vector<T> buffer(v.size());
  while (bounds.size() > 2) {
    std::vector<size_t> merged{0};
    for (size_t r = 0; r + 1 < bounds.size(); r += 2) {
      const size_t a = bounds[r], b = bounds[r + 1], c = r + 2 < bounds.size() ? bounds[r + 2] : b;
      std::merge(v.begin() + static_cast<long>(a), v.begin() + static_cast<long>(b), v.begin() + static_cast<long>(b),
                 v.begin() + static_cast<long>(c), buffer.begin() + static_cast<long>(a), less);
      merged.push_back(c);
    }
    v.swap(buffer);
    bounds = std::move(merged);
  }
}

}  // namespace

namespace {

/// The convex hull of points in a plane (normal n), in the plane's coordinates along u and w: its
/// corners in order, the first repeated at the end (Andrew's monotone chain).
std::vector<Eigen::Vector2d> plane_hull(const Eigen::MatrixXd& P, const Eigen::Vector3d& u, const Eigen::Vector3d& w) {
  std::vector<Eigen::Vector2d> q(static_cast<size_t>(P.rows()));
  for (Eigen::Index i = 0; i < P.rows(); ++i) q[i] = Eigen::Vector2d(P.row(i).dot(u), P.row(i).dot(w));
  sort_by_runs(q, [](const Eigen::Vector2d& a, const Eigen::Vector2d& b) { return a.x() != b.x() ? a.x() < b.x() : a.y() < b.y(); });
  auto cross = [](const Eigen::Vector2d& o, const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
    return (a - o).x() * (b - o).y() - (a - o).y() * (b - o).x();
  };
  std::vector<Eigen::Vector2d> hull(2 * q.size());
  size_t k = 0;
  for (size_t i = 0; i < q.size(); ++i) {
    while (k >= 2 && cross(hull[k - 2], hull[k - 1], q[i]) <= 0) --k;
    hull[k++] = q[i];
  }
  for (size_t i = q.size() - 1, t = k + 1; i-- > 0;) {
    while (k >= t && cross(hull[k - 2], hull[k - 1], q[i]) <= 0) --k;
    hull[k++] = q[i];
  }
  hull.resize(k);
  return hull;
}

}  // namespace

double convex_hull_perimeter(const Eigen::MatrixXd& P, const Eigen::Vector3d& normal) {
  if (P.rows() < 2) return 0.0;
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  const std::vector<Eigen::Vector2d> hull = plane_hull(P, u, w);
  double perimeter = 0;
  for (size_t i = 1; i < hull.size(); ++i) perimeter += (hull[i] - hull[i - 1]).norm();
  return perimeter;
}

Eigen::MatrixXd convex_hull_loop(const Eigen::MatrixXd& P, const Eigen::Vector3d& normal) {
  if (P.rows() < 2) return Eigen::MatrixXd(0, 3);
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  const std::vector<Eigen::Vector2d> hull = plane_hull(P, u, w);
  const double height = (P * n).mean();  // the section's plane
  Eigen::MatrixXd loop(static_cast<Eigen::Index>(hull.size()) - 1, 3);
  for (Eigen::Index i = 0; i < loop.rows(); ++i)
    loop.row(i) = (hull[static_cast<size_t>(i)].x() * u + hull[static_cast<size_t>(i)].y() * w + height * n).transpose();
  return loop;
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

double loop_distance(const SectionLoop& a, const SectionLoop& b) {
  if (a.points.rows() == 0 || b.points.rows() == 0) throw InvalidInput("loop_distance: an empty loop");
  // Nearest point of each loop's segments to each vertex of the other: the polylines' distance
  // (squared until the end: the square root keeps the order). The segments go in blocks of
  // kBlock consecutive ones with a bounding box; a block whose box is no nearer than the best so
  // far is passed over (a torso's loop beside an arm's: most of it is).
  constexpr Eigen::Index kBlock = 16;
  auto vertices_to_segments = [](const SectionLoop& from, const SectionLoop& to, double best) {
    const Eigen::Index n = to.points.rows(), segments = to.closed ? n : n - 1;
    if (segments <= 0) {
      for (Eigen::Index i = 0; i < from.points.rows(); ++i) best = std::min(best, (from.points.row(i) - to.points.row(0)).squaredNorm());
      return best;
    }
    std::vector<Eigen::AlignedBox3d> box(static_cast<size_t>((segments + kBlock - 1) / kBlock));
    for (Eigen::Index s = 0; s < segments; ++s) {
      Eigen::AlignedBox3d& b = box[static_cast<size_t>(s / kBlock)];
      b.extend(to.points.row(s).transpose());
      b.extend(to.points.row((s + 1) % n).transpose());
    }
    for (Eigen::Index i = 0; i < from.points.rows(); ++i) {
      const Eigen::Vector3d p = from.points.row(i).transpose();
      for (size_t k = 0; k < box.size(); ++k) {
        if (box[k].squaredExteriorDistance(p) >= best) continue;
        const Eigen::Index end = std::min(segments, static_cast<Eigen::Index>(k + 1) * kBlock);
        for (Eigen::Index s = static_cast<Eigen::Index>(k) * kBlock; s < end; ++s) {
          const Eigen::Vector3d q0 = to.points.row(s).transpose(), q1 = to.points.row((s + 1) % n).transpose();
          const Eigen::Vector3d d = q1 - q0;
          const double len2 = d.squaredNorm();
          const double t = len2 > 0 ? std::clamp((p - q0).dot(d) / len2, 0.0, 1.0) : 0.0;
          best = std::min(best, (p - q0 - t * d).squaredNorm());
        }
      }
    }
    return best;
  };
  const double a_to_b = vertices_to_segments(a, b, std::numeric_limits<double>::infinity());
  return std::sqrt(vertices_to_segments(b, a, a_to_b));
}

}  // namespace posekit
