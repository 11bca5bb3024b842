#include "posekit/shape/measurements.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <iomanip>
#include <limits>
#include <map>
#include <numeric>
#include <sstream>
#include <unordered_map>
#include <utility>

#include "bust_band.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/profile.h"

namespace posekit {

const std::vector<std::string>& girth_names() {
  static const std::vector<std::string> names = {"bust", "underbust", "waist",     "hip",   "thigh", "knee",
                                                 "calf", "ankle",     "upper_arm", "wrist", "neck"};
  return names;
}
using shape_detail::kBustBelowArmpits;
using shape_detail::kBustPlateau;
namespace {

constexpr double kMaxGapDeg = 40.0;
constexpr double kBustSearch = 0.03;                ///< m each side of the bust level searched for the fullest girth
constexpr double kBustProfile = 0.04;               ///< m each side of the features' bust level sectioned again
constexpr double kUnderbustBand[2] = {0.03, 0.12};  ///< m below the bust level: the underbust band
constexpr double kCrotchArchHalfWidth = 0.015;      ///< m each side of the body axis fitted (crotch_on_smooth_surface)
constexpr double kClusterCell = 0.008;              ///< m: scan points closer than about this belong to one section
constexpr double kSparsestBustCell = 0.025;         ///< m: clusters coarser than this join the arms to the chest: no bust

/// A section from scattered planar points (in the plane with normal n): the median radius about
/// their centroid in each sector, which also removes the scanner's noise; closed when no run of
/// empty sectors spans more than `max_gap_deg`. Sectors are as narrow as kPointsPerSector points
/// on average allow, from 5 down to 1 degree: a hull through 5-degree sectors' centres cuts the
/// corners of a hip's section (3 mm of girth short on a dense cloud, 0.4 mm at 1.25 degrees).
SectionLoop loop_from_points(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& n, double max_gap_deg) {
  constexpr int kPointsPerSector = 12;
  const int kSectors = std::clamp(static_cast<int>(pts.size()) / kPointsPerSector, 72, 360);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += p;
  c /= static_cast<double>(pts.size());
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  std::vector<std::vector<double>> radii(kSectors);
  for (const auto& p : pts) {
    const Eigen::Vector3d d = p - c;
    const double a = std::atan2(d.dot(w), d.dot(u)) + M_PI;
    radii[std::min(kSectors - 1, static_cast<int>(a / (2 * M_PI) * kSectors))].push_back(std::hypot(d.dot(u), d.dot(w)));
  }
  std::vector<Eigen::Vector3d> ring;
  int longest_gap = 0, gap = 0;
  for (int k = 0; k < 2 * kSectors; ++k) {  // twice round, for gaps across the start
    if (radii[k % kSectors].empty()) longest_gap = std::max(longest_gap, ++gap);
    else gap = 0;
  }
  for (int k = 0; k < kSectors; ++k) {
    auto& r = radii[k];
    if (r.empty()) continue;
    std::nth_element(r.begin(), r.begin() + static_cast<long>(r.size() / 2), r.end());
    const double a = (k + 0.5) / kSectors * 2 * M_PI - M_PI;
    ring.push_back(c + r[r.size() / 2] * (std::cos(a) * u + std::sin(a) * w));
  }
  SectionLoop loop;
  loop.closed = ring.size() >= 8 && longest_gap * 360.0 / kSectors < max_gap_deg;
  loop.points.resize(static_cast<Eigen::Index>(ring.size()), 3);
  for (size_t i = 0; i < ring.size(); ++i) loop.points.row(static_cast<Eigen::Index>(i)) = ring[i].transpose();
  return loop;
}

/// Clusters points (already in one slab) by 2D proximity in the plane with normal n.
std::vector<std::vector<Eigen::Vector3d>> cluster(const std::vector<Eigen::Vector3d>& pts, const Eigen::Vector3d& n, double cell) {
  const Eigen::Vector3d u = n.unitOrthogonal(), w = n.cross(u);
  std::map<std::pair<long, long>, std::vector<size_t>> grid;
  for (size_t i = 0; i < pts.size(); ++i)
    grid[{std::lround(std::floor(pts[i].dot(u) / cell)), std::lround(std::floor(pts[i].dot(w) / cell))}].push_back(i);
  std::map<std::pair<long, long>, int> label;
  int next = 0;
  for (const auto& [key, members] : grid) {
    if (label.count(key)) continue;
    std::vector<std::pair<long, long>> stack{key};
    label[key] = next;
    while (!stack.empty()) {
      const auto k = stack.back();
      stack.pop_back();
      for (long dx = -1; dx <= 1; ++dx)
        for (long dz = -1; dz <= 1; ++dz) {
          const std::pair<long, long> nb{k.first + dx, k.second + dz};
          if (grid.count(nb) && !label.count(nb)) label[nb] = next, stack.push_back(nb);
        }
    }
    ++next;
  }
  std::vector<std::vector<Eigen::Vector3d>> out(next);
  for (const auto& [key, members] : grid)
    for (size_t i : members) out[label[key]].push_back(pts[i]);
  return out;
}

/// The loop of a section through `point` (plane normal `normal`) nearest to the point, on the
/// smooth surface through the vertices (N: unit vertex normals), so that girths do not depend on
/// the tessellation.
SectionLoop mesh_section(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N, const Eigen::Vector3d& point,
                         const Eigen::Vector3d& normal) {
  const auto loops = slice_smooth_mesh(V, F, N, normal, normal.dot(point));
  const int k = nearest_loop(loops, point);
  return k < 0 ? SectionLoop{} : loops[k];
}

/// How a cloud is cut into sections: slab thickness and cluster cell (m). A dense cloud (spacing
/// under 2.3 mm) is cut 5 mm thick with 8 mm cells; a sparser one thicker and coarser, so that a
/// slab still holds a point every few mm along a section: with thickness t and areal density
/// 1/s^2 there are t/s^2 points per metre of section, and the cell must bridge their largest gaps.
struct CloudSlicing {
  double thickness = 0.005, cell = kClusterCell;
};
CloudSlicing slicing_for_spacing(double spacing) { return {std::max(0.005, 2.2 * spacing), std::max(kClusterCell, 2.7 * spacing)}; }

SectionLoop cloud_section(const Eigen::MatrixXd& P, const Eigen::Vector3d& point, const Eigen::Vector3d& normal,
                          const CloudSlicing& slicing) {
  const Eigen::Vector3d n = normal.normalized();
  const double half = std::max(0.004, 0.5 * slicing.thickness);
  std::vector<Eigen::Vector3d> slab;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const Eigen::Vector3d q = P.row(i).transpose();
    const double h = (q - point).dot(n);
    if (std::abs(h) < half && (q - point).norm() < 0.35) slab.push_back(q - h * n);
  }
  if (slab.size() < 8) return SectionLoop{};
  auto clusters = cluster(slab, n, slicing.cell);
  size_t best = 0;
  double best_d = 1e9;
  for (size_t c = 0; c < clusters.size(); ++c) {
    Eigen::Vector3d m = Eigen::Vector3d::Zero();
    for (const auto& q : clusters[c]) m += q;
    m /= static_cast<double>(clusters[c].size());
    if ((m - point).norm() < best_d && clusters[c].size() >= 8) best_d = (m - point).norm(), best = c;
  }
  return loop_from_points(clusters[best], n, kMaxGapDeg);
}

/// A girth found but not to be trusted: not measured, no tape, and why.
void not_measured(Girth* g, const std::string& why) {
  g->measured = false;
  g->tape.resize(0, 3);
  g->note = why;
}

template <typename Section>
BodyMeasurements measure(const BodyFeatures& f, Section&& section) {
  BodyMeasurements m;
  m.features = f;
  m.stature = f.stature;
  // One leg's section must lie on its side of the body axis: thighs that touch (or a scan that
  // cannot see the gap between them) give one section round both.
  auto spans_axis = [&](const SectionLoop& loop) {
    return loop.points.col(0).minCoeff() < f.axis_x && loop.points.col(0).maxCoeff() > f.axis_x;
  };
  auto add = [&](const std::string& name, const Eigen::Vector3d& point, const Eigen::Vector3d& normal, bool one_leg = false) {
    Girth g;
    g.name = name;
    g.point = point;
    g.normal = normal.normalized();
    const SectionLoop loop = section(point, g.normal);
    if (loop.points.rows() < 3) {
      g.note = "no section found";
    } else if (!loop.closed) {
      g.note = "section not closed (a hole in the surface or scan)";
    } else if (one_leg && spans_axis(loop)) {
      g.note = "the legs touch at this level: one section holds both (or the scan does not see the gap between them)";
    } else {
      g.value = convex_hull_perimeter(loop.points, g.normal);
      g.tape = convex_hull_loop(loop.points, g.normal);
      g.measured = true;
    }
    m.girths.push_back(g);
  };
  const Eigen::Vector3d up = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d centre(f.axis_x, 0, f.crotch.z());
  auto torso = [&](double y) { return Eigen::Vector3d(centre.x(), y, centre.z()); };
  // Bust and underbust levels again, on 1 mm sections of the surface the girths are measured on:
  // the 5 mm sections of find_body_features place a flat chest's bust level only to a few mm, and
  // the underbust band hangs from it. The bust level is the centre of the peak of the girth profile
  // (peak_centre, as in find_body_features), the bust girth the fullest within kBustSearch of it,
  // the underbust the narrowest level from 12 to 3 cm below it, in 2 mm steps.
  double bust_y = f.bust_y;  // where the tape goes round: the fullest level
  if (!f.torso_levels_doubtful) {
    const double band_top = f.arms_separate_y > f.bust_y ? f.arms_separate_y - kBustBelowArmpits : f.bust_y;
    std::vector<double> ys, gs;
    const double top = std::min(f.bust_y + kBustProfile, band_top);
    for (double y = f.bust_y - kBustProfile; y < top - 1e-6; y += 0.001) ys.push_back(y);
    ys.push_back(top);  // the band's exact end: a man's chest is often fullest there
    size_t best = 0;
    for (size_t k = 0; k < ys.size(); ++k) {
      const SectionLoop loop = section(torso(ys[k]), up);
      gs.push_back(loop.closed && loop.points.rows() >= 3 ? convex_hull_perimeter(loop.points, up)
                                                          : std::numeric_limits<double>::quiet_NaN());
      if (std::isnan(gs[best]) || gs[k] > gs[best]) best = k;
    }
    if (std::isfinite(gs[best])) {
      const double level = peak_centre(ys, gs, best, gs[best] - kBustPlateau);
      double fullest = -1;
      for (size_t k = 0; k < ys.size(); ++k)
        if (std::abs(ys[k] - level) <= kBustSearch && gs[k] > fullest) fullest = gs[k], bust_y = ys[k];
      double narrowest = std::numeric_limits<double>::max();
      for (double y = level - kUnderbustBand[0]; y >= level - kUnderbustBand[1] - 1e-9; y -= 0.002) {
        const SectionLoop loop = section(torso(y), up);
        if (!loop.closed || loop.points.rows() < 3) continue;
        const double g = convex_hull_perimeter(loop.points, up);
        if (g < narrowest) narrowest = g, m.features.underbust_y = y;
      }
      m.features.bust_y = level;
    }
  }
  // An arm hanging close can touch the torso below the armpit: the torso's section there then
  // reaches the arm's axis (shoulder - elbow - wrist), and its girth holds the arm.
  auto arm_x_at = [&](int side, double y, double* x) {
    const Eigen::Vector3d chain[3] = {f.shoulder[side], f.elbow[side], f.wrist[side]};
    for (int k = 0; k < 2; ++k)
      if (y <= chain[k].y() && y >= chain[k + 1].y() && chain[k].y() > chain[k + 1].y()) {
        *x = chain[k].x() + (chain[k + 1].x() - chain[k].x()) * (chain[k].y() - y) / (chain[k].y() - chain[k + 1].y());
        return true;
      }
    return false;
  };
  auto holds_an_arm = [&](const Girth& g) {
    if (!g.measured) return false;
    const SectionLoop loop = section(g.point, up);
    for (int side : {kLeft, kRight}) {
      double x = 0;
      if (!f.arm_found[side] || !arm_x_at(side, g.point.y(), &x)) continue;
      constexpr double kArmRadius = 0.025;  // m: the section reaching this near the arm's axis holds some of it
      if (side == kLeft ? loop.points.col(0).maxCoeff() > x - kArmRadius : loop.points.col(0).minCoeff() < x + kArmRadius) return true;
    }
    return false;
  };
  for (const auto& [name, y] :
       {std::pair<const char*, double>{"bust", bust_y}, {"underbust", m.features.underbust_y}, {"waist", f.waist_y}}) {
    if (!f.torso_levels_doubtful) {
      add(name, torso(y), up);
      const bool chest = std::string(name) != "waist";
      if (chest && (f.arm_touches_torso[kLeft] || f.arm_touches_torso[kRight]) && m.girths.back().measured) {
        not_measured(&m.girths.back(),
                     "the arms touch the torso below the armpits: the chest's section would hold them (hold the arms away from the body)");
      } else if (holds_an_arm(m.girths.back())) {
        not_measured(&m.girths.back(),
                     "an arm touches the torso at this level: its section holds the arm (hold the arms away from the body)");
      }
      continue;
    }
    Girth g;
    g.name = name;
    g.note = "level not found: the torso is fuller below the bust band (a belly, or arms merged with the torso in a scan)";
    m.girths.push_back(g);
  }
  add("hip", torso(f.hip_y), up);
  // Thigh: the left leg's section 2 cm below the crotch (the section nearest a point on the leg).
  add("thigh", Eigen::Vector3d(f.knee[kLeft].x(), f.crotch_y - 0.02, f.knee[kLeft].z()), up, true);
  add("knee", f.knee[kLeft], up, true);
  // Calf: the fullest, and ankle: the thinnest, horizontal leg section between ankle joint and knee.
  auto extreme_leg_level = [&](double from, double to, bool fullest) {
    Eigen::Vector3d best_point = f.ankle[kLeft] + from * (f.knee[kLeft] - f.ankle[kLeft]);
    double best = fullest ? -1.0 : 1e9;
    for (int k = 0; k <= 12; ++k) {
      const Eigen::Vector3d p = f.ankle[kLeft] + (from + (to - from) * k / 12.0) * (f.knee[kLeft] - f.ankle[kLeft]);
      const SectionLoop loop = section(p, up);
      if (!loop.closed || loop.points.rows() < 3) continue;
      const double g = convex_hull_perimeter(loop.points, up);
      if (fullest ? g > best : g < best) best = g, best_point = p;
    }
    return best_point;
  };
  add("calf", extreme_leg_level(0.3, 0.8, true), up, true);
  add("ankle", extreme_leg_level(0.05, 0.4, false), up, true);
  if (f.arm_found[kLeft]) {
    add("upper_arm", 0.5 * (f.shoulder[kLeft] + f.elbow[kLeft]), f.elbow[kLeft] - f.shoulder[kLeft]);
    add("wrist", f.wrist[kLeft], f.wrist[kLeft] - f.elbow[kLeft]);
  } else {
    for (const char* name : {"upper_arm", "wrist"}) {
      Girth g;
      g.name = name;
      g.note = "the left arm could not be followed (holes in the surface or scan)";
      m.girths.push_back(g);
    }
  }
  // Neck: perpendicular to the neck axis (neck joint to head joint), a third of the way up.
  add("neck", f.neck_joint + (f.head_joint - f.neck_joint) / 3.0, f.head_joint - f.neck_joint);
  if (f.head_cut) {
    not_measured(&m.girths.back(), "the head is cut off: the neck's tape level hangs on the head joint, which needs the whole head");
    m.stature_measured = false;
    m.stature_note = "the head is cut off: stature estimated from the level where the arms separate";
  }
  reject_implausible_girths(&m);
  return m;
}

}  // namespace

