#include "posekit/fitting/body_fit.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <set>
#include <sstream>
#include <unordered_map>

#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/parallel.h"
#include "posekit/core/point_grid.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/shape/body_features.h"

namespace posekit {
namespace {

constexpr double kDeg = M_PI / 180;
/// Grid cell (m) of the coarse samples the global search scores (700 target points, a body vertex
/// per 4 cm): the same nearest points as in 3 cm cells, in a fraction of the empty cells.
constexpr double kCoarseCell = 0.075;
/// A target point farther than this (m) from the fitted body is no part of it (a scanner's stray
/// return, the floor).
constexpr double kOutlier = 0.25;

/// The points averaged per cubic cell: a cloud whose density no longer depends on the scanner's.
/// (T has at least one point.)
Eigen::MatrixXd working_cloud(const Eigen::MatrixXd& T, double cell) {
  const Eigen::RowVector3d lo = T.colwise().minCoeff();
  std::unordered_map<std::uint64_t, int> slot;
  std::vector<Eigen::Vector3d> sum;
  std::vector<int> count;
  slot.reserve(1 << 15);
  for (Eigen::Index i = 0; i < T.rows(); ++i) {
    const Eigen::Array3d q = ((T.row(i) - lo) / cell).array().floor();
    const std::uint64_t key =
        (static_cast<std::uint64_t>(q.x()) << 42) | (static_cast<std::uint64_t>(q.y()) << 21) | static_cast<std::uint64_t>(q.z());
    const auto [it, inserted] = slot.try_emplace(key, static_cast<int>(sum.size()));
    if (inserted) sum.emplace_back(Eigen::Vector3d::Zero()), count.push_back(0);
    sum[static_cast<size_t>(it->second)] += T.row(i).transpose();
    ++count[static_cast<size_t>(it->second)];
  }
  // A cell holding under a tenth of the typical cell's points is a scanner's stray return, not
  // surface (on a mesh, one vertex per cell is typical and every cell is kept).
  std::vector<int> sorted = count;
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(sorted.size() / 2), sorted.end());
  const double least = 0.1 * sorted[sorted.size() / 2];
  std::vector<Eigen::Vector3d> kept;
  for (size_t k = 0; k < sum.size(); ++k)
    if (count[k] >= least) kept.push_back(sum[k] / count[k]);
  Eigen::MatrixXd W(static_cast<Eigen::Index>(kept.size()), 3);
  for (size_t k = 0; k < kept.size(); ++k) W.row(static_cast<Eigen::Index>(k)) = kept[k].transpose();
  return W;
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

/// One vertex per cubic cell of this size (m): a sample spread by area. MakeHuman's hands and face
/// hold a third of its vertices; every n-th vertex let the hands decide how arms score.
std::vector<int> spread_rows(const Eigen::MatrixXd& V, double cell) {
  const Eigen::RowVector3d lo = V.colwise().minCoeff();
  std::unordered_map<std::uint64_t, int> taken;
  std::vector<int> rows;
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    const Eigen::Array3d q = ((V.row(v) - lo) / cell).array().floor();
    const std::uint64_t key =
        (static_cast<std::uint64_t>(q.x()) << 42) | (static_cast<std::uint64_t>(q.y()) << 21) | static_cast<std::uint64_t>(q.z());
    if (taken.emplace(key, 0).second) rows.push_back(static_cast<int>(v));
  }
  return rows;
}

/// Rows of a body that score how well it explains a cloud: the hands last, after `scored` rows. A
/// hand is in the body's grid (the target's hands want a body near them) but is not charged for
/// lying where the target has nothing: scanners cut hands, and a short, heavy body (1.54 m) whose
/// hands were cut scored a forearm folded onto the belly, hand hidden, above its true pose.
struct ScoreRows {
  std::vector<int> rows;
  Eigen::Index scored = 0;
};

ScoreRows hands_last(const std::vector<int>& rows, const Eigen::VectorXi& vertex_part) {
  ScoreRows out;
  std::vector<int> hands;
  for (int r : rows) (vertex_part[r] == kLeftHand || vertex_part[r] == kRightHand ? hands : out.rows).push_back(r);
  out.scored = static_cast<Eigen::Index>(out.rows.size());
  out.rows.insert(out.rows.end(), hands.begin(), hands.end());
  return out;
}

/// Rows 0, s, 2s, ... of a matrix.
Eigen::MatrixXd every(const Eigen::MatrixXd& P, Eigen::Index stride) {
  return P(Eigen::seq(0, P.rows() - 1, std::max<Eigen::Index>(1, stride)), Eigen::all);
}

/// How badly a posed body explains a cloud: the mean of each point's distance to the other set,
/// capped at `cap`, both ways (the body's first `scored` rows to the cloud; all: -1). `cell`: the
/// body grid's (a sparse sample searches faster in larger cells: fewer empty ones between a
/// misplaced limb and the cloud). A search for the best of many passes the best so far as `bound`:
/// once the partial sums reach it (they only grow) the placement cannot win and a value >= bound is
/// returned; below it the value is exact.
double mismatch(const Eigen::MatrixXd& body, const Eigen::MatrixXd& cloud, const PointGrid& cloud_grid, double cap, double cell = 0.03,
                double bound = std::numeric_limits<double>::infinity(), Eigen::Index scored = -1) {
  const Eigen::Index body_scored = scored < 0 ? body.rows() : std::min(scored, body.rows());
  const auto body_n = static_cast<double>(std::max<Eigen::Index>(1, body_scored));
  const auto cloud_n = static_cast<double>(std::max<Eigen::Index>(1, cloud.rows()));
  constexpr Eigen::Index kCheckEvery = 16;
  // Body to cloud first: the cloud's grid is built already, the body's only when it is needed.
  double back = 0;
  for (Eigen::Index v = 0; v < body_scored; ++v) {
    double sq = 0;
    back += cloud_grid.nearest(body.row(v).transpose(), &sq, cap) >= 0 ? std::sqrt(sq) : cap;
    if (v % kCheckEvery == kCheckEvery - 1 && back / body_n >= bound) return back / body_n;
  }
  const double back_mean = back / body_n;
  if (back_mean >= bound) return back_mean;
  const PointGrid body_grid(body, cell);
  double sum = 0;
  for (Eigen::Index i = 0; i < cloud.rows(); ++i) {
    double sq = 0;
    sum += body_grid.nearest(cloud.row(i).transpose(), &sq, cap) >= 0 ? std::sqrt(sq) : cap;
    if (i % kCheckEvery == kCheckEvery - 1 && sum / cloud_n + back_mean >= bound) return sum / cloud_n + back_mean;
  }
  return sum / cloud_n + back_mean;
}

/// The `q` quantile of the cloud's distances to the body's nearest points, each capped at `cap`.
double cloud_quantile_to_body(const Eigen::MatrixXd& body, const Eigen::MatrixXd& cloud, double q, double cap) {
  const PointGrid body_grid(body, 0.03);
  std::vector<double> d(static_cast<size_t>(cloud.rows()));
  for (Eigen::Index i = 0; i < cloud.rows(); ++i) {
    double sq = 0;
    d[static_cast<size_t>(i)] = body_grid.nearest(cloud.row(i).transpose(), &sq, cap) >= 0 ? std::sqrt(sq) : cap;
  }
  return quantile(std::move(d), q);
}

/// The median of a cloud's coordinates on one axis.
double median_of(const Eigen::MatrixXd& P, int axis) {
  return quantile(std::vector<double>(P.col(axis).data(), P.col(axis).data() + P.rows()), 0.5);
}

/// Where a body is stood on a cloud: its floor (a low quantile of its heights, not a stray point)
/// and its median point across (stand_on_cloud).
struct Ground {
  double floor = 0, median_x = 0, median_z = 0;
};

Ground ground_of(const Eigen::MatrixXd& cloud) {
  std::vector<double> cy(static_cast<size_t>(cloud.rows()));
  for (Eigen::Index i = 0; i < cloud.rows(); ++i) cy[static_cast<size_t>(i)] = cloud(i, 1);
  return {quantile(cy, 0.005), median_of(cloud, 0), median_of(cloud, 2)};
}

Eigen::RowVector3d standing_move(const Eigen::MatrixXd& body, const Ground& ground) {
  return {ground.median_x - median_of(body, 0), ground.floor - body.col(1).minCoeff(), ground.median_z - median_of(body, 2)};
}

/// Moves a pose by standing_move of its posed body.
void stand_on(const Eigen::MatrixXd& body, const Ground& ground, PartPose* pose) {
  pose->root_translation += standing_move(body, ground).transpose();
}

}  // namespace

namespace {

/// Joint rotations said in anatomical angles (degrees) for a body of these rest joint centres (Y up,
/// facing +Z, left +X): an arm's abduction (its angle from hanging straight down, in the frontal plane)
/// then its flexion (forward elevation from there; negative: backwards); the elbow's and knee's
/// flexion about their hinge (0: straight); a hip's flexion and abduction; the spine's forward bend.
/// Whole angles, not changes from the rest pose: the template's A-pose arms hang about 45 degrees
/// out with the elbows a little bent, and any other rest pose says the same.
class Anatomy {
 public:
  explicit Anatomy(const Eigen::MatrixXd& J) : J_(J) {}

  void arm(PartPose& p, double side, double abduction, double flexion, double elbow_flexion) const {
    const std::string s = side > 0 ? "left_" : "right_";
    set(p, s + "shoulder", shoulder(side, abduction, flexion));
    set(p, s + "elbow", elbow(side, elbow_flexion));
  }
  void arms(PartPose& p, double abduction, double flexion, double elbow_flexion) const {
    arm(p, 1, abduction, flexion, elbow_flexion), arm(p, -1, abduction, flexion, elbow_flexion);
  }
  /// An arm whose elbow keeps its rest bend.
  void arm_at_rest_elbow(PartPose& p, double side, double abduction, double flexion) const {
    set(p, std::string(side > 0 ? "left_" : "right_") + "shoulder", shoulder(side, abduction, flexion));
  }
  void leg(PartPose& p, double side, double hip_flexion, double knee_flexion, double hip_abduction = 0) const {
    const std::string s = side > 0 ? "left_" : "right_";
    set(p, s + "hip",
        axis_angle_from_rotation(rotation_from_axis_angle(-hip_flexion * kDeg * Eigen::Vector3d::UnitX()) *
                                 rotation_from_axis_angle(side * hip_abduction * kDeg * Eigen::Vector3d::UnitZ())));
    set(p, s + "knee", knee_flexion * kDeg * Eigen::Vector3d::UnitX());
  }
  void legs(PartPose& p, double hip_flexion, double knee_flexion) const {
    leg(p, 1, hip_flexion, knee_flexion), leg(p, -1, hip_flexion, knee_flexion);
  }
  void spine(PartPose& p, double flexion) const { set(p, "lower_back", flexion * kDeg * Eigen::Vector3d::UnitX()); }

