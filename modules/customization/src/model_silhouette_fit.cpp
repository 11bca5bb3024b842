#include "posekit/customization/model_silhouette_fit.h"

#include <Eigen/Cholesky>
#include <Eigen/Sparse>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <iomanip>
#include <limits>
#include <sstream>
#include <unordered_map>

#include "customization_detail.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/parallel.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/fitting/body_model.h"
#include "posekit/io/image_io.h"
#include "posekit/population/survey_plausibility.h"
#include "posekit/shape/measurements.h"

namespace posekit {
namespace {

/// Squared Euclidean distance transform of one line (Felzenszwalb and Huttenlocher 2012): d[i] =
/// min_j (i - j)^2 + f[j].
void squared_distance_1d(const float* f, int n, long stride, float* d, std::vector<int>& v, std::vector<float>& z) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  int k = 0;
  v[0] = 0, z[0] = -kInf, z[1] = kInf;
  for (int q = 1; q < n; ++q) {
    const float fq = f[q * stride];
    if (fq == kInf) continue;
    if (f[v[static_cast<size_t>(k)] * stride] == kInf) {
      v[static_cast<size_t>(k)] = q;
      continue;
    }
    float s;
    while (true) {
      const int p = v[static_cast<size_t>(k)];
      s = ((fq + static_cast<float>(q) * q) - (f[p * stride] + static_cast<float>(p) * p)) / (2.0f * static_cast<float>(q - p));
      if (s > z[static_cast<size_t>(k)] || k == 0) break;
      --k;
    }
    if (s <= z[static_cast<size_t>(k)]) {  // k == 0 and the new parabola wins everywhere
      v[0] = q, z[1] = kInf;
      continue;
    }
    ++k;
    v[static_cast<size_t>(k)] = q, z[static_cast<size_t>(k)] = s, z[static_cast<size_t>(k) + 1] = kInf;
  }
  k = 0;
  for (int q = 0; q < n; ++q) {
    while (z[static_cast<size_t>(k) + 1] < static_cast<float>(q)) ++k;
    const int p = v[static_cast<size_t>(k)];
    const float fp = f[p * stride];
    d[q * stride] = fp == kInf ? kInf : static_cast<float>(q - p) * static_cast<float>(q - p) + fp;
  }
}

/// Distance (pixels) from each pixel centre to the nearest pixel centre where `seed` holds.
std::vector<float> distance_to(const std::vector<std::uint8_t>& seed, int w, int h) {
  constexpr float kInf = std::numeric_limits<float>::infinity();
  std::vector<float> f(seed.size()), d(seed.size());
  for (size_t i = 0; i < seed.size(); ++i) f[i] = seed[i] ? 0.0f : kInf;
  std::vector<int> v(static_cast<size_t>(std::max(w, h)));
  std::vector<float> z(static_cast<size_t>(std::max(w, h)) + 1);
  for (int x = 0; x < w; ++x) squared_distance_1d(f.data() + x, h, w, d.data() + x, v, z);
  for (int y = 0; y < h; ++y) squared_distance_1d(d.data() + static_cast<long>(y) * w, w, 1, f.data() + static_cast<long>(y) * w, v, z);
  for (float& x : f) x = std::sqrt(x);
  return f;
}

/// A silhouette at working resolution and its signed distance field (pixels, negative inside; the
/// edge half a pixel from the centres on either side).
struct Field {
  int width = 0, height = 0;
  std::vector<std::uint8_t> mask;
  std::vector<float> sdf;