void reject_implausible_girths(BodyMeasurements* m) {
  auto girth = [&](const std::string& name) -> Girth* {
    for (Girth& g : m->girths)
      if (g.name == name) return &g;
    return nullptr;
  };
  auto reject = [](Girth* g, const std::string& why) {
    std::ostringstream note;
    note.precision(1);
    note << std::fixed << "rejected as implausible: " << 100 * g->value << " cm " << why;
    g->measured = false;
    g->tape.resize(0, 3);
    g->note = note.str();
  };
  // A limb or the neck is never as big round as 0.6 of the stature, a torso girth never 1.5 times it.
  if (m->stature > 0)
    for (Girth& g : m->girths) {
      const bool torso = g.name == "bust" || g.name == "underbust" || g.name == "waist" || g.name == "hip";
      const double limit = (torso ? 1.5 : 0.6) * m->stature;
      if (g.measured && g.value > limit) {
        std::ostringstream why;
        why.precision(1);
        why << std::fixed << "is more than " << (torso ? "1.5 times" : "0.6 of") << " the stature (" << 100 * m->stature
            << " cm): the section did not isolate the " << g.name;
        reject(&g, why.str());
      }
    }
  // Anatomical order: the distal or smaller part is thinner than the one it hangs from.
  const std::pair<const char*, const char*> smaller_than[] = {{"neck", "bust"},  {"neck", "hip"},   {"wrist", "upper_arm"},
                                                              {"ankle", "calf"}, {"knee", "thigh"}, {"calf", "thigh"}};
  for (const auto& [small, large] : smaller_than) {
    Girth *a = girth(small), *b = girth(large);
    if (!a || !b || !a->measured || !b->measured || a->value < b->value) continue;
    std::ostringstream why;
    why.precision(1);
    why << std::fixed << "is not smaller than the " << large << " (" << 100 * b->value << " cm), as it is on every body";
    reject(a, why.str());
  }
  // A bust section that took in the arms (arms held against the chest, or a model whose arms touch
  // it) is far rounder than the hips: bust / hip is at most 1.13 on the dataset's 16 subjects and
  // the robustness set's 10 shapes (BMI 16 to 35); a photo-customized man came to 1.44.
  if (Girth* bust = girth("bust"), *hip = girth("hip"); bust && hip && bust->measured && hip->measured && bust->value > 1.35 * hip->value) {
    std::ostringstream why;
    why.precision(1);
    why << std::fixed << "is over 1.35 times the hip (" << 100 * hip->value << " cm): the section took in the arms";
    reject(bust, why.str());
  }
}