  Eigen::Vector3d shoulder(double side, double abduction, double flexion) const {
    const std::string s = side > 0 ? "left_" : "right_";
    const Eigen::Vector3d d = at(s + "elbow") - at(s + "shoulder");
    const double rest = std::atan2(std::abs(d.x()), -d.y());
    const Eigen::Matrix3d R = rotation_from_axis_angle(-flexion * kDeg * Eigen::Vector3d::UnitX()) *
                              rotation_from_axis_angle(side * (abduction * kDeg - rest) * Eigen::Vector3d::UnitZ());
    return axis_angle_from_rotation(R);
  }
  Eigen::Vector3d elbow(double side, double flexion) const {
    const std::string s = side > 0 ? "left_" : "right_";
    const Eigen::Vector3d upper = (at(s + "elbow") - at(s + "shoulder")).normalized(),
                          fore = (at(s + "wrist") - at(s + "elbow")).normalized();
    Eigen::Vector3d hinge = upper.cross(fore);
    // A straight arm at rest has no bend to tell the hinge: the forearm then flexes forward.
    if (hinge.norm() < 0.05) hinge = upper.cross(Eigen::Vector3d::UnitZ());
    return (flexion * kDeg - std::acos(std::clamp(upper.dot(fore), -1.0, 1.0))) * hinge.normalized();
  }

 private:
  static void set(PartPose& p, const std::string& joint, const Eigen::Vector3d& r) { p.joint(find_joint_index(joint)) = r; }
  Eigen::Vector3d at(const std::string& name) const { return J_.row(find_joint_index(name)).transpose(); }
  const Eigen::MatrixXd& J_;
};

/// One arm's shoulder and elbow rotations to try on their own (side: +1 left, -1 right): the upper
/// arm hanging, out, raised (hands about the head's height: between out and overhead, which an arm
/// drawn at 150-170 degrees from the rig's rest and reaching forward fitted neither), up, forward,
/// back or across, each with the elbow straight, at right angles or bent further.
std::vector<std::array<Eigen::Vector3d, 2>> arm_options(const Eigen::MatrixXd& J, double side) {
  const Anatomy body(J);
  const std::vector<std::array<double, 2>> shoulders = {{5, 0},  {20, 0},  {45, 0},  {90, 0},   {125, 0},  {125, 30}, {165, 0}, {5, 45},
                                                        {5, 90}, {20, 45}, {30, 90}, {30, -20}, {40, -15}, {10, 60},  {5, 150}};
  std::vector<std::array<Eigen::Vector3d, 2>> options;
  for (const auto& [abduction, flexion] : shoulders)
    for (const double elbow : {10.0, 45.0, 90.0, 125.0})
      options.push_back({body.shoulder(side, abduction, flexion), body.elbow(side, elbow)});
  return options;
}

/// One leg's hip and knee rotations to try on their own: the thigh back, down, forward, level or
/// up, straight out or (`spread`) also spread, each with the knee straight, half or fully bent.
std::vector<std::array<Eigen::Vector3d, 2>> leg_options(const Eigen::MatrixXd& J, double side, bool spread = true) {
  const Anatomy body(J);
  const std::string s = side > 0 ? "left_" : "right_";
  const auto hip = static_cast<size_t>(find_joint_index(s + "hip")), knee = static_cast<size_t>(find_joint_index(s + "knee"));
  std::vector<std::array<Eigen::Vector3d, 2>> options;
  for (const double flexion : {-15.0, 0.0, 30.0, 60.0, 90.0, 115.0})
    for (const double abduction : {0.0, 25.0})
      for (const double knee_flexion : {0.0, 45.0, 90.0, 130.0}) {
        if (abduction > 0 && !spread) continue;
        PartPose p;
        body.leg(p, side, flexion, knee_flexion, abduction);
        options.push_back({p.joint_rotation[hip], p.joint_rotation[knee]});
      }
  return options;
}

}  // namespace

Eigen::RowVector3d stand_on_cloud(const Eigen::MatrixXd& X, const Eigen::MatrixXd& cloud) { return standing_move(X, ground_of(cloud)); }

Eigen::RowVector3d centre_on_cloud(const Eigen::MatrixXd& cloud, const PointGrid& cloud_grid, double cap, double cell, int rounds,
                                   Eigen::MatrixXd* X) {
  Eigen::RowVector3d moved = Eigen::RowVector3d::Zero();
  for (int round = 0; round < rounds; ++round) {
    std::array<std::vector<double>, 3> offsets;
    auto add = [&](const Eigen::RowVector3d& d) {
      for (int a = 0; a < 3; ++a) offsets[static_cast<size_t>(a)].push_back(d[a]);
    };
    for (Eigen::Index v = 0; v < X->rows(); ++v) {
      double sq = 0;
      const int n = cloud_grid.nearest(X->row(v).transpose(), &sq, cap);
      if (n >= 0) add(cloud.row(n) - X->row(v));
    }
    const PointGrid body_grid(*X, cell);
    for (Eigen::Index i = 0; i < cloud.rows(); ++i) {
      double sq = 0;
      const int n = body_grid.nearest(cloud.row(i).transpose(), &sq, cap);
      if (n >= 0) add(cloud.row(i) - X->row(n));
    }
    if (offsets[0].size() < 10) break;
    const Eigen::RowVector3d shift(quantile(offsets[0], 0.5), quantile(offsets[1], 0.5), quantile(offsets[2], 0.5));
    X->rowwise() += shift;
    moved += shift;
    if (shift.norm() < 0.01) break;
  }
  return moved;
}

std::vector<LibraryPose> pose_library(const Eigen::MatrixXd& J) {
  const Anatomy body(J);
  std::vector<LibraryPose> lib;
  auto add = [&](const std::string& kind, const std::string& variant, const auto& make) {
    PartPose p;
    make(p);
    lib.push_back({variant.empty() ? kind : kind + " (" + variant + ")", kind, p});
  };
  // Standing, the arms' kinds.
  add("a_pose", "", [](PartPose&) {});
  add("arms_down", "", [&](PartPose& p) { body.arm_at_rest_elbow(p, 1, 20, 0), body.arm_at_rest_elbow(p, -1, 20, 0); });
  add("arms_touching", "", [&](PartPose& p) { body.arm_at_rest_elbow(p, 1, 4, 0), body.arm_at_rest_elbow(p, -1, 4, 0); });
  add("t_pose", "", [&](PartPose& p) { body.arms(p, 90, 0, 5); });
  add("arms_forward", "", [&](PartPose& p) { body.arms(p, 5, 90, 5); });
  add("arms_overhead", "", [&](PartPose& p) { body.arms(p, 160, 0, 10); });
  for (const double elbow : {90.0, 110.0})
    add("hands_on_hips", "elbows " + std::to_string(static_cast<int>(elbow)), [&](PartPose& p) { body.arms(p, 40, -15, elbow); });
  for (const double flexion : {30.0, 50.0})
    for (const double elbow : {105.0, 130.0})
      add("arms_crossed", std::to_string(static_cast<int>(flexion)) + "/" + std::to_string(static_cast<int>(elbow)),
          [&](PartPose& p) { body.arms(p, 25, flexion, elbow); });
  // The legs' kinds, either leg in front where the two differ.
  for (const double side : {1.0, -1.0}) {
    const std::string leg = side > 0 ? "left" : "right";
    add("raised_knee", leg, [&](PartPose& p) { body.leg(p, side, 90, 90); });
    add("lunge", leg, [&](PartPose& p) { body.leg(p, side, 60, 70), body.leg(p, -side, -20, 30); });
    add("stride", leg, [&](PartPose& p) { body.leg(p, side, 25, 10), body.leg(p, -side, -25, 25); });
    add("kneel_one_knee", leg, [&](PartPose& p) { body.leg(p, side, 90, 90), body.leg(p, -side, 0, 90); });
  }
  add("kneel_both_knees", "", [&](PartPose& p) { body.legs(p, 0, 90); });
  add("kneel_sitting_back", "", [&](PartPose& p) { body.legs(p, 60, 150); });
  add("squat", "half", [&](PartPose& p) { body.legs(p, 60, 80), body.spine(p, 10), body.arms(p, 10, 40, 20); });
  for (const double hip : {100.0, 120.0})
    add("squat", std::to_string(static_cast<int>(hip)),
        [&](PartPose& p) { body.legs(p, hip, hip + 25), body.spine(p, 20), body.arms(p, 10, 60, 10); });
  add("sit_chair", "", [&](PartPose& p) { body.legs(p, 90, 90), body.arm_at_rest_elbow(p, 1, 5, 0), body.arm_at_rest_elbow(p, -1, 5, 0); });
  add("sit_floor", "",
      [&](PartPose& p) { body.legs(p, 90, 5), body.arm_at_rest_elbow(p, 1, 20, 0), body.arm_at_rest_elbow(p, -1, 20, 0); });
  add("bend_forward", "", [&](PartPose& p) {
    p.root_rotation = 40 * kDeg * Eigen::Vector3d::UnitX();  // the pelvis tips forward, the legs stay upright
    body.legs(p, 40, 0), body.spine(p, 25);
    body.arm_at_rest_elbow(p, 1, 5, 65), body.arm_at_rest_elbow(p, -1, 5, 65);  // hanging
  });
  return lib;
}

namespace {

/// The largest angle (radians) between two poses' joint rotations and their pelvises' rotations.
double pose_distance(const PartPose& a, const PartPose& b) {
  double worst =
      Eigen::AngleAxisd(rotation_from_axis_angle(a.root_rotation).transpose() * rotation_from_axis_angle(b.root_rotation)).angle();
  for (size_t j = 0; j < a.joint_rotation.size(); ++j)
    worst = std::max(
        worst, Eigen::AngleAxisd(rotation_from_axis_angle(a.joint_rotation[j]).transpose() * rotation_from_axis_angle(b.joint_rotation[j]))
                   .angle());
  return worst;
}

}  // namespace