  float at(int u, int v) const { return sdf[static_cast<size_t>(std::clamp(v, 0, height - 1)) * width + std::clamp(u, 0, width - 1)]; }
  /// Bilinear, at continuous pixel coordinates (pixel u's centre at u + 0.5); beyond the frame the
  /// distance grows with the distance from it.
  double value(double x, double y) const {
    const double fx = x - 0.5, fy = y - 0.5;
    const double cx = std::clamp(fx, 0.0, width - 1.0), cy = std::clamp(fy, 0.0, height - 1.0);
    const int u = std::min(static_cast<int>(cx), width - 2), v = std::min(static_cast<int>(cy), height - 2);
    const double a = cx - u, b = cy - v;
    const double s = (1 - a) * (1 - b) * at(u, v) + a * (1 - b) * at(u + 1, v) + (1 - a) * b * at(u, v + 1) + a * b * at(u + 1, v + 1);
    return s + std::hypot(fx - cx, fy - cy);
  }
  Eigen::Vector2d gradient(double x, double y) const {
    return Eigen::Vector2d(value(x + 0.5, y) - value(x - 0.5, y), value(x, y + 0.5) - value(x, y - 0.5));
  }
};

Field make_field(std::vector<std::uint8_t> mask, int w, int h) {
  // The edge is the midpoints between each person pixel's centre and its non-person 4-neighbours':
  // at half-pixel spacing, the distance to them is unbiased for edges of every slope (to the nearest
  // centre less half a pixel, a diagonal edge sits 0.2-0.3 px outwards).
  Field f;
  f.width = w, f.height = h, f.mask = std::move(mask);
  const int W = 2 * w + 1, H = 2 * h + 1;
  std::vector<std::uint8_t> seed(static_cast<size_t>(W) * H, 0);
  auto in = [&](int u, int v) { return u >= 0 && v >= 0 && u < w && v < h && f.mask[static_cast<size_t>(v) * w + u]; };
  for (int v = -1; v < h; ++v)
    for (int u = -1; u < w; ++u) {
      if (v >= 0 && in(u, v) != in(u + 1, v)) seed[static_cast<size_t>(2 * v + 1) * W + 2 * u + 2] = 1;
      if (u >= 0 && in(u, v) != in(u, v + 1)) seed[static_cast<size_t>(2 * v + 2) * W + 2 * u + 1] = 1;
    }
  const std::vector<float> half = distance_to(seed, W, H);
  f.sdf.resize(f.mask.size());
  for (int v = 0; v < h; ++v)
    for (int u = 0; u < w; ++u) {
      const float d = 0.5f * half[static_cast<size_t>(2 * v + 1) * W + 2 * u + 1];
      f.sdf[static_cast<size_t>(v) * w + u] = f.mask[static_cast<size_t>(v) * w + u] ? -d : d;
    }
  return f;
}

/// The silhouette reduced by `k` (a working pixel is the person when half its k x k block is).
Field reduced_field(const Silhouette& s, int k) {
  const int w = s.width / k, h = s.height / k;
  std::vector<std::uint8_t> m(static_cast<size_t>(w) * h);
  std::vector<int> count(static_cast<size_t>(w));
  for (int v = 0; v < h; ++v) {
    std::fill(count.begin(), count.end(), 0);
    for (int dv = 0; dv < k; ++dv) {
      const std::uint8_t* row = s.mask.data() + static_cast<size_t>(v * k + dv) * s.width;
      for (int u = 0; u < w; ++u)
        for (int du = 0; du < k; ++du) count[static_cast<size_t>(u)] += row[u * k + du] != 0;
    }
    for (int u = 0; u < w; ++u) m[static_cast<size_t>(v) * w + u] = 2 * count[static_cast<size_t>(u)] >= k * k;
  }
  return make_field(std::move(m), w, h);
}

PinholeCamera reduced_camera(const PinholeCamera& c, int k) {
  PinholeCamera r = c;
  r.width = c.width / k, r.height = c.height / k;
  r.fx /= k, r.fy /= k, r.cx /= k, r.cy /= k;
  return r;
}

/// Pixel coordinates of x and their derivative by x.
Eigen::Vector2d project_with_jacobian(const PinholeCamera& c, const Eigen::Vector3d& x, Eigen::Matrix<double, 2, 3>* J) {
  const Eigen::Vector3d p = c.R * x + c.t;
  const double iz = 1.0 / p.z();
  Eigen::Matrix<double, 2, 3> d;
  d << c.fx * iz, 0, -c.fx * p.x() * iz * iz, 0, c.fy * iz, -c.fy * p.y() * iz * iz;
  *J = d * c.R;
  return Eigen::Vector2d(c.fx * p.x() * iz + c.cx, c.fy * p.y() * iz + c.cy);
}

/// The point nearest both rays (least squares), for the body's place from two views.
Eigen::Vector3d nearest_to_rays(const Eigen::Vector3d& o1, const Eigen::Vector3d& d1, const Eigen::Vector3d& o2,
                                const Eigen::Vector3d& d2) {
  Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
  Eigen::Vector3d b = Eigen::Vector3d::Zero();
  for (const auto& [o, d] : {std::pair{o1, d1}, std::pair{o2, d2}}) {
    const Eigen::Matrix3d P = Eigen::Matrix3d::Identity() - d * d.transpose();
    A += P, b += P * o;
  }
  return A.ldlt().solve(b);
}

// The pose increments fitted (apply_pose_increment's unknowns): root translation and rotation, the
// spine, neck, shoulders, elbows, hips and knees. Wrists and ankles stay: the outline barely shows them.
std::vector<int> fitted_pose_unknowns() {
  std::vector<int> out = {0, 1, 2, 3, 4, 5};
  for (const char* name : {"lower_back", "upper_back", "neck", "left_shoulder", "left_elbow", "right_shoulder", "right_elbow", "left_hip",
                           "left_knee", "right_hip", "right_knee"}) {
    const int j = find_joint_index(name);
    for (int a = 0; a < 3; ++a) out.push_back(6 + 3 * j + a);
  }
  return out;
}

struct View {
  const PinholeCamera* full = nullptr;
  PinholeCamera camera;
  Field silhouette;
  std::vector<Eigen::Vector2d> edge, edge_normal;  ///< the silhouette's edge pixels (centres) and outward normals
  double metres_per_px = 0;                        ///< at the body's distance
};

std::vector<View> make_views(const Silhouette* sil[2], const PinholeCamera* cams[2], int rows, const Eigen::Vector3d& body_centre,
                             int threads) {
  std::vector<View> views(2);
  auto make_view = [&](int k) {
    View& w = views[static_cast<size_t>(k)];
    const int factor = std::max(1, static_cast<int>(std::lround(static_cast<double>(sil[k]->height) / rows)));
    w.full = cams[k];
    w.camera = reduced_camera(*cams[k], factor);
    w.silhouette = reduced_field(*sil[k], factor);
    w.metres_per_px = depth_of(w.camera, body_centre) / w.camera.fy;
    const Field& f = w.silhouette;
    for (int v = 0; v < f.height; ++v)
      for (int u = 0; u < f.width; ++u) {
        if (!f.mask[static_cast<size_t>(v) * f.width + u]) continue;
        const bool edge = u == 0 || v == 0 || u == f.width - 1 || v == f.height - 1 || !f.mask[static_cast<size_t>(v) * f.width + u - 1] ||
                          !f.mask[static_cast<size_t>(v) * f.width + u + 1] || !f.mask[static_cast<size_t>(v - 1) * f.width + u] ||
                          !f.mask[static_cast<size_t>(v + 1) * f.width + u];
        if (!edge) continue;
        const Eigen::Vector2d p(u + 0.5, v + 0.5), g = f.gradient(p.x(), p.y());
        if (g.norm() < 0.1) continue;
        w.edge.push_back(p);
        w.edge_normal.push_back(g.normalized());
      }
  };
  run_beside(
      threads, [&] { make_view(1); }, [&] { make_view(0); });  // the views are independent
  return views;
}

/// The model's contour generators in a view (vertices whose normal is across the line of sight) that
/// project onto the edge of the rendered body or lie hidden behind another part; which are on the
/// edge; and for those, the rendered body's signed distance (pixels) at their projection: a vertex of
/// the band beside the rim projects up to a pixel inside the body's outline, and its residual must
/// measure the outline, not the vertex (else the fit swells the body by that much).
std::vector<int> contour_vertices(const TriangleMesh& posed, const Eigen::MatrixXd& normals, const PinholeCamera& cam,
                                  std::vector<std::uint8_t>* on_outline, std::vector<double>* outline_distance, RenderBuffers* rendered) {
  *rendered = render_mesh(posed, cam);
  const RenderBuffers& r = *rendered;
  auto covered = [&](int u, int v) {
    return u >= 0 && v >= 0 && u < r.width && v < r.height && r.face[static_cast<size_t>(v) * r.width + u] >= 0;
  };
  const Eigen::Vector3d eye = cam.centre();
  std::vector<int> out;
  for (int i = 0; i < posed.V.rows(); ++i) {
    const Eigen::Vector3d x = posed.V.row(i).transpose();
    const Eigen::Vector3d ray = (x - eye).normalized();
    if (std::abs(ray.dot(normals.row(i).transpose())) > 0.35) continue;
    const Eigen::Vector2d p = project(cam, x);
    const int u = static_cast<int>(std::floor(p.x())), v = static_cast<int>(std::floor(p.y()));
    int in = 0, out_n = 0;
    for (int dv = -1; dv <= 1; ++dv)
      for (int du = -1; du <= 1; ++du) (covered(u + du, v + dv) ? in : out_n)++;
    // Kept: on the outline, or hidden behind another part (the belly behind a forearm in the side
    // view), which only the silhouette's own edges can pull. A generator inside its own outline
    // (the visible band beside the rim) is not one: pulled to the edge it would swell the body.
    const bool outline = in && out_n;
    const bool hidden = covered(u, v) && r.depth[static_cast<size_t>(v) * r.width + u] < depth_of(cam, x) - 0.02;
    if (!outline && !hidden) continue;
    double distance = 0;
    if (outline) {  // to the nearest pixel centre of the other kind, less half a pixel
      const bool inside = covered(u, v);
      double best = 9;
      for (int dv = -2; dv <= 2; ++dv)
        for (int du = -2; du <= 2; ++du)
          if (covered(u + du, v + dv) != inside) best = std::min(best, (Eigen::Vector2d(u + du + 0.5, v + dv + 0.5) - p).norm());
      distance = (inside ? -1 : 1) * (best - 0.5);
    }
    out.push_back(i);
    on_outline->push_back(outline);
    outline_distance->push_back(distance);
  }
  return out;
}

/// Nearest projected contour vertex to a pixel, within `radius` (a uniform grid of the projections).
class ProjectionGrid {
 public:
  ProjectionGrid(const std::vector<Eigen::Vector2d>& points, double cell) : points_(points), cell_(cell) {
    for (size_t i = 0; i < points.size(); ++i) cells_[key(points[i])].push_back(static_cast<int>(i));
  }
  int nearest(const Eigen::Vector2d& q, double radius) const {
    // Rings of cells outwards, until the ring's nearest possible point is farther than the best.
    const int rings = static_cast<int>(std::ceil(radius / cell_));
    const auto [cx, cy] = cell_of(q);
    int best = -1;
    double best_d = radius * radius;
    for (int ring = 0; ring <= rings; ++ring) {
      const double reach = (ring - 1) * cell_;
      if (ring > 1 && reach * reach > best_d) break;
      for (int dy = -ring; dy <= ring; ++dy)
        for (int dx = -ring; dx <= ring; ++dx) {
          if (std::max(std::abs(dx), std::abs(dy)) != ring) continue;
          const auto it = cells_.find(pack(cx + dx, cy + dy));
          if (it == cells_.end()) continue;
          for (int i : it->second) {
            const double d = (points_[static_cast<size_t>(i)] - q).squaredNorm();
            if (d < best_d) best_d = d, best = i;
          }
        }
    }
    return best;
  }