const Girth* BodyMeasurements::find(const std::string& name) const {
  for (const auto& g : girths)
    if (g.name == name) return &g;
  return nullptr;
}

namespace {

/// The crotch on the smooth surface: the top of the arch between the legs in the frontal section
/// through the axis point that the features' crotch sections enclose (a least-squares parabola
/// through the arch's points within kCrotchArchHalfWidth of the axis, evaluated at the axis). The
/// features' crotch, the lowest flat section enclosing that point, moves by up to 1 mm when the
/// body is remeshed, and the thigh girth 2 cm below it changes by up to 2 mm per mm there. The
/// features' crotch where no arch is found.
double crotch_on_smooth_surface(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::MatrixXd& N, const BodyFeatures& f) {
  const Eigen::Vector3d frontal = Eigen::Vector3d::UnitZ();
  const SectionLoop loop = mesh_section(V, F, N, Eigen::Vector3d(f.axis_x, f.crotch_y, f.crotch_axis_z), frontal);
  Eigen::Matrix3d normal_matrix = Eigen::Matrix3d::Zero();
  Eigen::Vector3d rhs = Eigen::Vector3d::Zero();
  int count = 0;
  for (Eigen::Index i = 0; i < loop.points.rows(); ++i) {
    const double dx = loop.points(i, 0) - f.axis_x, y = loop.points(i, 1);
    if (std::abs(dx) > kCrotchArchHalfWidth || std::abs(y - f.crotch_y) > kCrotchArchHalfWidth) continue;
    const Eigen::Vector3d basis(1, dx, dx * dx);
    normal_matrix += basis * basis.transpose();
    rhs += basis * y;
    ++count;
  }
  if (count < 5) return f.crotch_y;
  const Eigen::Vector3d c = normal_matrix.ldlt().solve(rhs);
  return std::abs(c[0] - f.crotch_y) < kCrotchArchHalfWidth && c[2] < 0 ? c[0] : f.crotch_y;
}

}  // namespace