Eigen::RowVectorXd pose_row(const PartPose& pose) {
  Eigen::RowVectorXd row(3 * (1 + kNumJoints));
  row.head<3>() = pose.root_rotation.transpose();
  for (int j = 0; j < kNumJoints; ++j) row.segment<3>(3 + 3 * j) = pose.joint(j).transpose();
  return row;
}

PartPose pose_from_row(const Eigen::RowVectorXd& row) {
  if (row.size() != 3 * (1 + kNumJoints))
    throw InvalidInput("a stored pose has " + std::to_string(row.size()) + " values, " + std::to_string(3 * (1 + kNumJoints)) +
                       " expected");
  PartPose pose;
  pose.root_rotation = row.head<3>().transpose();
  for (int j = 0; j < kNumJoints; ++j) pose.joint(j) = row.segment<3>(3 + 3 * j).transpose();
  return pose;
}

std::vector<LibraryPose> distinct_motion_poses(const std::vector<LibraryPose>& frames, const std::vector<LibraryPose>& library,
                                               int max_poses, double min_degrees) {
  std::vector<LibraryPose> level;  // the frames, heading off, standing at the origin
  for (const LibraryPose& f : frames) {
    LibraryPose p = f;
    const Eigen::Matrix3d R = rotation_from_axis_angle(p.pose.root_rotation);
    const Eigen::Vector3d left = R * Eigen::Vector3d::UnitX();  // horizontal however far the body bends forward
    const double heading = std::atan2(-left.z(), left.x());
    p.pose.root_rotation = axis_angle_from_rotation(rotation_from_axis_angle(-heading * Eigen::Vector3d::UnitY()) * R);
    p.pose.root_translation.setZero();
    level.push_back(std::move(p));
  }
  std::vector<double> nearest(level.size(), std::numeric_limits<double>::infinity());
  for (size_t f = 0; f < level.size(); ++f)
    for (const LibraryPose& l : library) nearest[f] = std::min(nearest[f], pose_distance(level[f].pose, l.pose));
  std::vector<LibraryPose> chosen;
  while (static_cast<int>(chosen.size()) < max_poses && !level.empty()) {
    const size_t far = static_cast<size_t>(std::max_element(nearest.begin(), nearest.end()) - nearest.begin());
    if (nearest[far] < min_degrees * kDeg) break;
    chosen.push_back(level[far]);
    for (size_t f = 0; f < level.size(); ++f) nearest[f] = std::min(nearest[f], pose_distance(level[f].pose, level[far].pose));
  }
  return chosen;
}