 private:
  std::pair<int, int> cell_of(const Eigen::Vector2d& p) const {
    return {static_cast<int>(std::floor(p.x() / cell_)), static_cast<int>(std::floor(p.y() / cell_))};
  }
  static long long pack(int x, int y) { return (static_cast<long long>(x) << 32) ^ static_cast<unsigned>(y); }
  long long key(const Eigen::Vector2d& p) const {
    const auto [x, y] = cell_of(p);
    return pack(x, y);
  }
  const std::vector<Eigen::Vector2d>& points_;
  double cell_;
  std::unordered_map<long long, std::vector<int>> cells_;
};

/// The outline pairs of one view: each model contour vertex with the silhouette's signed distance
/// at its projection, and each silhouette edge pixel with its nearest contour vertex along the edge's
/// normal. A residual is `direction . (projection - ...)` in working pixels; `share` weighs it so
/// that each of the two kinds counts a quarter of the two views' data.
struct OutlinePair {
  int rim = 0;                ///< index into ViewOutline::rim
  Eigen::Vector2d direction;  ///< unit, in the image
  double residual_px = 0;
  double share = 0;
};
struct ViewOutline {
  std::vector<int> rim;                            ///< contour generators
  std::vector<std::uint8_t> on_outline;            ///< ... seen on the body's outline
  std::vector<double> outline_distance;            ///< ... the rendered outline's signed distance there (px)
  std::vector<Eigen::Matrix<double, 2, 3>> dproj;  ///< their projection's derivative by position
  std::vector<OutlinePair> pairs;
};

ViewOutline outline_pairs(const View& w, const TriangleMesh& posed, const Eigen::MatrixXd& normals, const char* view) {
  ViewOutline out;
  RenderBuffers rendered;
  out.rim = contour_vertices(posed, normals, w.camera, &out.on_outline, &out.outline_distance, &rendered);
  if (std::count(out.on_outline.begin(), out.on_outline.end(), 1) < 50)
    throw InvalidInput(std::string("model fit to the photos: the body left the ") + view + " photo");
  const int R = static_cast<int>(out.rim.size());
  std::vector<Eigen::Vector2d> proj(static_cast<size_t>(R));
  out.dproj.resize(static_cast<size_t>(R));
  for (int r = 0; r < R; ++r)
    proj[static_cast<size_t>(r)] =
        project_with_jacobian(w.camera, posed.V.row(out.rim[static_cast<size_t>(r)]).transpose(), &out.dproj[static_cast<size_t>(r)]);
  int seen = 0;
  for (int r = 0; r < R; ++r) seen += out.on_outline[static_cast<size_t>(r)];
  for (int r = 0; r < R; ++r) {
    if (!out.on_outline[static_cast<size_t>(r)]) continue;
    const Eigen::Vector2d& p = proj[static_cast<size_t>(r)];
    const Eigen::Vector2d grad = w.silhouette.gradient(p.x(), p.y());
    if (grad.norm() < 0.1) continue;
    out.pairs.push_back(
        {r, grad.normalized(), w.silhouette.value(p.x(), p.y()) - out.outline_distance[static_cast<size_t>(r)], 0.25 / seen});
  }
  const ProjectionGrid grid(proj, 8);
  const double reach = 0.25 / w.metres_per_px;  // 25 cm at the body
  const auto E = static_cast<double>(w.edge.size());
  for (size_t e = 0; e < w.edge.size(); ++e) {
    const int r = grid.nearest(w.edge[e], reach);
    if (r < 0) continue;
    const Eigen::Vector2d& n = w.edge_normal[e];
    out.pairs.push_back({r, n, n.dot(proj[static_cast<size_t>(r)] - w.edge[e]) - out.outline_distance[static_cast<size_t>(r)], 0.25 / E});
  }
  // The silhouette's pixels the body leaves uncovered (a gap between arm and belly the person does
  // not have) draw the nearest contour generator in, each weighing as an edge pixel.
  const Field& f = w.silhouette;
  for (int v = 0; v < f.height; ++v)
    for (int u = 0; u < f.width; ++u) {
      const size_t i = static_cast<size_t>(v) * f.width + u;
      if (!f.mask[i] || rendered.face[i] >= 0 || f.sdf[i] > -1.0f) continue;  // not on the edge: the edge terms have those
      const Eigen::Vector2d q(u + 0.5, v + 0.5);
      const int r = grid.nearest(q, reach);
      if (r < 0) continue;
      const Eigen::Vector2d to = proj[static_cast<size_t>(r)] - q;
      const double length = to.norm();
      if (length < 1e-9) continue;
      out.pairs.push_back({r, to / length, length + out.outline_distance[static_cast<size_t>(r)], 0.25 / E});
    }
  return out;
}

/// Cauchy weight of a residual (pixels) at `scale` pixels.
double cauchy(double r, double scale) { return 1 / (1 + (r / scale) * (r / scale)); }

/// The uniform graph Laplacian of the mesh's vertices (I - D^-1 A).
Eigen::SparseMatrix<double> uniform_laplacian(const Eigen::MatrixXi& F, int n) {
  std::vector<std::vector<int>> nb(static_cast<size_t>(n));
  for (int f = 0; f < F.rows(); ++f)
    for (int a = 0; a < 3; ++a) {
      const int i = F(f, a), j = F(f, (a + 1) % 3);
      nb[static_cast<size_t>(i)].push_back(j), nb[static_cast<size_t>(j)].push_back(i);
    }
  std::vector<Eigen::Triplet<double>> t;
  for (int i = 0; i < n; ++i) {
    auto& v = nb[static_cast<size_t>(i)];
    std::sort(v.begin(), v.end());
    v.erase(std::unique(v.begin(), v.end()), v.end());
    t.emplace_back(i, i, 1.0);
    for (int j : v) t.emplace_back(i, j, -1.0 / static_cast<double>(v.size()));
  }
  Eigen::SparseMatrix<double> L(n, n);
  L.setFromTriplets(t.begin(), t.end());
  return L;
}

const char* const kViewNames[2] = {"front", "side"};

/// Where the fit starts: the mean body, its soles on the floor below the silhouettes' centre (the two
/// views' centre rays triangulated), scaled through the shape's stature direction to the front
/// silhouette's height there. Returns that centre.
Eigen::Vector3d start_on_the_floor(const ShapeSpace& space, const Silhouette* sil[2], const PinholeCamera* cams[2], Eigen::VectorXd* c,
                                   PartPose* pose) {
  double top[2], bottom[2];
  Eigen::Vector3d ray[2];
  for (int k = 0; k < 2; ++k) {
    top[k] = sil[k]->top(), bottom[k] = sil[k]->bottom() + 1.0;
    ray[k] = cams[k]->ray(0.5 * (sil[k]->left() + sil[k]->right() + 1), 0.5 * (top[k] + bottom[k]));
  }
  const Eigen::Vector3d centre = nearest_to_rays(cams[0]->centre(), ray[0], cams[1]->centre(), ray[1]);
  const double depth = depth_of(*cams[0], centre), u_mid = 0.5 * (sil[0]->left() + sil[0]->right() + 1);
  const double floor_y = point_at_depth(*cams[0], u_mid, bottom[0], depth).y(),
               crown_y = point_at_depth(*cams[0], u_mid, top[0], depth).y();
  const Eigen::MatrixXd& M = space.mean;
  Eigen::Index hi, lo;
  M.col(1).maxCoeff(&hi), M.col(1).minCoeff(&lo);
  const Eigen::VectorXd stature = space.basis.row(3 * hi + 1) - space.basis.row(3 * lo + 1);
  *c = Eigen::VectorXd::Zero(space.components());
  if (stature.squaredNorm() > 0) *c = stature * (((crown_y - floor_y) - (M(hi, 1) - M(lo, 1))) / stature.squaredNorm());
  const Eigen::MatrixXd V = space.body(*c);
  const Eigen::RowVector3d low = V.colwise().minCoeff(), high = V.colwise().maxCoeff();
  *pose = PartPose();
  pose->root_translation =
      Eigen::Vector3d(centre.x() - 0.5 * (low.x() + high.x()), floor_y - low.y(), centre.z() - 0.5 * (low.z() + high.z()));
  return centre;
}

/// One view's share of the Gauss-Newton normal equations over [shape K, pose P] (H: lower half),
/// and its outline RMS (mm). Each contour vertex's derivative: shape through the vertex's skinning
/// rotation (the skinning is affine in the rest vertex), pose by differences.
void view_normal_equations(const BodyModel& model, const ShapedBody& body, const PartPose& pose, const std::vector<int>& pose_unknowns,
                           const View& w, const TriangleMesh& posed, const Eigen::MatrixXd& normals, const char* name,
                           double robust_distance, Eigen::MatrixXd* H, Eigen::VectorXd* g, double* rms_mm) {
  const int K = model.components(), P = static_cast<int>(pose_unknowns.size()), N = K + P;
  const ViewOutline outline = outline_pairs(w, posed, normals, name);
  const std::vector<int>& rim = outline.rim;
  const PartTransforms T = body.part_motions(pose);
  Eigen::MatrixXd X0, Xu[3];
  ShapedBody::skin(model, body.rest_vertices(), T, rim, &X0);
  Eigen::MatrixXd shifted = body.rest_vertices();
  for (int a = 0; a < 3; ++a) {
    shifted.col(a).array() += 1.0;
    ShapedBody::skin(model, shifted, T, rim, &Xu[a]);
    shifted.col(a).array() -= 1.0;
  }
  std::vector<Eigen::MatrixXd> dpose(static_cast<size_t>(P));
  constexpr double kStep = 1e-4;
  for (int q = 0; q < P; ++q) {
    Eigen::VectorXd inc = Eigen::VectorXd::Zero(kPoseIncrementSize);
    inc(pose_unknowns[static_cast<size_t>(q)]) = kStep;
    PartPose moved = pose;
    apply_pose_increment(&moved, inc);
    ShapedBody::skin(model, body.rest_vertices(), body.part_motions(moved), rim, &dpose[static_cast<size_t>(q)]);
    dpose[static_cast<size_t>(q)] = (dpose[static_cast<size_t>(q)] - X0) / kStep;
  }
  std::vector<Eigen::MatrixXd> jac(rim.size());  // 2 x N: pixel by unknown
  for (size_t r = 0; r < rim.size(); ++r) {
    const auto row = static_cast<Eigen::Index>(r);
    Eigen::Matrix3d rot;
    for (int a = 0; a < 3; ++a) rot.col(a) = (Xu[a].row(row) - X0.row(row)).transpose();
    const Eigen::Matrix<double, 2, 3>& dp = outline.dproj[r];
    Eigen::MatrixXd J(2, N);
    J.leftCols(K) = dp * rot * model.space().basis.middleRows(3 * rim[r], 3);
    for (int q = 0; q < P; ++q) J.col(K + q) = dp * dpose[static_cast<size_t>(q)].row(row).transpose();
    jac[r] = std::move(J);
  }
  // Residuals in metres at the body: comparable across views and resolutions.
  const double m = w.metres_per_px, scale = robust_distance / m;
  double sum = 0;
  Eigen::MatrixXd A(static_cast<Eigen::Index>(outline.pairs.size()), N);  // rows scaled by the root of their weight
  Eigen::VectorXd b(A.rows());
  for (size_t i = 0; i < outline.pairs.size(); ++i) {
    const OutlinePair& pair = outline.pairs[i];
    const double weight = pair.share * cauchy(pair.residual_px, scale) * m * m, root = std::sqrt(weight);
    A.row(static_cast<Eigen::Index>(i)) = root * (pair.direction.transpose() * jac[static_cast<size_t>(pair.rim)]);
    b(static_cast<Eigen::Index>(i)) = root * pair.residual_px;
    sum += weight * pair.residual_px * pair.residual_px;
  }
  *H = Eigen::MatrixXd::Zero(N, N);
  H->selfadjointView<Eigen::Lower>().rankUpdate(A.transpose());
  *g = A.transpose() * b;
  *rms_mm = 1000 * std::sqrt(2 * sum);
}

/// The priors' terms: the shape's Gaussian, and the joints' rotations away from the rest (about the
/// parent's axes; a joint's world increment turns it by the parent's rotation transposed).
void add_priors(const Eigen::VectorXd& c, const PartPose& pose, const std::vector<int>& pose_unknowns, const SilhouetteFitOptions& o,
                Eigen::MatrixXd* H, Eigen::VectorXd* g) {
  const auto K = c.size();
  const double ls = o.shape_prior * o.shape_prior, lp = o.pose_prior * o.pose_prior;
  H->topLeftCorner(K, K).diagonal().array() += ls;
  g->head(K) += ls * c;
  const auto world = part_rotations(pose);
  for (size_t q = 6; q < pose_unknowns.size(); q += 3) {
    const int j = (pose_unknowns[q] - 6) / 3;
    const Eigen::Matrix3d A = world[static_cast<size_t>(part_parent(j + 1))].transpose();
    H->block(K + static_cast<Eigen::Index>(q), K + static_cast<Eigen::Index>(q), 3, 3) += lp * A.transpose() * A;
    g->segment(K + static_cast<Eigen::Index>(q), 3) += lp * A.transpose() * pose.joint(j);
  }
}

/// Shape and pose by Gauss-Newton, coarse to fine; returns the finest views.
std::vector<View> fit_shape_and_pose(const BodyModel& model, const Silhouette* sil[2], const PinholeCamera* cams[2],
                                     const Eigen::Vector3d& centre, const SilhouetteFitOptions& o, bool trace, Eigen::VectorXd* c,
                                     PartPose* pose, SilhouetteFit* fit) {
  const int K = model.components();
  const std::vector<int> pose_unknowns = fitted_pose_unknowns();
  const int P = static_cast<int>(pose_unknowns.size());
  TriangleMesh posed;
  posed.F = model.faces();
  std::vector<View> views;
  for (int level = 0; level < 2; ++level) {
    views = make_views(sil, cams, level == 0 ? o.working_rows / 4 : o.working_rows, centre, o.threads);
    const int iterations = level == 0 ? o.coarse_iterations : o.fine_iterations;
    for (int it = 0; it < iterations; ++it, ++fit->iterations) {
      const ShapedBody body(model, *c);
      body.pose(*pose, &posed.V);
      const Eigen::MatrixXd normals = vertex_normals(posed.V, posed.F);
      Eigen::MatrixXd view_H[2];
      Eigen::VectorXd view_g[2];
      auto view = [&](int k) {
        view_normal_equations(model, body, *pose, pose_unknowns, views[static_cast<size_t>(k)], posed, normals, kViewNames[k],
                              o.robust_distance, &view_H[k], &view_g[k], &fit->outline_rms_mm[k]);
      };
      run_beside(
          o.threads, [&] { view(1); }, [&] { view(0); });  // the two views apart
      Eigen::MatrixXd H = view_H[0] + view_H[1];
      Eigen::VectorXd g = view_g[0] + view_g[1];
      add_priors(*c, *pose, pose_unknowns, o, &H, &g);
      H.triangularView<Eigen::StrictlyUpper>() = H.transpose();    // the rank updates filled the lower half
      H.diagonal().array() += 1e-9 + 1e-4 * H.diagonal().array();  // Levenberg-Marquardt's damping
      Eigen::VectorXd step = -H.ldlt().solve(g);
      if (!step.allFinite()) throw InvalidInput("model fit to the photos: the normal equations are singular");
      if (trace)
        std::fprintf(stderr, "level %d it %d rms %.2f %.2f mm |c| %.2f step c %.3f pose %.4f\n", level, it, fit->outline_rms_mm[0],
                     fit->outline_rms_mm[1], c->norm(), step.head(K).cwiseAbs().maxCoeff(), step.tail(P).cwiseAbs().maxCoeff());
      // A step of at most a standard deviation of shape, 0.2 rad or 10 cm.
      double limit = 1;
      limit = std::min(limit, 1.0 / std::max(1e-12, step.head(K).cwiseAbs().maxCoeff()));
      limit = std::min(limit, 0.1 / std::max(1e-12, step.segment(K, 3).cwiseAbs().maxCoeff()));
      limit = std::min(limit, 0.2 / std::max(1e-12, step.tail(P - 3).cwiseAbs().maxCoeff()));
      step *= limit;
      *c += step.head(K);
      Eigen::VectorXd inc = Eigen::VectorXd::Zero(kPoseIncrementSize);
      for (int q = 0; q < P; ++q) inc(pose_unknowns[static_cast<size_t>(q)]) = step(K + q);
      apply_pose_increment(pose, inc);
      if (level == 1 && step.head(K).cwiseAbs().maxCoeff() < 0.005 && step.tail(P).cwiseAbs().maxCoeff() < 1e-4) break;
    }
  }
  return views;
}

/// What the space cannot say (a local bulge, hips wider than its proportions): each vertex of
/// `posed` moved along its normal by an offset, smooth over the surface (Laplacian), fitted to the
/// same outlines. Returns the largest offset (m).
double fit_detail_offsets(const std::vector<View>& views, const SilhouetteFitOptions& o, bool trace, TriangleMesh* posed,
                          SilhouetteFit* fit) {
  const int n = static_cast<int>(posed->V.rows());
  const Eigen::SparseMatrix<double> L = uniform_laplacian(posed->F, n);
  const Eigen::SparseMatrix<double> smooth = (o.detail_smoothness * L.transpose() * L).pruned();
  const Eigen::MatrixXd base = posed->V, normals = vertex_normals(base, posed->F);
  Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
  Eigen::SimplicialLDLT<Eigen::SparseMatrix<double>> solver;
  for (int it = 0; it < o.detail_iterations; ++it, ++fit->iterations) {
    posed->V = base + (normals.array().colwise() * d.array()).matrix();
    const Eigen::MatrixXd now_normals = vertex_normals(posed->V, posed->F);
    Eigen::VectorXd diag = Eigen::VectorXd::Constant(n, o.detail_offset_prior * o.detail_offset_prior), g = Eigen::VectorXd::Zero(n);
    ViewOutline outlines[2];
    run_beside(
        o.threads, [&] { outlines[1] = outline_pairs(views[1], *posed, now_normals, kViewNames[1]); },
        [&] { outlines[0] = outline_pairs(views[0], *posed, now_normals, kViewNames[0]); });
    for (int k = 0; k < 2; ++k) {
      const View& w = views[static_cast<size_t>(k)];
      const double m = w.metres_per_px, scale = o.robust_distance / m;
      double sum = 0;
      for (const OutlinePair& pair : outlines[k].pairs) {
        const int v = outlines[k].rim[static_cast<size_t>(pair.rim)];
        const double J = pair.direction.dot(outlines[k].dproj[static_cast<size_t>(pair.rim)] * normals.row(v).transpose());
        const double weight = pair.share * cauchy(pair.residual_px, scale) * m * m;
        diag(v) += weight * J * J;
        g(v) += weight * pair.residual_px * J;
        sum += weight * pair.residual_px * pair.residual_px;
      }
      fit->outline_rms_mm[k] = 1000 * std::sqrt(2 * sum);
    }
    g += o.detail_offset_prior * o.detail_offset_prior * d + smooth * d;
    Eigen::SparseMatrix<double> A = smooth;
    for (int i = 0; i < n; ++i) A.coeffRef(i, i) += diag(i);
    if (it == 0) solver.analyzePattern(A);
    solver.factorize(A);
    const Eigen::VectorXd step = -solver.solve(g);
    if (solver.info() != Eigen::Success || !step.allFinite())
      throw InvalidInput("model fit to the photos: the detail offsets' system is singular");
    if (trace)
      std::fprintf(stderr, "detail it %d rms %.2f %.2f mm max offset %.1f mm\n", it, fit->outline_rms_mm[0], fit->outline_rms_mm[1],
                   1000 * d.cwiseAbs().maxCoeff());
    d += step;
  }
  posed->V = base + (normals.array().colwise() * d.array()).matrix();
  return d.cwiseAbs().maxCoeff();
}

/// The body's turn about the vertical from facing the front camera (degrees, positive: to its left).
double yaw_from_front_camera(const PartPose& pose, const Eigen::MatrixXd& V, const PinholeCamera& front) {
  const Eigen::Vector3d facing = part_rotations(pose)[kPelvis] * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d to_camera = front.centre() - V.colwise().mean().transpose();
  return std::remainder(180 / M_PI * (std::atan2(facing.x(), facing.z()) - std::atan2(to_camera.x(), to_camera.z())), 360.0);
}

/// The fit's warnings (a turn, a shape outside the population) and reasons to call it poor.
void judge_fit(const SilhouetteFitOptions& o, int components, SilhouetteFit* fit) {
  if (std::abs(fit->yaw_degrees) >= 3) {
    std::ostringstream w;
    w.precision(2);
    w << "model fit to the photos: the body is turned " << std::abs(fit->yaw_degrees) << " degrees "
      << (fit->yaw_degrees > 0 ? "to its left" : "to its right")
      << " from the front camera (fitted; photos taken square to the body are more accurate)";
    fit->warnings.push_back(w.str());
  }
  const double chi_mean = std::sqrt(std::max(1.0, components - 0.5)), chi_sd = std::sqrt(0.5);
  if (fit->shape_mahalanobis > chi_mean + o.max_shape_sigma * chi_sd)
    fit->warnings.push_back("model fit to the photos: the body is outside the body model's population (shape at " +
                            std::to_string(static_cast<int>(std::lround(fit->shape_mahalanobis))) + " standard deviations)");
  auto mm = [](double m) { return std::to_string(static_cast<int>(std::lround(1000 * m))); };
  for (int k = 0; k < 2; ++k)
    if (fit->shape_outline_rms_mm[k] > 1000 * o.max_shape_outline)
      fit->reasons.push_back(std::string("the body model's outline stays ") + mm(fit->shape_outline_rms_mm[k] / 1000) +
                             " mm (RMS) from the " + kViewNames[k] + " silhouette (" + mm(o.max_shape_outline) +
                             " mm at most): not a body the model can take in this pose");
  if (fit->max_offset_mm > 1000 * o.max_offset)
    fit->reasons.push_back("the silhouettes need the body's surface moved " + mm(fit->max_offset_mm / 1000) +
                           " mm off the model's shape (" + mm(o.max_offset) + " mm at most)");
  fit->confident = fit->reasons.empty();
}

}  // namespace