BodyMeasurements measure_body(const Eigen::MatrixXd& V_in, const Eigen::MatrixXi& F_in) {
  TriangleMesh surface;                                       // sectioned as the features were
  BodyFeatures f = find_body_features(V_in, F_in, &surface);  // wrists refined with perpendicular sections
  const Eigen::MatrixXd& V = surface.V;
  const Eigen::MatrixXi& F = surface.F;
  const Eigen::MatrixXd N = vertex_normals(V, F);
  f.crotch_y = f.crotch.y() = crotch_on_smooth_surface(V, F, N, f);
  return measure(f, [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n) { return mesh_section(V, F, N, p, n); });
}

namespace {

/// A 2 cm grid cell's integer coordinates, hashed for unordered maps.
using GridCell = std::array<long, 3>;
struct GridCellHash {
  size_t operator()(const GridCell& c) const {
    return static_cast<size_t>(c[0] * 73856093LL) ^ static_cast<size_t>(c[1] * 19349663LL) ^ static_cast<size_t>(c[2] * 83492791LL);
  }
};

GridCell grid_cell(const Eigen::MatrixXd& P, Eigen::Index i, double cell) {
  return {std::lround(std::floor(P(i, 0) / cell)), std::lround(std::floor(P(i, 1) / cell)), std::lround(std::floor(P(i, 2) / cell))};
}

/// Drops isolated points (outliers): those with fewer than 4 others in their 2 cm cell and its 26
/// neighbours. The neighbourhood's count is the same for every point of a cell: made once per cell.
Eigen::MatrixXd drop_isolated_points(const Eigen::MatrixXd& P) {
  constexpr double kCell = 0.02;
  std::unordered_map<GridCell, int, GridCellHash> count;
  for (Eigen::Index i = 0; i < P.rows(); ++i) ++count[grid_cell(P, i, kCell)];
  std::unordered_map<GridCell, int, GridCellHash> around;
  around.reserve(count.size());
  for (const auto& [c, own] : count) {
    int n = 0;
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) {
          const auto it = count.find({c[0] + dx, c[1] + dy, c[2] + dz});
          if (it != count.end()) n += it->second;
        }
    around[c] = n;
  }
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    if (around.at(grid_cell(P, i, kCell)) - 1 >= 4) keep.push_back(i);
  Eigen::MatrixXd out(static_cast<Eigen::Index>(keep.size()), 3);
  for (size_t k = 0; k < keep.size(); ++k) out.row(static_cast<Eigen::Index>(k)) = P.row(keep[k]);
  return out;
}