namespace {

using VertexTargetPairs = std::vector<std::pair<Eigen::Index, Eigen::Index>>;

/// d x / d (c, translation) of the posed vertices `rows` (3 rows each): exact for a fixed pose, as
/// skinning is affine in the vertices and joints.
Eigen::MatrixXd shape_jacobian(const BodyModel& model, const PartPose& pose, const std::vector<int>& rows, int threads) {
  const ShapeSpace& S = model.space();
  const int K = S.components();
  const auto n = static_cast<Eigen::Index>(rows.size());
  using RowMajorX3 = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(3 * n, K + 3);
  for (Eigen::Index i = 0; i < n; ++i) A.block<3, 3>(3 * i, K).setIdentity();
  Eigen::MatrixXd X0;
  ShapedBody::skin(model, S.mean, part_transforms(pose, S.joint_mean), rows, &X0);
  parallel_for_ranges(
      K, threads,
      [&](long k0, long k1) {
        Eigen::MatrixXd Xk;
        for (long k = k0; k < k1; ++k) {
          const Eigen::MatrixXd Vk = S.mean + Eigen::Map<const RowMajorX3>(S.basis.col(k).data(), S.vertices(), 3);
          const Eigen::MatrixXd Jk = S.joint_mean + Eigen::Map<const RowMajorX3>(S.joint_basis.col(k).data(), S.joint_mean.rows(), 3);
          ShapedBody::skin(model, Vk, part_transforms(pose, Jk), rows, &Xk);
          Xk -= X0;
          for (Eigen::Index i = 0; i < n; ++i) A.block(3 * i, k, 3, 1) = Xk.row(i).transpose();
        }
      },
      1);
  return A;
}

/// Pairs (row of X, target point) both ways within max_d: every `target_stride`-th target point
/// and its nearest vertex; each vertex and its nearest target point where that is mutual (the
/// point's nearest vertex within 3 cm). Found in two halves on their own threads, kept in order (the
/// same pairs on any number of threads).
VertexTargetPairs mutual_pairs(const Eigen::MatrixXd& X, const Eigen::MatrixXd& P, const PointGrid& grid, Eigen::Index target_stride,
                               double max_d, int threads) {
  const PointGrid body_grid(X, 0.03);
  const Eigen::Index n = X.rows(), target_count = (P.rows() + target_stride - 1) / target_stride;
  std::array<VertexTargetPairs, 2> found;
  parallel_for_ranges(
      2, threads,
      [&](long h0, long h1) {
        for (long h = h0; h < h1; ++h) {
          auto& mine = found[static_cast<size_t>(h)];
          for (Eigen::Index s = h * (target_count + n) / 2; s < (h + 1) * (target_count + n) / 2; ++s) {
            double sq = 0, back = 0;
            if (s < target_count) {
              const Eigen::Index t = s * target_stride;
              const int i = body_grid.nearest(P.row(t).transpose(), &sq, max_d);
              if (i >= 0) mine.emplace_back(i, t);
              continue;
            }
            const Eigen::Index i = s - target_count;
            const int t = grid.nearest(X.row(i).transpose(), &sq, max_d);
            if (t < 0) continue;
            const int u = body_grid.nearest(P.row(t).transpose(), &back, max_d);
            if (u >= 0 && (X.row(u) - X.row(i)).norm() < 0.03) mine.emplace_back(i, t);
          }
        }
      },
      1);
  VertexTargetPairs pairs = std::move(found[0]);
  pairs.insert(pairs.end(), found[1].begin(), found[1].end());
  return pairs;
}

/// The shape fit's normal equations over its pairs: in (c, translation) H and g; with the pose, per
/// part the twist's 6 x 6 equations and their cross terms with (c, translation).
struct ShapeNormalEquations {
  Eigen::MatrixXd H;  ///< lower half summed
  Eigen::VectorXd g;
  double weight = 0;  ///< the pairs' Cauchy weights summed
  std::array<Eigen::Matrix<double, 6, 6>, kNumParts> H6;
  std::array<Eigen::Matrix<double, 6, 1>, kNumParts> b6;
  std::array<Eigen::MatrixXd, kNumParts> C;  ///< (K + 3) x 6
};

/// Sums the pairs' rows, in blocks (one buffer, no matrix of every pair's rows), the pairs in two
/// fixed halves on their own threads. A pair's three rows are sqrt(w) S (its rows of A, and its
/// offset) with S = sqrt(p2p) I + (sqrt(1 + p2p) - sqrt(p2p)) n n^T, the square root of
/// n n^T + p2p I: along the normal with a little point-to-point; w its Cauchy weight (sigma).
/// `part`: each row of X's part (with_pose).
ShapeNormalEquations shape_normal_equations(const Eigen::MatrixXd& A, const Eigen::MatrixXd& X, const Eigen::MatrixXd& normals,
                                            const Eigen::MatrixXd& P, const VertexTargetPairs& pairs, const std::vector<int>& part,
                                            bool with_pose, double sigma, double p2p, int threads) {
  const Eigen::Index unknowns = A.cols();
  constexpr Eigen::Index kBlock = 512;
  const auto m = static_cast<Eigen::Index>(pairs.size());
  std::array<ShapeNormalEquations, 2> half;
  const double a = std::sqrt(p2p), b = std::sqrt(1 + p2p) - std::sqrt(p2p);
  parallel_for_ranges(
      2, threads,
      [&](long h0, long h1) {
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> J(3 * kBlock, unknowns);
        Eigen::VectorXd r(3 * kBlock);
        for (long h = h0; h < h1; ++h) {
          ShapeNormalEquations& mine = half[static_cast<size_t>(h)];
          mine.H = Eigen::MatrixXd::Zero(unknowns, unknowns), mine.g = Eigen::VectorXd::Zero(unknowns);
          for (int q = 0; q < kNumParts && with_pose; ++q)
            mine.H6[static_cast<size_t>(q)].setZero(), mine.b6[static_cast<size_t>(q)].setZero(),
                mine.C[static_cast<size_t>(q)] = Eigen::MatrixXd::Zero(unknowns, 6);
          const Eigen::Index end = (h + 1) * m / 2;
          for (Eigen::Index start = h * m / 2; start < end; start += kBlock) {
            const Eigen::Index count = std::min(kBlock, end - start);
            for (Eigen::Index k = 0; k < count; ++k) {
              const auto [i, t] = pairs[static_cast<size_t>(start + k)];
              const Eigen::Vector3d x = X.row(i).transpose(), d = x - P.row(t).transpose(), nn = normals.row(i).transpose();
              const double along = nn.dot(d), w = 1 / (1 + (along * along + p2p * d.squaredNorm()) / (sigma * sigma));
              const Eigen::Matrix3d Sw = std::sqrt(w) * (a * Eigen::Matrix3d::Identity() + b * nn * nn.transpose());
              J.middleRows(3 * k, 3).noalias() = Sw * A.middleRows(3 * i, 3);
              r.segment<3>(3 * k) = Sw * d;
              mine.weight += w;
              if (!with_pose) continue;
              // The twist (t, w) of the vertex's part moves it by t - [x]x w.
              Eigen::Matrix<double, 3, 6> SJ0;
              SJ0.leftCols<3>() = Sw;
              SJ0.rightCols<3>().noalias() = -Sw * cross_product_matrix(x);
              const size_t q = static_cast<size_t>(part[static_cast<size_t>(i)]);
              mine.H6[q].noalias() += SJ0.transpose() * SJ0;
              mine.b6[q].noalias() += SJ0.transpose() * r.segment<3>(3 * k);
              mine.C[q].noalias() += J.middleRows(3 * k, 3).transpose() * SJ0;
            }
            const auto Jb = J.topRows(3 * count);
            mine.H.selfadjointView<Eigen::Lower>().rankUpdate(Jb.transpose());
            mine.g.noalias() += Jb.transpose() * r.head(3 * count);
          }
        }
      },
      1);
  ShapeNormalEquations sum = std::move(half[0]);
  sum.H += half[1].H, sum.g += half[1].g, sum.weight += half[1].weight;
  for (size_t q = 0; q < kNumParts && with_pose; ++q) sum.H6[q] += half[1].H6[q], sum.b6[q] += half[1].b6[q], sum.C[q] += half[1].C[q];
  return sum;
}

/// The pose's unknowns added to the shape's system `*H`, `*g` (of size K + 3 + 48): the pelvis's and
/// each joint's world rotation increment, about the pelvis's pivot and the posed joint centres; part
/// q's twist is B_q times them (its translation is the shape's unknown already).
void add_pose_unknowns(const ShapedBody& body, const PartPose& pose, const ShapeNormalEquations& e, Eigen::MatrixXd* H,
                       Eigen::VectorXd* g) {
  constexpr int kRotations = kPoseIncrementSize - 3;
  const Eigen::Index shape = e.g.size();
  const Eigen::MatrixXd& Jc = body.joint_centres();
  const PartTransforms T = body.part_motions(pose);
  const Eigen::Vector3d pivot =
      (Jc.row(kAbdomen - 1) + Jc.row(kLeftThigh - 1) + Jc.row(kRightThigh - 1)).transpose() / 3 + pose.root_translation;
  for (int q = 0; q < kNumParts; ++q) {
    Eigen::Matrix<double, 6, kRotations> B = Eigen::Matrix<double, 6, kRotations>::Zero();
    B.block<3, 3>(0, 0) = cross_product_matrix(pivot);
    B.block<3, 3>(3, 0).setIdentity();
    for (int j = q - 1; j >= 0; j = part_parent(j + 1) - 1) {  // the joints that move part q
      const size_t parent = static_cast<size_t>(part_parent(j + 1));
      B.block<3, 3>(0, 3 + 3 * j) = cross_product_matrix(T.R[parent] * Jc.row(j).transpose() + T.t[parent]);
      B.block<3, 3>(3, 3 + 3 * j).setIdentity();
    }
    const size_t p = static_cast<size_t>(q);
    H->block(0, shape, shape, kRotations).noalias() += e.C[p] * B;
    H->bottomRightCorner<kRotations, kRotations>().noalias() += B.transpose() * e.H6[p] * B;
    g->tail<kRotations>().noalias() += B.transpose() * e.b6[p];
  }
  H->block(shape, 0, kRotations, shape) = H->block(0, shape, shape, kRotations).transpose();
  // A little Levenberg damping: joints the pairs hardly see (a hand's twist) stay put.
  H->diagonal().tail<kRotations>() += 1e-3 * H->diagonal().tail<kRotations>() + Eigen::VectorXd::Constant(kRotations, 1e-6 * e.weight);
}

/// One shape least-squares round set (at most `rounds` Gauss-Newton steps on the coefficients):
/// pairs both ways between the working cloud P and sampled vertices, point-to-plane with a little
/// point-to-point, Cauchy weights, and the Gaussian prior of BodyFitOptions::shape_prior. The body's
/// translation moves too; with `with_pose` every joint's rotation as well (the pose's Jacobian by
/// parts, as fit_pose's), so that a shape change the pose must follow (wider shoulders, arms hung
/// from them at another angle) is found in one step instead of in turns.
Eigen::VectorXd fit_shape(const BodyModel& model, Eigen::VectorXd c, PartPose* pose_io, const Eigen::MatrixXd& P, const PointGrid& grid,
                          const BodyFitOptions& o, int rounds = 4, bool with_pose = false) {
  PartPose& pose = *pose_io;
  const int K = model.components();
  const std::vector<int> rows = spread_rows(model.space().mean, 0.02);
  std::vector<int> part(rows.size());
  for (size_t i = 0; i < rows.size(); ++i) part[i] = model.vertex_parts()[rows[i]];
  Eigen::MatrixXd A = shape_jacobian(model, pose, rows, o.threads);
  const double max_d = 0.08, sigma = 0.03, p2p = 0.1;
  const Eigen::Index target_stride = std::max<Eigen::Index>(1, P.rows() / 8000);  // about 8,000 target points
  for (int round = 0; round < rounds; ++round) {
    Eigen::MatrixXd full;
    const ShapedBody body(model, c);
    body.pose(pose, &full);
    const Eigen::MatrixXd X = full(rows, Eigen::all), normals = vertex_normals(full, model.faces())(rows, Eigen::all);
    const ShapeNormalEquations e = shape_normal_equations(A, X, normals, P, mutual_pairs(X, P, grid, target_stride, max_d, o.threads), part,
                                                          with_pose, sigma, p2p, o.threads);
    if (e.weight <= 0) break;
    const Eigen::Index N = K + 3 + (with_pose ? kPoseIncrementSize - 3 : 0);
    Eigen::MatrixXd H = Eigen::MatrixXd::Zero(N, N);
    Eigen::VectorXd g = Eigen::VectorXd::Zero(N);
    H.topLeftCorner(K + 3, K + 3) = e.H.selfadjointView<Eigen::Lower>();
    g.head(K + 3) = e.g;
    if (with_pose) add_pose_unknowns(body, pose, e, &H, &g);
    const double lambda = e.weight * o.shape_prior * o.shape_prior;
    H.diagonal().head(K).array() += lambda;
    H.diagonal().segment<3>(K).array() += 1e-9 * e.weight;
    g.head(K) += lambda * c;
    const Eigen::VectorXd step = H.ldlt().solve(-g);
    if (!step.allFinite()) break;
    c += step.head(K);
    if (with_pose) {
      Eigen::VectorXd increment(kPoseIncrementSize);
      increment << step.segment<3>(K), step.tail(N - K - 3);
      apply_pose_increment(&pose, increment);
      A = shape_jacobian(model, pose, rows, o.threads);
    } else {
      pose.root_translation += step.segment<3>(K);
    }
    if (step.norm() < 0.01) break;
  }
  return c;
}

/// The target seen with one up direction: turned so that it points +Y, and a coarse and a sparse
/// sample of it.
struct UpFrame {
  Eigen::Matrix3d rotation;  ///< target frame -> this frame
  Eigen::MatrixXd cloud, coarse, sparse;
  std::unique_ptr<PointGrid> coarse_grid, sparse_grid;
  Ground coarse_ground;  ///< where the search stands its starts (on the coarse samples)
};

/// Seconds per named stage: lap(stage) adds the time since the last lap to the stage's.
/// The working cloud W seen with each of the up directions `ups` (about its centre).
std::vector<UpFrame> up_frames(const Eigen::MatrixXd& W, const Eigen::RowVector3d& centre, const std::vector<Eigen::Vector3d>& ups) {
  std::vector<UpFrame> frames(ups.size());
  for (size_t u = 0; u < ups.size(); ++u) {
    UpFrame& f = frames[u];
    f.rotation = Eigen::Quaterniond::FromTwoVectors(ups[u].normalized(), Eigen::Vector3d::UnitY()).toRotationMatrix();
    f.cloud = (W.rowwise() - centre) * f.rotation.transpose();
    f.coarse = every(f.cloud, std::max<Eigen::Index>(1, W.rows() / 700));
    f.coarse_grid = std::make_unique<PointGrid>(f.coarse, kCoarseCell);
    f.coarse_ground = ground_of(f.coarse);
    f.sparse = every(f.cloud, std::max<Eigen::Index>(1, W.rows() / 200));
    f.sparse_grid = std::make_unique<PointGrid>(f.sparse, 2 * kCoarseCell);
  }
  return frames;
}

/// How a start is placed and scored: on the sparse samples; on the coarse ones; centred on the coarse
/// ones (centre_on_cloud) and scored there.
enum class Placed { kSparse, kCoarse, kCentred };

/// A start of the articulated fit: a library pose at a heading, placed on one up frame's cloud.
struct Start {
  double score = 0;  ///< mismatch of the mean body so placed (m)
  size_t up = 0;
  int heading = 0;
  std::string name, kind;
  PartPose pose;
};

/// The search's placements scored on the sparse samples only, and the up directions the motion
/// poses were placed on.
struct SparsePlacements {
  std::vector<Start> starts;
  std::vector<size_t> motion_ups;
};

/// The global search for starts of the articulated fit, in stages: the library at every up
/// direction and heading (library_starts), the legs searched on the best of those (with_legs_searched),
/// and the arms of every library pose on the best few (with_arms_mixed). Each start is the mean body
/// placed on the cloud (its feet on the cloud's lowest points, its median point over the cloud's:
/// stand_on_cloud) and scored on a sparse sample (a fifth of the body's coarse vertices, 200 target
/// points) or a coarse one (700 target points; the best starts and those of the later stages centred
/// on them first: centre_on_cloud). Every stage returns its starts best first.
class StartSearch {
 public:
  StartSearch(const BodyModel& model, const ShapedBody& mean_body, const std::vector<UpFrame>& frames, int threads)
      : model_(model),
        mean_body_(mean_body),
        frames_(frames),
        threads_(threads),
        sample_rows_(spread_rows(mean_body.rest_vertices(), 0.04)) {
    const std::set<int> legs = {kLeftThigh, kLeftShank, kLeftFoot, kRightThigh, kRightShank, kRightFoot};
    for (size_t i = 0; i < sample_rows_.size(); ++i) {
      const auto& weights = model.part_weights()[static_cast<size_t>(sample_rows_[i])];
      if (std::any_of(weights.begin(), weights.end(), [&](const auto& w) { return legs.count(w.first) > 0; }))
        leg_sample_.push_back(static_cast<Eigen::Index>(i)), leg_rows_.push_back(sample_rows_[i]);
    }
  }