SilhouetteFit fit_body_model_to_silhouettes(const BodyModel& model, const Silhouette& front, const Silhouette& side,
                                            const PhotoCameras& cameras, const SilhouetteFitOptions& o) {
  const Stopwatch clock;
  const bool trace = std::getenv("POSEKIT_FIT_TRACE") != nullptr;
  const Silhouette* sil[2] = {&front, &side};
  const PinholeCamera* cams[2] = {&cameras.front, &cameras.side};
  SilhouetteFit fit;
  Eigen::VectorXd c;
  PartPose pose;
  const Eigen::Vector3d centre = start_on_the_floor(model.space(), sil, cams, &c, &pose);
  const std::vector<View> views = fit_shape_and_pose(model, sil, cams, centre, o, trace, &c, &pose, &fit);
  TriangleMesh posed;
  posed.F = model.faces();
  ShapedBody(model, c).pose(pose, &posed.V);
  fit.shape_outline_rms_mm[0] = fit.outline_rms_mm[0], fit.shape_outline_rms_mm[1] = fit.outline_rms_mm[1];
  fit.coefficients = c;
  fit.pose = pose;
  fit.shape_mahalanobis = c.norm();
  fit.yaw_degrees = yaw_from_front_camera(pose, posed.V, cameras.front);
  if (o.detail_iterations > 0) fit.max_offset_mm = 1000 * fit_detail_offsets(views, o, trace, &posed, &fit);
  judge_fit(o, model.components(), &fit);
  fit.mesh = std::move(posed);
  fit.seconds = clock.seconds();
  return fit;
}