/// Distance between neighbouring points on the sparser parts of the surface, 1/sqrt(points per m^2),
/// from the count within 2 cm of a sample of points (in 3-D; the surface is nearly flat at that scale).
double surface_spacing(const Eigen::MatrixXd& P) {
  constexpr double kRadius = 0.02;
  const Eigen::Index stride = std::max<Eigen::Index>(1, P.rows() / 2000);
  // Only the cells around the samples are gathered.
  std::unordered_map<GridCell, std::vector<Eigen::Index>, GridCellHash> grid;
  for (Eigen::Index i = 0; i < P.rows(); i += stride) {
    const GridCell c = grid_cell(P, i, kRadius);
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz) grid.try_emplace({c[0] + dx, c[1] + dy, c[2] + dz});
  }
  for (Eigen::Index i = 0; i < P.rows(); ++i)
    if (const auto it = grid.find(grid_cell(P, i, kRadius)); it != grid.end()) it->second.push_back(i);
  std::vector<double> density;
  for (Eigen::Index i = 0; i < P.rows(); i += stride) {
    const GridCell c = grid_cell(P, i, kRadius);
    long count = 0;
    for (long dx = -1; dx <= 1; ++dx)
      for (long dy = -1; dy <= 1; ++dy)
        for (long dz = -1; dz <= 1; ++dz)
          for (Eigen::Index j : grid.at({c[0] + dx, c[1] + dy, c[2] + dz}))
            count += (P.row(j) - P.row(i)).squaredNorm() < kRadius * kRadius;
    density.push_back(static_cast<double>(count) / (M_PI * kRadius * kRadius));
  }
  // Sampling points favours the densely sampled regions (a scanner's near side, a remesher's hands
  // and face): weigh each sample by the area it stands for (1/density) and take the density that
  // 30% of the surface falls below, so that the sparser regions are still cut into whole sections.
  std::sort(density.begin(), density.end());
  double total = 0;
  for (double d : density) total += 1 / std::max(d, 1.0);
  double below = 0;
  for (double d : density) {
    below += 1 / std::max(d, 1.0);
    if (below >= 0.3 * total) return 1 / std::sqrt(std::max(d, 1.0));
  }
  return 1 / std::sqrt(std::max(density.back(), 1.0));
}

