#include "posekit/segmentation/segmentation.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <vector>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_slice.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/registration/correspondence.h"

namespace posekit {

Segmentation segment_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const LayeredRepresentation& rep,
                          const Eigen::VectorXi& representation_labels, const SegmentationOptions& options) {
  const Eigen::VectorXi& rep_labels = representation_labels.size() ? representation_labels : rep.triangle_part;
  if (rep_labels.size() != rep.mesh.F.rows())
    throw InvalidInput("segment_body: " + std::to_string(rep_labels.size()) + " representation labels for " +
                       std::to_string(rep.mesh.F.rows()) + " representation triangles");
  if (F.rows() == 0) throw InvalidInput("segment_body: the mesh has no triangles");
  const CentroidIndex index(rep.mesh.V, rep.mesh.F);
  Segmentation out;
  const Eigen::VectorXi match = index.match(face_centroids(V, F), face_normals(V, F), options.candidates, &out.normal_failures);
  out.triangle_part.resize(F.rows());
  for (Eigen::Index f = 0; f < F.rows(); ++f) out.triangle_part[f] = rep_labels[match[f]];
  if (options.clean) out.relabelled = clean_part_labels(V, F, &out.triangle_part);
  if (options.border_smoothing > 0) {
    smooth_part_borders(V, F, options.border_smoothing, &out.triangle_part);
    if (options.clean) out.relabelled += clean_part_labels(V, F, &out.triangle_part);
  }
  out.vertex_part = vertex_labels_from_triangles(V, F, out.triangle_part);
  return out;
}

Eigen::VectorXi representation_labels_from_body(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                                                const LayeredRepresentation& rep) {
  if (triangle_part.size() != F.rows())
    throw InvalidInput("representation_labels_from_body: " + std::to_string(triangle_part.size()) + " labels for " +
                       std::to_string(F.rows()) + " triangles");
  const CentroidIndex index(rep.mesh.V, rep.mesh.F);
  const Eigen::VectorXi match = index.match(face_centroids(V, F), face_normals(V, F), 16);
  const Eigen::VectorXd area = face_areas(V, F);
  Eigen::MatrixXd votes = Eigen::MatrixXd::Zero(rep.mesh.F.rows(), kNumParts);
  for (Eigen::Index f = 0; f < F.rows(); ++f) votes(match[f], triangle_part[f]) += area[f];
  Eigen::VectorXi labels = rep.triangle_part;
  for (Eigen::Index t = 0; t < votes.rows(); ++t) {
    Eigen::Index best;
    if (votes.row(t).maxCoeff(&best) > 0) labels[t] = static_cast<int>(best);
  }
  return labels;
}

int clean_part_labels(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, Eigen::VectorXi* triangle_part) {
  Eigen::VectorXi& L = *triangle_part;
  const Eigen::MatrixXi TT = face_adjacency(F);
  const Eigen::VectorXd area = face_areas(V, F);
  int relabelled = 0;
  // Repeat: islands may merge into a neighbour that is itself an island.
  for (int round = 0; round < 4; ++round) {
    // Regions: edge-connected triangles of one label.
    Eigen::VectorXi region = Eigen::VectorXi::Constant(F.rows(), -1);
    std::vector<double> region_area;
    std::vector<int> region_label, stack;
    for (Eigen::Index seed = 0; seed < F.rows(); ++seed) {
      if (region[seed] >= 0) continue;
      const int r = static_cast<int>(region_area.size());
      region_area.push_back(0);
      region_label.push_back(L[seed]);
      region[seed] = r;
      stack.assign(1, static_cast<int>(seed));
      while (!stack.empty()) {
        const int f = stack.back();
        stack.pop_back();
        region_area[r] += area[f];
        for (int c = 0; c < 3; ++c) {
          const int g = TT(f, c);
          if (g >= 0 && region[g] < 0 && L[g] == L[f]) {
            region[g] = r;
            stack.push_back(g);
          }
        }
      }
    }
    std::vector<int> main_region(kNumParts, -1);
    for (size_t r = 0; r < region_area.size(); ++r) {
      int& m = main_region[static_cast<size_t>(region_label[r])];
      if (m < 0 || region_area[r] > region_area[static_cast<size_t>(m)]) m = static_cast<int>(r);
    }
    // Each island takes the label it shares the longest boundary with.
    std::vector<std::map<int, double>> border(region_area.size());
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      for (int c = 0; c < 3; ++c) {
        const int g = TT(f, c);
        if (g < 0 || L[g] == L[f]) continue;
        const double len = (V.row(F(f, c)) - V.row(F(f, (c + 1) % 3))).norm();
        border[static_cast<size_t>(region[f])][L[g]] += len;
      }
    }
    std::vector<int> new_label(region_area.size(), -1);
    bool changed = false;
    for (size_t r = 0; r < region_area.size(); ++r) {
      if (main_region[static_cast<size_t>(region_label[r])] == static_cast<int>(r) || border[r].empty()) continue;
      const auto best =
          std::max_element(border[r].begin(), border[r].end(), [](const auto& a, const auto& b) { return a.second < b.second; });
      new_label[r] = best->first;
      changed = true;
    }
    if (!changed) break;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      const int n = new_label[static_cast<size_t>(region[f])];
      if (n >= 0) {
        L[f] = n;
        ++relabelled;
      }
    }
  }
  return relabelled;
}