  /// Every library pose at `headings` headings on every up frame, and the model's motion poses on the
  /// two up directions the library liked best, on the sparse samples; the best `rescored` of those
  /// again on the coarse ones.
  std::vector<Start> library_starts(const std::vector<LibraryPose>& library, const std::vector<LibraryPose>& motion_poses, int headings,
                                    int rescored, SparsePlacements* sparse) const {
    std::vector<size_t> all_ups(frames_.size());
    for (size_t u = 0; u < frames_.size(); ++u) all_ups[u] = u;
    std::vector<Start> starts = place_all(library, all_ups, headings);
    std::sort(starts.begin(), starts.end(), by_score);
    // The motion poses only on the two best up directions: they are many, and the vertical is told
    // by the library's standing, kneeling and sitting poses alike.
    sparse->motion_ups.clear();
    if (!motion_poses.empty()) {
      for (const Start& s : starts)
        if (sparse->motion_ups.size() < 2 &&
            std::find(sparse->motion_ups.begin(), sparse->motion_ups.end(), s.up) == sparse->motion_ups.end())
          sparse->motion_ups.push_back(s.up);
      std::vector<Start> more = place_all(motion_poses, sparse->motion_ups, headings);
      starts.insert(starts.end(), more.begin(), more.end());
    }
    sparse->starts = starts;
    return rescored_best(std::move(starts), rescored);
  }

  /// `starts` and, on every up direction, its own best `per_up` placements of the library and the
  /// model's motion poses (those of `sparse`, the motion poses placed on the other directions too),
  /// each with the arms of every library pose on its best three: library_starts keeps the best over
  /// all directions, and a crouch with the back bent had its library poses upside down fill them and
  /// its upright start (a motion pose with the arms forward) cut before its arms were tried.
  std::vector<Start> with_best_of_every_up(std::vector<Start> starts, const SparsePlacements& sparse,
                                           const std::vector<LibraryPose>& library, const std::vector<LibraryPose>& motion_poses,
                                           int headings, int per_up) const {
    for (size_t u = 0; u < frames_.size(); ++u) {
      std::vector<Start> placed;
      for (const Start& s : sparse.starts)
        if (s.up == u) placed.push_back(s);
      if (std::find(sparse.motion_ups.begin(), sparse.motion_ups.end(), u) == sparse.motion_ups.end()) {
        const std::vector<Start> motion = place_all(motion_poses, {u}, headings);
        placed.insert(placed.end(), motion.begin(), motion.end());
      }
      const std::vector<Start> best = with_arms_mixed(rescored_best(std::move(placed), per_up), library);
      starts.insert(starts.end(), best.begin(), best.end());
    }
    std::sort(starts.begin(), starts.end(), by_score);
    return starts;
  }

  /// `starts` and, on the best start of each of the `count` best pairs of up direction and heading,
  /// the legs searched, the body placed on the cloud again for every option: a library pose's legs go
  /// together, a person's need not (one thigh raised, the other knee bent back), and such a body
  /// matched the library better on its side or facing away than upright with the library's legs.
  /// Both legs together first, on the sparse samples (the placement, on the lowest point, depends on
  /// both: one at a time stopped at a thigh raised 30 degrees of 76), then each on its own with the
  /// thighs also spread.
  std::vector<Start> with_legs_searched(std::vector<Start> starts, int count) const {
    std::vector<Start> legged;
    for (const Start& s : starts)
      if (static_cast<int>(legged.size()) < count &&
          std::none_of(legged.begin(), legged.end(), [&](const Start& t) { return t.up == s.up && t.heading == s.heading; }))
        legged.push_back(s);
    const Eigen::MatrixXd& J = mean_body_.joint_centres();
    const std::array<std::vector<std::array<Eigen::Vector3d, 2>>, 2> each = {leg_options(J, 1), leg_options(J, -1)},
                                                                     pairs = {leg_options(J, 1, false), leg_options(J, -1, false)};
    std::array<std::array<size_t, 3>, 2> joints;
    for (int i = 0; i < 2; ++i) {
      const std::string s = i == 0 ? "left_" : "right_";
      joints[static_cast<size_t>(i)] = {static_cast<size_t>(find_joint_index(s + "hip")), static_cast<size_t>(find_joint_index(s + "knee")),
                                        static_cast<size_t>(find_joint_index(s + "ankle"))};
    }
    auto set_leg = [&](PartPose* pose, int side, const std::array<Eigen::Vector3d, 2>& option) {
      const auto& [hip, knee, ankle] = joints[static_cast<size_t>(side)];
      pose->joint_rotation[hip] = option[0], pose->joint_rotation[knee] = option[1], pose->joint_rotation[ankle].setZero();
    };
    parallel_for_ranges(
        static_cast<long>(legged.size()), threads_,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            Start& best = legged[static_cast<size_t>(k)];
            const std::string name = best.name + ", legs searched", kind = best.kind + "+legs";
            Start pair = place(best.up, best.heading, best.pose, name, kind, Placed::kSparse);
            const PartPose base = best.pose;
            // The legs move only the sample rows a leg part weighs on: the rest skinned once.
            Eigen::MatrixXd X, legs_X;
            ShapedBody::skin(model_, mean_body_.rest_vertices(), mean_body_.part_motions(base), sample_rows_, &X);
            for (const auto& left : pairs[0])
              for (const auto& right : pairs[1]) {
                PartPose pose = base;
                set_leg(&pose, 0, left), set_leg(&pose, 1, right);
                ShapedBody::skin(model_, mean_body_.rest_vertices(), mean_body_.part_motions(pose), leg_rows_, &legs_X);
                for (size_t i = 0; i < leg_sample_.size(); ++i) X.row(leg_sample_[i]) = legs_X.row(static_cast<Eigen::Index>(i));
                const Start candidate = place_skinned(best.up, best.heading, pose, X, name, kind, Placed::kSparse, pair.score);
                if (candidate.score < pair.score) pair = candidate;
              }
            // Each leg's options compared as placed (not centred: 96 centrings per start made a
            // fit searching twice 0.5-1 s slower, and one random pose of 40 was refused), the
            // chosen one centred.
            best = place(best.up, best.heading, pair.pose, name, kind, Placed::kCoarse);
            for (const int side : {0, 1}) {
              const PartPose held = best.pose;
              for (const auto& option : each[static_cast<size_t>(side)]) {
                PartPose pose = held;
                set_leg(&pose, side, option);
                const Start candidate = place(best.up, best.heading, pose, name, kind, Placed::kCoarse, best.score);
                if (candidate.score < best.score) best = candidate;
              }
            }
            best = place(best.up, best.heading, best.pose, name, kind, Placed::kCentred);
          }
        },
        1);
    starts.insert(starts.end(), legged.begin(), legged.end());
    std::sort(starts.begin(), starts.end(), by_score);
    return starts;
  }

  /// `starts` and the arms of every library pose on the best three (legs and arms combine freely:
  /// sitting with the arms out, kneeling with hands on hips).
  std::vector<Start> with_arms_mixed(std::vector<Start> starts, const std::vector<LibraryPose>& library) const {
    std::vector<int> arm_joints;
    for (const char* side : {"left_", "right_"})
      for (const char* joint : {"shoulder", "elbow", "wrist"}) arm_joints.push_back(find_joint_index(std::string(side) + joint));
    auto arms_of = [&](const PartPose& p) {
      std::vector<Eigen::Vector3d> a;
      for (int j : arm_joints) a.push_back(p.joint(j));
      return a;
    };
    std::vector<Start> mixed;  // unplaced first, then placed on the threads
    for (size_t k = 0; k < std::min<size_t>(3, starts.size()); ++k) {
      std::vector<std::vector<Eigen::Vector3d>> seen = {arms_of(starts[k].pose)};
      for (const LibraryPose& lib : library) {
        const auto arms = arms_of(lib.pose);
        if (std::find(seen.begin(), seen.end(), arms) != seen.end()) continue;
        seen.push_back(arms);
        Start m = starts[k];
        for (size_t i = 0; i < arm_joints.size(); ++i) m.pose.joint(arm_joints[i]) = arms[i];
        m.name += ", arms as " + lib.name, m.kind += "+" + lib.kind;
        mixed.push_back(std::move(m));
      }
    }
    parallel_for_ranges(
        static_cast<long>(mixed.size()), threads_,
        [&](long begin, long end) {
          for (long i = begin; i < end; ++i) {
            Start& m = mixed[static_cast<size_t>(i)];
            m = place(m.up, m.heading, m.pose, m.name, m.kind, Placed::kCentred);
          }
        },
        1);
    starts.insert(starts.end(), mixed.begin(), mixed.end());
    std::sort(starts.begin(), starts.end(), by_score);
    return starts;
  }

 private:
  static bool by_score(const Start& a, const Start& b) { return a.score < b.score; }

  /// `bound`: see mismatch (a search for the best placement passes the best score so far).
  Start place(size_t u, int heading, PartPose pose, const std::string& name, const std::string& kind, Placed how,
              double bound = std::numeric_limits<double>::infinity()) const {
    Eigen::MatrixXd X;
    ShapedBody::skin(model_, mean_body_.rest_vertices(), mean_body_.part_motions(pose), sample_rows_, &X);
    return place_skinned(u, heading, std::move(pose), std::move(X), name, kind, how, bound);
  }

  /// place() of a pose whose sample rows are skinned already (X).
  Start place_skinned(size_t u, int heading, PartPose pose, Eigen::MatrixXd X, const std::string& name, const std::string& kind, Placed how,
                      double bound = std::numeric_limits<double>::infinity()) const {
    const Eigen::Vector3d placed = pose.root_translation;
    stand_on(X, frames_[u].coarse_ground, &pose);
    X.rowwise() += (pose.root_translation - placed).transpose();
    // The median points meet, not the boxes' centres: those follow the limbs, and a start with other
    // arms than the target's lay beside its trunk (a random pose's own true pose scored 0.073 m so
    // placed, the library's best start 0.149). Centred on the coarse samples only: the sparse scores
    // of the whole library are many, and a bound cuts most of them short.
    if (how == Placed::kCentred)
      pose.root_translation += centre_on_cloud(frames_[u].coarse, *frames_[u].coarse_grid, 0.15, kCoarseCell, 3, &X).transpose();
    const double score = how == Placed::kSparse
                             ? mismatch(every(X, kSparseStride), frames_[u].sparse, *frames_[u].sparse_grid, 0.15, 2 * kCoarseCell, bound)
                             : mismatch(X, frames_[u].coarse, *frames_[u].coarse_grid, 0.15, kCoarseCell, bound);
    return Start{score, u, heading, name, kind, pose};
  }

  /// Every pose of `poses` at every heading on each of the up frames `ups`, on the sparse samples.
  /// The best `count` of `starts` (sparse scores), placed again and scored on the coarse samples, the
  /// best kCentred of those centred and scored again; best first.
  std::vector<Start> rescored_best(std::vector<Start> starts, int count) const {
    std::sort(starts.begin(), starts.end(), by_score);
    starts.resize(std::min(starts.size(), static_cast<size_t>(std::max(1, count))));
    parallel_for_ranges(
        static_cast<long>(starts.size()), threads_,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            Start& s = starts[static_cast<size_t>(k)];
            s = place(s.up, s.heading, s.pose, s.name, s.kind, Placed::kCoarse);
          }
        },
        1);
    std::sort(starts.begin(), starts.end(), by_score);
    const long centred = std::min<long>(kCentred, static_cast<long>(starts.size()));
    parallel_for_ranges(
        centred, threads_,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            Start& s = starts[static_cast<size_t>(k)];
            s = place(s.up, s.heading, s.pose, s.name, s.kind, Placed::kCentred);
          }
        },
        1);
    std::sort(starts.begin(), starts.end(), by_score);
    return starts;
  }

  std::vector<Start> place_all(const std::vector<LibraryPose>& poses, const std::vector<size_t>& ups, int headings) const {
    const long per_up = static_cast<long>(poses.size()) * headings;
    std::vector<Start> placed(ups.size() * static_cast<size_t>(per_up));
    parallel_for_ranges(
        static_cast<long>(placed.size()), threads_,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            const size_t u = ups[static_cast<size_t>(k / per_up)];
            const LibraryPose& lib = poses[static_cast<size_t>((k % per_up) / headings)];
            const int h = static_cast<int>(k % headings);
            PartPose pose = lib.pose;
            pose.root_rotation = axis_angle_from_rotation(rotation_from_axis_angle(2 * M_PI * h / headings * Eigen::Vector3d::UnitY()) *
                                                          rotation_from_axis_angle(pose.root_rotation));
            placed[static_cast<size_t>(k)] = place(u, h, pose, lib.name, lib.kind, Placed::kSparse);
          }
        },
        1);
    return placed;
  }

  static constexpr Eigen::Index kSparseStride = 5;
  /// The best coarse placements centred (centre_on_cloud) and scored again. Stood by the median points,
  /// with these 30 and the later stages' starts centred 20 of 20 random poses fitted within both bars,
  /// without 19; the 400-body set's median fit took 1.21 s against 1.16. (Stood by the boxes' centres,
  /// centring all 300 fitted 18, the best 30 19.)
  static constexpr long kCentred = 30;
  const BodyModel& model_;
  const ShapedBody& mean_body_;
  const std::vector<UpFrame>& frames_;
  int threads_;
  std::vector<int> sample_rows_;
  std::vector<Eigen::Index> leg_sample_;  ///< the sample rows a leg part weighs on (places in sample_rows_)
  std::vector<int> leg_rows_;             ///< and their vertices
};