CustomizedBody customize_by_body_model(const BodyModel& model, const Silhouette& front, const Silhouette& side, const PhotoCameras& cameras,
                                       double stated_stature, bool accept_poor, const SilhouetteFitOptions& options,
                                       const SurveyDistribution* survey) {
  SilhouetteFit fit = fit_body_model_to_silhouettes(model, front, side, cameras, options);
  CustomizedBody out;
  out.mesh = std::move(fit.mesh);
  out.warnings = std::move(fit.warnings);
  const double soles = out.mesh.V.col(1).minCoeff(), crown = out.mesh.V.col(1).maxCoeff();
  out.features.floor_y = soles, out.features.crown_y = out.features.top_y = crown, out.features.stature = crown - soles;
  out.photo_agreement = std::min(photo_agreement(out.mesh, front, cameras.front), photo_agreement(out.mesh, side, cameras.side));
  if (!fit.confident) {
    std::string why;
    for (const auto& r : fit.reasons) why += (why.empty() ? "" : "; ") + r;
    if (!accept_poor)
      throw BelowConfidence("customize: the body model's fit to the photos is poor: " + why +
                            "; nothing written (--accept-poor gives it anyway, marked as poor)");
    out.warnings.push_back("poor result: " + why);
  }
  check_photo_agreement(&out, accept_poor);
  const Eigen::RowVector3d mid = out.mesh.V.colwise().mean();
  scale_to_stated_stature(&out, cameras, stated_stature, Eigen::Vector2d(mid.x(), mid.z()));
  if (survey) {
    SurveyValues values{};
    const SurveyMask given = survey_values_of(measure_body(out.mesh.V, out.mesh.F), &values);
    if (std::count(given.begin(), given.end(), true) >= 2) {
      const Plausibility p = judge_plausibility(*survey, values, given);
      if (p.more_unusual_share < 0.005) {
        std::ostringstream w;
        w << std::fixed << std::setprecision(1) << "this body's measurements are more unusual than " << 100 * (1 - p.more_unusual_share)
          << "% of " << survey->source << "'s " << (p.male ? "men" : "women") << " (Mahalanobis distance " << p.distance
          << "): at the edge of the body model's population, "
          << "whose shapes there are few; check the result";
        out.warnings.push_back(w.str());
      }
    }
  }
  return out;
}

void write_outline_png(const std::string& path, const Silhouette& silhouette, const PinholeCamera& camera, const TriangleMesh& mesh) {
  const RenderBuffers r = render_mesh(mesh, camera);
  Image8 img{silhouette.width, silhouette.height, 3,
             std::vector<std::uint8_t>(static_cast<size_t>(silhouette.width) * silhouette.height * 3)};
  auto covered = [&](int u, int v) {
    return u >= 0 && v >= 0 && u < r.width && v < r.height && r.face[static_cast<size_t>(v) * r.width + u] >= 0;
  };
  for (int v = 0; v < img.height; ++v)
    for (int u = 0; u < img.width; ++u) {
      const bool in = covered(u, v);
      const bool edge = in && (!covered(u - 1, v) || !covered(u + 1, v) || !covered(u, v - 1) || !covered(u, v + 1));
      const std::uint8_t g = silhouette.inside(u, v) ? 170 : 40;
      std::uint8_t* px = &img.pixels[3 * (static_cast<size_t>(v) * img.width + u)];
      px[0] = edge ? 0 : g, px[1] = edge ? 0 : g, px[2] = edge ? 255 : g;  // BGR: the body's outline red
    }
  write_png(path, img);
}

}  // namespace posekit
