#include "posekit/segmentation/skeleton_checks.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"

namespace posekit {
namespace {

constexpr double kSecondPieceFraction = 0.05;  ///< of a part's area: a second piece this large is a split part
constexpr double kBorderSlack = 0.01;          ///< m added to the border distance allowed

std::string cm(double metres) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(1);
  s << 100 * metres << " cm";
  return s.str();
}

int side_of(const std::string& name) {
  if (name.rfind("left_", 0) == 0) return 1;
  if (name.rfind("right_", 0) == 0) return -1;
  return 0;
}

}  // namespace

std::string SkeletonCheck::summary() const {
  std::string out;
  for (const auto& p : problems) out += (out.empty() ? "" : "; ") + p;
  return out;
}

SkeletonCheck check_skeleton(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const Eigen::VectorXi& triangle_part,
                             const Eigen::MatrixXd& joints, const SkeletonCheckOptions& options) {
  if (triangle_part.size() != F.rows())
    throw InvalidInput("check_skeleton: " + std::to_string(triangle_part.size()) + " labels for " + std::to_string(F.rows()) +
                       " triangles");
  if (joints.rows() != kNumJoints || joints.cols() != 3)
    throw InvalidInput("check_skeleton: expected " + std::to_string(kNumJoints) + " x 3 joint centres");
  SkeletonCheck check;
  const Eigen::VectorXd area = face_areas(V, F);
  const Eigen::MatrixXd centroid = face_centroids(V, F);

  // Per part: area, centroid; the midline from the torso parts and the head.
  std::array<double, kNumParts> part_area{};
  std::array<Eigen::Vector3d, kNumParts> part_centre;
  part_centre.fill(Eigen::Vector3d::Zero());
  for (Eigen::Index f = 0; f < F.rows(); ++f) {
    const int p = triangle_part[f];
    if (p < 0 || p >= kNumParts) throw InvalidInput("check_skeleton: triangle " + std::to_string(f) + " has label " + std::to_string(p));
    part_area[p] += area[f];
    part_centre[p] += area[f] * centroid.row(f).transpose();
  }
  double torso_area = 0, midline = 0;
  for (int p = 0; p < kNumParts; ++p) {
    if (part_area[p] > 0) part_centre[p] /= part_area[p];
    if (side_of(part_name(p)) == 0 && part_area[p] > 0) {
      torso_area += part_area[p];
      midline += part_area[p] * part_centre[p].x();
    }
  }
  auto cut_off = [&](int p) {
    return std::find(options.cut_off_parts.begin(), options.cut_off_parts.end(), p) != options.cut_off_parts.end();
  };
  for (int p = 0; p < kNumParts; ++p)
    if (part_area[p] == 0 && !cut_off(p)) check.problems.push_back("no triangle is labelled " + part_name(p));
  if (torso_area == 0) return check;
  midline /= torso_area;

  // Left is left: parts and joints on their own side of the midline.
  auto wrong_side = [&](const std::string& name, double x) {
    const int side = side_of(name);
    if (side == 0 || side * (x - midline) > 0) return;
    check.problems.push_back(name + " lies " + cm(std::abs(x - midline)) + (x > midline ? " left" : " right") +
                             " of the body's midline, on the " + (side > 0 ? "right" : "left") + " side");
  };
  for (int p = 0; p < kNumParts; ++p)
    if (part_area[p] > 0) wrong_side(part_name(p) + " (part)", part_centre[p].x());
  for (int j = 0; j < kNumJoints; ++j) wrong_side(joint_name(j) + " (joint)", joints(j, 0));

  // One piece per part; left and right limb parts of similar area.
  const Eigen::MatrixXi TT = face_adjacency(F);
  Eigen::VectorXi piece = Eigen::VectorXi::Constant(F.rows(), -1);
  std::array<std::vector<double>, kNumParts> piece_areas;
  std::vector<Eigen::Index> stack;
  for (Eigen::Index seed = 0; seed < F.rows(); ++seed) {
    if (piece[seed] >= 0) continue;
    const int p = triangle_part[seed];
    const int id = static_cast<int>(piece_areas[p].size());
    double a = 0;
    piece[seed] = id;
    stack.assign(1, seed);
    while (!stack.empty()) {
      const Eigen::Index f = stack.back();
      stack.pop_back();
      a += area[f];
      for (int c = 0; c < 3; ++c) {
        const int g = TT(f, c);
        if (g >= 0 && piece[g] < 0 && triangle_part[g] == p) {
          piece[g] = id;
          stack.push_back(g);
        }
      }
    }
    piece_areas[p].push_back(a);
  }
  for (int p = 0; p < kNumParts; ++p) {
    auto& pieces = piece_areas[p];
    if (pieces.size() < 2) continue;
    std::sort(pieces.rbegin(), pieces.rend());
    if (pieces[1] > kSecondPieceFraction * part_area[p])
      check.problems.push_back(part_name(p) + " is in " + std::to_string(pieces.size()) + " pieces (the second holds " +
                               std::to_string(static_cast<int>(std::lround(100 * pieces[1] / part_area[p]))) + "% of it)");
  }
  for (int p = 0; p < kNumParts; ++p) {
    const int q = mirror_part(p);
    if (side_of(part_name(p)) <= 0 || part_area[p] == 0 || part_area[q] == 0) continue;
    const double ratio = part_area[p] / part_area[q];
    if (ratio > options.part_area_ratio || ratio < 1 / options.part_area_ratio)
      check.problems.push_back(part_name(p) + " and " + part_name(q) + " differ in area " +
                               std::to_string(static_cast<int>(std::lround(100 * std::max(ratio, 1 / ratio) - 100))) +
                               "% (a part swallowed by its neighbour?)");
  }

  // Joints at their parts' border: border edges between child and parent, length-weighted.
  for (int j = 0; j < kNumJoints; ++j) {
    const int child = j + 1, parent = part_parent(child);
    if (cut_off(child)) continue;
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    std::vector<std::pair<Eigen::Vector3d, double>> edges;
    double length = 0;
    for (Eigen::Index f = 0; f < F.rows(); ++f) {
      if (triangle_part[f] != child) continue;
      for (int c = 0; c < 3; ++c) {
        const int g = TT(f, c);
        if (g < 0 || triangle_part[g] != parent) continue;
        const Eigen::Vector3d a = V.row(F(f, c)).transpose(), b = V.row(F(f, (c + 1) % 3)).transpose();
        const double l = (b - a).norm();
        edges.emplace_back(0.5 * (a + b), l);
        centre += l * 0.5 * (a + b);
        length += l;
      }
    }
    if (!(length > 0)) {
      if (part_area[child] > 0 && part_area[parent] > 0)
        check.problems.push_back(part_name(child) + " and " + part_name(parent) + " do not touch, so " + joint_name(j) + " joins nothing");
      continue;
    }
    centre /= length;
    double radius = 0;
    for (const auto& [mid, l] : edges) radius += l * (mid - centre).norm();
    radius /= length;
    const double off = (joints.row(j).transpose() - centre).norm();
    if (off > options.border_radii * radius + kBorderSlack)
      check.problems.push_back(joint_name(j) + " lies " + cm(off) + " from the centre of the " + part_name(child) + "/" +
                               part_name(parent) + " border, whose radius is " + cm(radius));
  }

  // Left and right limb segments of similar length.
  const std::array<std::array<const char*, 3>, 4> segments = {
      {{"upper arm", "shoulder", "elbow"}, {"forearm", "elbow", "wrist"}, {"thigh", "hip", "knee"}, {"shank", "knee", "ankle"}}};
  for (const auto& s : segments) {
    double len[2];
    for (int side = 0; side < 2; ++side) {
      const std::string prefix = side == 0 ? "left_" : "right_";
      len[side] = (joints.row(find_joint_index(prefix + s[1])) - joints.row(find_joint_index(prefix + s[2]))).norm();
    }
    const double mean = 0.5 * (len[0] + len[1]);
    if (std::abs(len[0] - len[1]) > options.limb_length_tolerance * mean)
      check.problems.push_back(std::string("the left and right ") + s[0] + " lengths differ: " + cm(len[0]) + " and " + cm(len[1]) + " (" +
                               s[1] + " to " + s[2] + ")");
  }
  return check;
}

}  // namespace posekit