/// Each target point's part (its nearest fitted vertex's) and distance to the fitted body (out->V);
/// a point farther than kOutlier is labelled -1. (An unbounded search from far away also visits
/// every empty cell between.)
void label_target(const BodyModel& model, const Eigen::MatrixXd& T, int threads, BodyFit* out) {
  const PointGrid body_grid(out->V, 0.02);
  out->target_part.resize(T.rows());
  out->target_distance.resize(T.rows());
  const Eigen::VectorXi& part = model.vertex_parts();
  parallel_for_ranges(T.rows(), threads, [&](long begin, long end) {
    for (Eigen::Index i = begin; i < end; ++i) {
      double sq = 0;
      const int v = body_grid.nearest(T.row(i).transpose(), &sq, kOutlier);
      out->target_part[i] = v >= 0 ? part[v] : -1;
      out->target_distance[i] = v >= 0 ? std::sqrt(sq) : std::numeric_limits<double>::infinity();
    }
  });
}

/// What tells a fit's confidence, read off the fitted body (out->V, in the target's frame) against
/// the working cloud W: its distances to the fitted surface, coverage, each part's and limb's.
void read_off_fit(const BodyModel& model, const Eigen::MatrixXd& W, const BodyFitOptions& o, const std::vector<std::string>& pose_warnings,
                  BodyFit* out) {
  const PointGrid body_grid(out->V, 0.02);
  const Eigen::VectorXi& part = model.vertex_parts();
  // The working cloud's distances to the fitted surface (not its vertices, 1-3 cm apart on the trunk).
  const TriangleTree surface(out->V, model.faces());
  std::vector<double> d(static_cast<size_t>(W.rows()));
  double sum = 0;
  for (Eigen::Index i = 0; i < W.rows(); ++i) {
    Eigen::Vector3d point;
    double distance = kOutlier;
    if (surface.closest(W.row(i).transpose(), &point, &distance, kOutlier) < 0) distance = kOutlier;
    d[static_cast<size_t>(i)] = distance;
    sum += distance;
  }
  out->target_mean = sum / static_cast<double>(W.rows());
  out->target_p95 = quantile(d, 0.95);
  const PointGrid cloud_grid(W, 0.03);
  int covered = 0;
  for (Eigen::Index v = 0; v < out->V.rows(); ++v) {
    double sq = 0;
    covered += cloud_grid.nearest(out->V.row(v).transpose(), &sq, 0.02) >= 0;
  }
  out->coverage = static_cast<double>(covered) / static_cast<double>(out->V.rows());
  out->shape_mahalanobis = out->coefficients.norm();

  std::ostringstream msg;
  msg.precision(1);
  msg << std::fixed;
  auto reason = [&] { out->reasons.push_back(msg.str()), msg.str(""); };
  if (out->coverage < o.min_coverage)
    msg << "only " << 100 * out->coverage << "% of the fitted body lies within 2 cm of the target", reason();
  if (out->target_p95 > o.max_target_p95)
    msg << "a twentieth of the target lies over " << 1000 * out->target_p95 << " mm from the fitted body", reason();
  // |c| of a population member follows a chi distribution with K degrees of freedom.
  const double K = static_cast<double>(model.components());
  const double chi_mean = std::sqrt(std::max(0.5, K - 0.5)), chi_sd = std::sqrt(0.5);
  if (out->shape_mahalanobis > chi_mean + o.max_shape_sigma * chi_sd)
    msg << "the fitted shape lies " << (out->shape_mahalanobis - chi_mean) / chi_sd << " standard deviations outside the population ("
        << model.space().population << ")",
        reason();
  for (const auto& w : pose_warnings)
    if (w.find("beyond its range of motion") != std::string::npos) out->reasons.push_back(w);
  // A limb or trunk part the target does not show near it: placed wrongly (scans cut heads, hands
  // and feet, so those may go unseen).
  std::array<int, kNumParts> seen{}, all{};
  for (Eigen::Index v = 0; v < out->V.rows(); ++v) {
    double sq = 0;
    ++all[static_cast<size_t>(part[v])];
    seen[static_cast<size_t>(part[v])] += cloud_grid.nearest(out->V.row(v).transpose(), &sq, 0.03) >= 0;
  }
  for (int p = 0; p < kNumParts; ++p)
    if (p != kHead && p != kLeftHand && p != kRightHand && p != kLeftFoot && p != kRightFoot && all[static_cast<size_t>(p)] > 0 &&
        seen[static_cast<size_t>(p)] < o.min_part_coverage * all[static_cast<size_t>(p)])
      msg << "only " << 100.0 * seen[static_cast<size_t>(p)] / all[static_cast<size_t>(p)] << "% of the fitted " << part_name(p)
          << " lies within 3 cm of the target",
          reason();
  // An arm or leg lying along the target's but bent or turned elsewhere (an elbow 8 cm behind the
  // real one) is near the target nearly everywhere, but leaves some of the target's limb unexplained:
  // a twentieth of the whole target hardly notices a forearm. Asked of the target, not of the fitted
  // body, so that surface a scanner did not see (the inside of an arm at the torso) does not count.
  std::array<int, kNumParts> labelled{}, explained{};
  for (Eigen::Index i = 0; i < W.rows(); ++i) {
    double sq = 0;
    const int v = body_grid.nearest(W.row(i).transpose(), &sq, kOutlier);
    if (v < 0) continue;
    ++labelled[static_cast<size_t>(part[v])];
    explained[static_cast<size_t>(part[v])] += d[static_cast<size_t>(i)] <= o.limb_close_distance;
  }
  for (int p : {kLeftUpperArm, kLeftForearm, kRightUpperArm, kRightForearm, kLeftThigh, kLeftShank, kRightThigh, kRightShank})
    if (labelled[static_cast<size_t>(p)] >= 20 &&
        explained[static_cast<size_t>(p)] < o.min_limb_explained * labelled[static_cast<size_t>(p)])
      msg << "only " << 100.0 * explained[static_cast<size_t>(p)] / labelled[static_cast<size_t>(p)]
          << "% of the target nearest the fitted " << part_name(p) << " lies within " << 1000 * o.limb_close_distance
          << " mm of it (the limb bent or turned elsewhere)",
          reason();
  out->warnings = pose_warnings;
  out->confident = out->reasons.empty();
}

}  // namespace