Eigen::VectorXi vertex_labels_from_triangles(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part) {
  const Eigen::VectorXd area = face_areas(V, F);
  Eigen::MatrixXd votes = Eigen::MatrixXd::Zero(V.rows(), kNumParts);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) votes(F(f, c), triangle_part[f]) += area[f] + 1e-18;
  Eigen::VectorXi out = Eigen::VectorXi::Zero(V.rows());
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    Eigen::Index best;
    votes.row(v).maxCoeff(&best);
    out[v] = static_cast<int>(best);
  }
  return out;
}

double label_agreement(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& a, const Eigen::VectorXi& b) {
  if (a.size() != F.rows() || b.size() != F.rows())
    throw InvalidInput("label_agreement: labels do not match the " + std::to_string(F.rows()) + " triangles");
  const Eigen::VectorXd area = face_areas(V, F);
  double same = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    if (a[f] == b[f]) same += area[f];
  return same / std::max(area.sum(), 1e-300);
}

void smooth_part_borders(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, double radius, Eigen::VectorXi* triangle_part) {
  Eigen::VectorXi& L = *triangle_part;
  if (L.size() != F.rows())
    throw InvalidInput("smooth_part_borders: " + std::to_string(L.size()) + " labels for " + std::to_string(F.rows()) + " triangles");
  if (!(radius > 0) || F.rows() == 0) return;
  // Each vertex starts wholly in its triangles' majority part; the shares are diffused over the
  // edges: after k rounds of neighbour averaging a label has spread about sqrt(k) mean edges.
  const Eigen::VectorXi vertex_part = vertex_labels_from_triangles(V, F, L);
  std::vector<std::vector<int>> neighbours(static_cast<size_t>(V.rows()));
  double edge_sum = 0;
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int a = F(f, c), b = F(f, (c + 1) % 3);
      neighbours[static_cast<size_t>(a)].push_back(b);
      neighbours[static_cast<size_t>(b)].push_back(a);
      edge_sum += (V.row(a) - V.row(b)).norm();
    }
  const double mean_edge = edge_sum / static_cast<double>(3 * F.rows());
  for (auto& n : neighbours) {  // each edge was met from both its triangles
    std::sort(n.begin(), n.end());
    n.erase(std::unique(n.begin(), n.end()), n.end());
  }
  const int rounds = std::clamp(static_cast<int>(std::lround(std::pow(radius / std::max(mean_edge, 1e-12), 2))), 1, 200);
  using Shares = Eigen::Matrix<float, Eigen::Dynamic, kNumParts, Eigen::RowMajor>;  // a vertex's shares together
  Shares share = Shares::Zero(V.rows(), kNumParts), next(V.rows(), kNumParts);
  for (Eigen::Index v = 0; v < V.rows(); ++v) share(v, vertex_part[v]) = 1;
  // Only a band round the borders changes enough to matter (1.5 radii of rings); the rest keeps
  // its one part.
  std::vector<int> band, ring_of(static_cast<size_t>(V.rows()), -1);
  for (Eigen::Index v = 0; v < V.rows(); ++v)
    for (int u : neighbours[static_cast<size_t>(v)])
      if (vertex_part[u] != vertex_part[v]) {
        ring_of[static_cast<size_t>(v)] = 0;
        band.push_back(static_cast<int>(v));
        break;
      }
  const int rings = static_cast<int>(std::ceil(1.5 * radius / std::max(mean_edge, 1e-12)));
  for (size_t i = 0; i < band.size(); ++i) {
    const int v = band[i];
    if (ring_of[static_cast<size_t>(v)] >= rings) continue;
    for (int u : neighbours[static_cast<size_t>(v)])
      if (ring_of[static_cast<size_t>(u)] < 0) {
        ring_of[static_cast<size_t>(u)] = ring_of[static_cast<size_t>(v)] + 1;
        band.push_back(u);
      }
  }
  next = share;
  for (int r = 0; r < rounds; ++r) {
    for (int v : band) {
      const auto& n = neighbours[static_cast<size_t>(v)];
      next.row(v) = share.row(v);
      for (int u : n) next.row(v) += share.row(u);
      next.row(v) /= static_cast<float>(n.size() + 1);
    }
    for (int v : band) share.row(v) = next.row(v);
  }
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const Eigen::Matrix<float, 1, kNumParts> s = share.row(F(f, 0)) + share.row(F(f, 1)) + share.row(F(f, 2));
    Eigen::Index best;
    s.maxCoeff(&best);
    L[f] = static_cast<int>(best);
  }
}