/// Sections of a cloud whose outliers are already gone, every `step` along Y: each from the points
/// within half the slicing's thickness of its level.
SectionStack sections_of_clean_points(const Eigen::MatrixXd& P, double step, double max_gap_deg, const CloudSlicing& slicing) {
  SectionStack s;
  s.floor_y = P.col(1).minCoeff();
  s.top_y = P.col(1).maxCoeff();
  s.step = step;
  for (double y = s.floor_y + step / 2; y < s.top_y; y += step) s.y.push_back(y);
  std::vector<std::vector<Eigen::Vector3d>> slabs(s.y.size());
  const long n = static_cast<long>(s.y.size());
  const double half = 0.5 * slicing.thickness;
  for (Eigen::Index i = 0; i < P.rows(); ++i) {
    const double y = P(i, 1) - s.floor_y;
    // Levels k (at (k + 1/2) step) within half the thickness; slabs of one step when no thicker.
    long first = std::lround(std::floor(y / step)), last = first;
    if (slicing.thickness > step) {
      first = std::lround(std::ceil((y - half) / step - 0.5));
      last = std::lround(std::floor((y + half) / step - 0.5));
    }
    for (long k = std::max(0L, first); k <= std::min(n - 1, last); ++k) slabs[k].push_back(Eigen::Vector3d(P(i, 0), s.y[k], P(i, 2)));
  }
  s.loops.resize(s.y.size());
  for (size_t k = 0; k < slabs.size(); ++k)
    for (const auto& c : cluster(slabs[k], Eigen::Vector3d::UnitY(), slicing.cell))
      if (c.size() >= 8) s.loops[k].push_back(loop_from_points(c, Eigen::Vector3d::UnitY(), max_gap_deg));
  return s;
}

}  // namespace