namespace {

/// A brief articulated fit from `start` (its prior pulling towards it) on one thread; *score: the
/// fitted body's mismatch over the rows `spread`.
PartPose brief_fit(const BodyModel& model, const Eigen::MatrixXd& cloud, const PartPose& start, const PoseFitOptions& brief,
                   const ScoreRows& spread, const BodyFitOptions& o, double* score) {
  const Eigen::VectorXd zero = Eigen::VectorXd::Zero(model.components());
  PoseFitOptions mine = brief;
  mine.start = mine.prior_pose = start;
  const PointGrid grid(cloud, 0.03);
  BodyFitOptions one_thread = o;
  one_thread.threads = 1;
  // Fitted with the shape fitted at the start (two Gauss-Newton steps), not the mean shape: a pelvis
  // fitted with another body's buttocks and thighs tipped 16-18 degrees in a squat, the lower back
  // and hips making up for it, and the later shape fits settled in that tilt.
  const Eigen::VectorXd start_shape = fit_shape(model, zero, &mine.start.value(), cloud, grid, one_thread, 2);
  const PoseFitResult r = fit_pose(ShapedBody(model, start_shape), cloud, mine);
  // Scored with the shape fitted to it (two Gauss-Newton steps): with the mean shape the body's own
  // proportions (3 cm) outweighed a forearm turned wrong.
  PartPose shaped_pose = r.pose;
  const Eigen::VectorXd c = fit_shape(model, zero, &shaped_pose, cloud, grid, one_thread, 2);
  Eigen::MatrixXd X;
  ShapedBody(model, c).pose(shaped_pose, &X);
  *score = mismatch(X(spread.rows, Eigen::all), cloud, grid, 0.15, 0.03, std::numeric_limits<double>::infinity(), spread.scored);
  return r.pose;
}

/// Each arm, then each leg, on its own from `pose`: the options of arm_options and leg_options scored
/// on the coarse samples, the best kept limb by limb. Arms are where whole-body starts miss most (hands
/// on hips, arms crossed) and the options of two arms multiply; a library pose's legs go together, a
/// person's need not. `changed`: whether any limb moved.
PartPose limbs_one_by_one(const BodyModel& model, const ShapedBody& mean_body, const UpFrame& frame, const ScoreRows& coarse_rows,
                          PartPose pose, int threads, bool* changed) {
  auto score_of = [&](const PartPose& p, double bound) {
    Eigen::MatrixXd X;
    ShapedBody::skin(model, mean_body.rest_vertices(), mean_body.part_motions(p), coarse_rows.rows, &X);
    return mismatch(X, frame.coarse, *frame.coarse_grid, 0.15, kCoarseCell, bound, coarse_rows.scored);
  };
  double score = score_of(pose, std::numeric_limits<double>::infinity());
  *changed = false;
  struct Limb {
    const char *first, *second, *end;  // the end joint goes to rest with each option
    bool arm;
  };
  for (const Limb& limb : {Limb{"shoulder", "elbow", "wrist", true}, Limb{"hip", "knee", "ankle", false}})
    for (const double side : {1.0, -1.0}) {
      const std::string s = side > 0 ? "left_" : "right_";
      const auto first = static_cast<size_t>(find_joint_index(s + limb.first)),
                 second = static_cast<size_t>(find_joint_index(s + limb.second)), end = static_cast<size_t>(find_joint_index(s + limb.end));
      std::vector<PartPose> candidates;
      for (const auto& option : limb.arm ? arm_options(mean_body.joint_centres(), side) : leg_options(mean_body.joint_centres(), side)) {
        PartPose& candidate = candidates.emplace_back(pose);
        candidate.joint_rotation[first] = option[0], candidate.joint_rotation[second] = option[1];
        candidate.joint_rotation[end].setZero();
      }
      // Each scored up to the pose's own score: a candidate that reaches it is not kept.
      std::vector<double> scores(candidates.size());
      parallel_for_ranges(
          static_cast<long>(candidates.size()), threads,
          [&](long begin, long end_) {
            for (long i = begin; i < end_; ++i) scores[static_cast<size_t>(i)] = score_of(candidates[static_cast<size_t>(i)], score);
          },
          1);
      PartPose best = pose;
      for (size_t i = 0; i < candidates.size(); ++i)  // the first best in the options' order
        if (scores[i] < score) score = scores[i], best = candidates[i], *changed = true;
      pose = best;
    }
  return pose;
}

/// Shape and pose from `pose`: o.shape_rounds rounds of fit_shape (the pose moving with the shape)
/// and a brief articulated refit with the joints' priors, then the final articulated refinement; the
/// joint priors pull towards `recognised`. Leaves the pose in `pose`, the coefficients in `c`.
PoseFitResult fit_shape_and_pose(const BodyModel& model, const UpFrame& frame, const PointGrid& grid, const BodyFitOptions& o,
                                 const PartPose& recognised, PartPose* pose, Eigen::VectorXd* c) {
  *c = Eigen::VectorXd::Zero(model.components());
  PoseFitOptions refine;
  refine.prior_pose = recognised;
  // A limb's twist about its bone hardly shows on the surface (an elbow turned one way, the wrist
  // back): pulled as hard as the swing towards the recognised pose's, the robustness set's mean
  // joint-angle error fell from 6.1 to 4.2 degrees over 15 bodies (standing, sitting, bending,
  // tilted), joints as close.
  refine.refinement_twist_weight = 1;
  refine.threads = o.threads;
  // A refinement crawling on ends: on a 940k-point scan the final refinement took 60 steps, the last
  // 50 lowering the objective by 0.15% in all. Ended at 1e-3 over 5 steps, the robustness set's 117
  // fits came out as accurate (joint angles and girths to the tenth, joints 0.01 mm apart on
  // average) and `eval bodies` took 203-219 s in two runs instead of 249.
  refine.stall_window = 5;
  refine.stall_gain = 1e-3;
  PoseFitResult result;
  for (int round = 0; round <= o.shape_rounds; ++round) {
    if (round > 0) *c = fit_shape(model, *c, pose, frame.cloud, grid, o, 4, true);
    refine.start = *pose;
    if (round < o.shape_rounds) refine.iterations = 8, refine.refinement_model_samples = 3000;  // brief: the shape moves on
    else refine.iterations = 100, refine.refinement_model_samples = 12000;
    result = fit_pose(ShapedBody(model, *c, o.threads), frame.cloud, refine);
    *pose = result.pose;
  }
  return result;
}

/// The stages of fit_body_model over one target (after COLMAP's IncrementalMapper): the working
/// cloud and its up frames, brief fits of the best starts, and a brief fit finished into the result.
class BodyFitter {
 public:
  BodyFitter(const BodyModel& model, const Eigen::MatrixXd& T, const BodyFitOptions& o)
      : model_(model), o_(o), mean_body_(model, Eigen::VectorXd::Zero(model.components())) {
    if (T.rows() < 100 || T.cols() != 3 || !T.allFinite())
      throw InvalidInput("body fit: the target has " + std::to_string(T.rows()) + " points (at least 100 finite ones needed)");
    W_ = working_cloud(T, o.working_cell);
    if (W_.rows() < 100)
      throw InvalidInput("body fit: the target covers only " + std::to_string(W_.rows()) + " cells of " + std::to_string(o.working_cell) +
                         " m; is it in metres?");
    centre_ = W_.colwise().mean();
    library_ = pose_library(mean_body_.joint_centres());
    const ShapeSpace& space = model.space();
    for (Eigen::Index p = 0; p < space.poses.rows(); ++p) {  // the model's own poses, from motion capture
      const std::string& name = space.pose_names[static_cast<size_t>(p)];
      motion_poses_.push_back({name, name, pose_from_row(space.poses.row(p))});
    }
    ups_ = o.up_candidates;
    if (ups_.empty())
      for (int a = 0; a < 3; ++a) ups_.push_back(Eigen::Vector3d::Unit(a)), ups_.push_back(-Eigen::Vector3d::Unit(a));
    frames_ = up_frames(W_, centre_, ups_);
    lap("working cloud");
    brief_.iterations = 20;
    brief_.model_samples = 1500;
    brief_.refinement_model_samples = 3000;
    brief_.max_distance_end = 0.15;
    brief_.refinement_twist_weight = 1;                 // as in the final refinement
    brief_.stall_window = 5, brief_.stall_gain = 1e-3;  // as in fit_shape_and_pose
    spread_ = hands_last(spread_rows(mean_body_.rest_vertices(), 0.02), model.vertex_parts());
    coarse_rows_ = hands_last(spread_rows(mean_body_.rest_vertices(), 0.04), model.vertex_parts());
  }

  BodyFit fit(const Eigen::MatrixXd& T);

 private:
  /// From one brief fit to the result. `from`: the brief fit's index in tried_; `cut_short`: read off
  /// the brief fit alone (finish_from).
  struct Finished {
    BodyFit fit;
    size_t from = 0;
    bool cut_short = false;
  };

  void lap(const std::string& stage) { timer_.lap(stage); }
  std::vector<size_t> brief_fits(const std::vector<Start>& starts);
  Finished finish_from(size_t k, bool whole);
  Finished finish_best(const std::vector<size_t>& ranked);
  Finished read_off(size_t k, const PartPose& pose, const Eigen::VectorXd& c, const Eigen::MatrixXd& V,
                    const std::vector<std::string>& warnings, const std::array<bool, kNumJoints>& guessed);
  static std::string poor_because(const Finished& f) { return (f.cut_short ? "fitted briefly: " : "") + f.fit.reasons.front(); }