double border_roughness(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part) {
  if (triangle_part.size() != F.rows())
    throw InvalidInput("border_roughness: " + std::to_string(triangle_part.size()) + " labels for " + std::to_string(F.rows()) +
                       " triangles");
  const Eigen::MatrixXi TT = face_adjacency(F);
  std::vector<std::vector<Eigen::Vector3d>> points(kNumParts);  // border edge midpoints, by child part
  std::vector<double> length(kNumParts, 0.0);
  for (Eigen::Index f = 0; f < F.rows(); ++f)
    for (int c = 0; c < 3; ++c) {
      const int g = TT(f, c), child = triangle_part[f];
      if (g < 0 || child < 1 || child >= kNumParts || triangle_part[g] != part_parent(child)) continue;
      const Eigen::Vector3d a = V.row(F(f, c)).transpose(), b = V.row(F(f, (c + 1) % 3)).transpose();
      points[static_cast<size_t>(child)].push_back(0.5 * (a + b));
      length[static_cast<size_t>(child)] += (b - a).norm();
    }
  std::vector<double> ratios;
  for (int p = 1; p < kNumParts; ++p) {
    const auto& P = points[static_cast<size_t>(p)];
    if (P.size() < 6) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& q : P) mean += q / static_cast<double>(P.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& q : P) cov += (q - mean) * (q - mean).transpose();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> pca(cov);
    Eigen::MatrixXd M(static_cast<Eigen::Index>(P.size()), 3);
    for (size_t i = 0; i < P.size(); ++i) M.row(static_cast<Eigen::Index>(i)) = P[i].transpose();
    const double perimeter = convex_hull_perimeter(M, pca.eigenvectors().col(0));  // in the border's plane
    if (perimeter > 0) ratios.push_back(length[static_cast<size_t>(p)] / perimeter);
  }
  if (ratios.empty()) return std::numeric_limits<double>::quiet_NaN();
  std::nth_element(ratios.begin(), ratios.begin() + static_cast<std::ptrdiff_t>(ratios.size() / 2), ratios.end());
  return ratios[ratios.size() / 2];
}

}  // namespace posekit