SectionLoop section_from_planar_points(const std::vector<Eigen::Vector3d>& points, const Eigen::Vector3d& normal, double max_gap_deg) {
  if (points.empty()) return SectionLoop{};
  return loop_from_points(points, normal.normalized(), max_gap_deg);
}

double section_slab_thickness(double spacing) { return slicing_for_spacing(spacing).thickness; }

SectionStack horizontal_sections_of_points(const Eigen::MatrixXd& scan, double step, double max_gap_deg) {
  if (scan.rows() < 1000) throw InvalidInput("measure: the point cloud has " + std::to_string(scan.rows()) + " points, too few for a body");
  const Eigen::MatrixXd P = drop_isolated_points(scan);
  return sections_of_clean_points(P, step, max_gap_deg, slicing_for_spacing(surface_spacing(P)));
}

BodyMeasurements measure_point_cloud(const Eigen::MatrixXd& scan) {
  if (scan.rows() < 1000) throw InvalidInput("measure: the point cloud has " + std::to_string(scan.rows()) + " points, too few for a body");
  // The unit first: a body in mm read as metres has no neighbours within 2 cm at all.
  const double tall = bounding_box(scan).extent().y();
  if (tall > 500 && tall < 2600)
    throw InvalidInput("measure: the cloud is " + std::to_string(tall) +
                       " units tall along its up axis (posekit's Y): did you mean --unit mm?");
  const Eigen::MatrixXd P = drop_isolated_points(scan);
  if (P.rows() < 1000)
    throw InvalidInput("measure: only " + std::to_string(P.rows()) + " of " + std::to_string(scan.rows()) +
                       " points have neighbours within 2 cm: a sparse cloud, or in another unit (wrong --unit?)");
  const BoundingBox box = bounding_box(P);
  if (box.extent().y() < 0.8 || box.extent().y() > 2.6)
    throw InvalidInput("measure: the cloud is " + std::to_string(box.extent().y()) +
                       " m tall along its up axis (posekit's Y): expected a standing human in metres (wrong unit, or up axis?)");
  const CloudSlicing slicing = slicing_for_spacing(surface_spacing(P));
  auto section = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n) { return cloud_section(P, p, n, slicing); };
  BodyFeatures f = find_body_features(sections_of_clean_points(P, 0.005, kMaxGapDeg, slicing));
  refine_wrists(section, &f);
  BodyMeasurements m = measure(f, section);
  // A sparse cloud bridges gaps under its cluster cell: an arm this near the chest counts as joined
  // to it, the arms separate lower, and the bust band ends below the fullest level. On simulated
  // scans of the default body: 3-6 mm short at 100k points (17 mm cells), 11-15 mm at 50k (20 mm),
  // 25-32 mm at 20k (32 mm).
  if (slicing.cell > kClusterCell) {
    std::ostringstream why;
    why << std::fixed << std::setprecision(0) << "the cloud's points are " << 1000 * slicing.cell / 2.7
        << " mm apart on its sparser parts: gaps under " << 1000 * slicing.cell << " mm (an arm near the chest) are not seen";
    const bool too_sparse = slicing.cell > kSparsestBustCell;
    for (Girth& g : m.girths) {
      if ((g.name != "bust" && g.name != "underbust") || !g.measured || !too_sparse) continue;  // the underbust hangs from the bust
      g.measured = false;
      g.tape.resize(0, 3);
      g.note = why.str() + ", so the arms cannot be told from the chest";
    }
    if (!too_sparse) m.features.warnings.push_back(why.str() + "; the bust and underbust may come out up to 1.5 cm short");
  }
  return m;
}

}  // namespace posekit