  const BodyModel& model_;
  const BodyFitOptions& o_;
  StageTimer timer_;  ///< started first: the working cloud's stage includes the mean body
  const ShapedBody mean_body_;
  Eigen::MatrixXd W_;  ///< the working cloud
  Eigen::RowVector3d centre_;
  std::vector<LibraryPose> library_, motion_poses_;
  std::vector<Eigen::Vector3d> ups_;
  std::vector<UpFrame> frames_;
  PoseFitOptions brief_;  ///< the brief fits of the best starts; the best of those goes on
  ScoreRows spread_, coarse_rows_;
  std::vector<Start> tried_;  ///< the starts fitted briefly, with their scores and poses
  std::vector<double> tried_score_;
  std::vector<PartPose> tried_pose_;
};

/// Brief fits of the best distinct starts not fitted before, best first. Distinct starts only: the
/// same library pose at the next heading, or the same joints reached by another name (legs of one
/// pose, arms of another), is the same start to a brief fit.
std::vector<size_t> BodyFitter::brief_fits(const std::vector<Start>& starts) {
  auto same_start = [](const Start& a, const Start& b) {
    if (a.up != b.up) return false;
    if (a.kind == b.kind) return true;
    for (size_t j = 0; j < a.pose.joint_rotation.size(); ++j)
      if ((a.pose.joint_rotation[j] - b.pose.joint_rotation[j]).norm() > 1e-9) return false;
    return (a.pose.root_rotation - b.pose.root_rotation).norm() < 1e-9;
  };
  const size_t first = tried_.size();
  for (size_t k = 0; k < starts.size() && static_cast<int>(tried_.size() - first) < std::max(1, o_.hypotheses_refined); ++k)
    if (std::none_of(tried_.begin(), tried_.end(), [&](const Start& t) { return same_start(t, starts[k]); })) tried_.push_back(starts[k]);
  tried_score_.resize(tried_.size()), tried_pose_.resize(tried_.size());
  parallel_for_ranges(
      static_cast<long>(tried_.size() - first), o_.threads,
      [&](long begin, long end) {
        for (long i = begin; i < end; ++i) {
          const auto k = static_cast<size_t>(i) + first;
          tried_pose_[k] = brief_fit(model_, frames_[tried_[k].up].cloud, tried_[k].pose, brief_, spread_, o_, &tried_score_[k]);
        }
      },
      1);
  // By score (ties in the starts' order: the same choice on any number of threads).
  std::vector<size_t> ranked(tried_.size() - first);
  for (size_t k = 0; k < ranked.size(); ++k) ranked[k] = k + first;
  std::stable_sort(ranked.begin(), ranked.end(), [&](size_t a, size_t b) { return tried_score_[a] < tried_score_[b]; });
  lap("brief fits");
  return ranked;
}

/// What is read off a finished fit (shape c, posed vertices V in the fit's frame), back in the
/// target's frame.
BodyFitter::Finished BodyFitter::read_off(size_t k, const PartPose& pose, const Eigen::VectorXd& c, const Eigen::MatrixXd& V,
                                          const std::vector<std::string>& warnings, const std::array<bool, kNumJoints>& guessed) {
  const Start& best = tried_[k];
  const UpFrame& frame = frames_[best.up];
  Finished out;
  out.from = k;
  BodyFit& fit = out.fit;
  fit.coefficients = c;
  fit.pose = pose;
  fit.to_fit_frame = frame.rotation;
  fit.up = ups_[best.up].normalized();
  fit.start = best.name;
  fit.working_points = static_cast<int>(W_.rows());
  // Back to the target's frame: x = R^T y + centre.
  fit.V = (V * frame.rotation).rowwise() + centre_;
  fit.joints = (ShapedBody(model_, c).posed_joints(pose) * frame.rotation).rowwise() + centre_;
  fit.joint_guessed = guessed;
  read_off_fit(model_, W_, o_, warnings, &fit);
  lap("read-off");
  return out;
}

/// From brief fit k to the result: the arm step, shape and pose in turn, the final refinement, and
/// what is read off the fit. Without `whole`, a brief fit that leaves much of the target far from
/// the body is read off as it is (cut short).
BodyFitter::Finished BodyFitter::finish_from(size_t k, bool whole) {
  const Start* best = &tried_[k];
  const double best_score = tried_score_[k];
  PartPose pose = tried_pose_[k];
  // The recognised pose: the priors of every later fit pull towards it, not towards standing.
  PartPose recognised = best->pose;
  const UpFrame& frame = frames_[best->up];
  if (o_.frame_chosen) o_.frame_chosen(frame.rotation);
  const PointGrid grid(frame.cloud, 0.03);

  // Each arm, then each leg, on its own (limbs_one_by_one); kept when its brief fit is better.
  bool changed = false;
  const PartPose limbed = limbs_one_by_one(model_, mean_body_, frame, coarse_rows_, pose, o_.threads, &changed);
  if (changed) {
    PoseFitOptions limbs = brief_;
    limbs.start = limbed;
    limbs.threads = o_.threads;
    PartPose limbed_recognised = recognised;
    for (const char* side : {"left_", "right_"})
      for (const char* joint : {"shoulder", "elbow", "wrist", "hip", "knee", "ankle"}) {
        const auto j = static_cast<size_t>(find_joint_index(std::string(side) + joint));
        limbed_recognised.joint_rotation[j] = limbed.joint_rotation[j];
      }
    limbs.prior_pose = limbed_recognised;
    const PoseFitResult r = fit_pose(mean_body_, frame.cloud, limbs);
    const double score =
        mismatch(r.V(spread_.rows, Eigen::all), frame.cloud, grid, 0.15, 0.03, std::numeric_limits<double>::infinity(), spread_.scored);
    if (score < best_score) pose = r.pose, recognised = limbed_recognised;
  }
  lap("limbs");

  // A brief fit that leaves a twentieth of the target over kOutlier from the body is no start for
  // the shape rounds: over the 3-shape robustness set's and 12 random poses' 152 finishes none of
  // the 128 confident ones had left more than 13 cm, 19 of the 24 poor ones 25 cm or more, and a
  // poor finish costs the most (its refinement runs to the end). Such a fit is read off as it is;
  // a refusal is finished whole at the end.
  if (!whole) {
    Eigen::MatrixXd X;
    mean_body_.pose(pose, &X);
    if (cloud_quantile_to_body(X, frame.cloud, 0.95, kOutlier) >= kOutlier) {
      Finished cut = read_off(k, pose, Eigen::VectorXd::Zero(model_.components()), X, {}, {});
      cut.cut_short = true;
      if (!cut.fit.confident) return cut;
    }
  }

  Eigen::VectorXd c;
  const PoseFitResult result = fit_shape_and_pose(model_, frame, grid, o_, recognised, &pose, &c);
  lap("shape and pose");
  return read_off(k, pose, c, result.V, result.warnings, result.joint_guessed);
}

/// The best brief fit finished; when that is poor, the runner-up's (an elbow bent where the arm is
/// straight scored best on a tilted A-pose body), kept when it is confident.
BodyFitter::Finished BodyFitter::finish_best(const std::vector<size_t>& ranked) {
  Finished out = finish_from(ranked.front(), false);
  if (!out.fit.confident && ranked.size() > 1) {
    Finished second = finish_from(ranked[1], false);
    if (second.fit.confident) {
      second.fit.warnings.push_back("the best start (" + out.fit.start + ") gave a poor fit (" + poor_because(out) +
                                    "); the runner-up's is kept");
      out = std::move(second);
    }
  }
  return out;
}

BodyFit BodyFitter::fit(const Eigen::MatrixXd& T) {
  const StartSearch search(model_, mean_body_, frames_, o_.threads);
  SparsePlacements sparse;
  const std::vector<Start> library_starts = search.library_starts(library_, motion_poses_, o_.headings, o_.starts_rescored, &sparse);
  std::vector<Start> starts = search.with_arms_mixed(library_starts, library_);
  lap("search");
  Finished out = finish_best(brief_fits(starts));
  // Still poor: the body may hold its legs as no library pose does. The search again with the legs
  // searched, only now: on bodies that the library's starts fit, starts with the legs searched
  // scored better and fitted worse (a pelvis tipped 10-15 degrees, the hips and back making up).
  if (!out.fit.confident && o_.legs_searched > 0) {
    const std::vector<Start> every_up = search.with_best_of_every_up(library_starts, sparse, library_, motion_poses_, o_.headings,
                                                                     o_.starts_rescored / static_cast<int>(frames_.size()));
    starts = search.with_arms_mixed(search.with_legs_searched(every_up, o_.legs_searched), library_);
    lap("search");
    const std::vector<size_t> ranked = brief_fits(starts);
    if (!ranked.empty()) {
      Finished legged = finish_best(ranked);
      if (legged.fit.confident) {
        legged.fit.warnings.push_back("the library's starts gave a poor fit (" + poor_because(out) +
                                      "); a start with the legs searched is kept");
        out = std::move(legged);
      }
    }
  }
  // A refusal still gives the best start's fit whole (--accept-poor writes it).
  if (out.cut_short) out = finish_from(out.from, true);
  // The target's points labelled once, for the fit returned (a dense scan's take the most time).
  BodyFit& fit = out.fit;
  label_target(model_, T, o_.threads, &fit);
  lap("read-off");
  fit.stage_seconds = timer_.stages();
  return std::move(fit);
}

}  // namespace

BodyFit fit_body_model(const BodyModel& model, const Eigen::MatrixXd& T, const BodyFitOptions& o) {
  const Stopwatch t0;
  BodyFitter fitter(model, T, o);
  BodyFit fit = fitter.fit(T);
  fit.seconds = t0.seconds();
  return fit;
}

BodyFit fit_body_model_to_mesh(const BodyModel& model, const Eigen::MatrixXd& V, const Eigen::MatrixXi& F, const BodyFitOptions& o) {
  std::vector<int> vertex_map;
  body_surface(V, F, nullptr, &vertex_map);
  std::vector<int> kept;
  for (int v : vertex_map)
    if (v >= 0) kept.push_back(v);
  BodyFit fit = fit_body_model(model, V(kept, Eigen::all), o);
  Eigen::VectorXi part = Eigen::VectorXi::Constant(V.rows(), -1);
  Eigen::VectorXd distance = Eigen::VectorXd::Constant(V.rows(), std::numeric_limits<double>::infinity());
  for (size_t k = 0; k < kept.size(); ++k) {
    part[kept[k]] = fit.target_part[static_cast<Eigen::Index>(k)];
    distance[kept[k]] = fit.target_distance[static_cast<Eigen::Index>(k)];
  }
  fit.target_part = std::move(part);
  fit.target_distance = std::move(distance);
  return fit;
}

Eigen::VectorXi parts_of_every_vertex(const BodyModel& model, const BodyFit& fit, const Eigen::MatrixXd& V) {
  if (fit.target_part.size() != V.rows())
    throw InvalidInput("parts_of_every_vertex: the fit labels " + std::to_string(fit.target_part.size()) + " points, the mesh has " +
                       std::to_string(V.rows()) + " vertices");
  const PointGrid fitted(fit.V);
  Eigen::VectorXi part = fit.target_part;
  for (Eigen::Index v = 0; v < part.size(); ++v) {
    if (part[v] >= 0) continue;
    double sq = 0;
    part[v] = model.vertex_parts()[fitted.nearest(V.row(v).transpose(), &sq)];
  }
  return part;
}

RestLabeller body_model_labeller(const BodyModel& model, const BodyFitOptions& options) {
  return [&model, options](const Eigen::MatrixXd& V, const Eigen::MatrixXi& F) {
    const BodyFit fit = fit_body_model_to_mesh(model, V, F, options);
    RestLabels labels;
    if (!fit.confident)
      for (const auto& r : fit.reasons) labels.poor_fit += (labels.poor_fit.empty() ? "" : "; ") + r;
    labels.triangle_part = triangle_part_labels(F, parts_of_every_vertex(model, fit, V));
    labels.joint_centres = fit.joints;
    return labels;
  };
}

}  // namespace posekit
