#include "posekit/deformation/pose_fitting.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/parallel.h"
#include "posekit/core/point_grid.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/rigid_pose.h"

namespace posekit {
namespace {

constexpr int kUnknowns = kPoseIncrementSize;

/// The value below which a fraction q of v lies.
// A grid cell holding about ten points of a sampled surface (a scan, a body's vertices): three
// spacings, the spacing from the points' count over the area of half the bounding box's faces (a
// standing body's skin has about that area). The grid's own default, for a volume, is 3 to 6 times
// coarser on a body and made fit 25% slower (same pairs).
double surface_cell(const Eigen::MatrixXd& P) {
  const Eigen::Vector3d e = (P.colwise().maxCoeff() - P.colwise().minCoeff()).transpose();
  const double area = e.x() * e.y() + e.y() * e.z() + e.z() * e.x();
  return 3 * std::sqrt(area / static_cast<double>(std::max<Eigen::Index>(1, P.rows())));
}

double quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<long>(k), v.end());
  return v[k];
}

}  // namespace

double joint_limit_degrees(int joint) {
  // Ranges of motion a body reaches (rotation from the standing rest, any direction).
  static const std::array<double, kNumJoints> limits = {60,             // lower_back
                                                        45,             // upper_back
                                                        80,             // neck
                                                        170, 150, 90,   // left shoulder, elbow, wrist
                                                        170, 150, 90,   // right
                                                        130, 155, 60,   // left hip, knee, ankle
                                                        130, 155, 60};  // right
  return joint >= 0 && joint < kNumJoints ? limits[static_cast<size_t>(joint)] : 180;
}

namespace {
/// A subject posed by one method, as fit_pose sees it.
class SynthesizedBody final : public PosableBody {
 public:
  SynthesizedBody(const PoseSynthesizer& synth, PoseMethod method) : synth_(synth), method_(method) {}
  const Eigen::MatrixXd& rest_vertices() const override { return synth_.rest_vertices(); }
  const Eigen::MatrixXi& faces() const override { return synth_.faces(); }
  const Eigen::VectorXi& vertex_parts() const override { return synth_.vertex_parts(); }
  const Eigen::MatrixXd& joint_centres() const override { return synth_.info().joint_centres; }
  Eigen::MatrixXd joint_pivots() const override { return synth_.joint_pivots(method_); }
  void pose(const PartPose& pose, Eigen::MatrixXd* X) const override { synth_.pose(pose, method_, X); }
  PartTransforms part_motions(const PartPose& pose) const override { return synth_.part_motions(pose, method_); }

 private:
  const PoseSynthesizer& synth_;
  PoseMethod method_;
};
}  // namespace

PoseFitResult fit_pose(const PoseSynthesizer& synth, const Eigen::MatrixXd& T, const PoseFitOptions& o) {
  return fit_pose(SynthesizedBody(synth, o.method), T, o);
}

namespace {

using System = Eigen::Matrix<double, kUnknowns, kUnknowns>;
using Vector = Eigen::Matrix<double, kUnknowns, 1>;
/// One linearisation of fit_pose's robust objective at a pose.
struct Linearisation {
  System N = System::Zero();
  Vector g = Vector::Zero();
  double cost = 0, data_weight = 0;
};
constexpr int kMaxActive = 6 + 3 * 5;  // root and the longest chain (pelvis to a hand)

/// Swing-twist decomposition of a joint rotation about its bone axis: the twist angle about the
/// bone, and the swing (the rotation left, as a rotation vector across the bone).
struct SwingTwist {
  Eigen::Vector3d swing;
  double twist;
};

/// fit_pose in stages over the subject, the target and what the stages share: the start search
/// (search_start), the final refinement (refine), parts the target does not show (hold_unseen_parts)
/// and the result's residuals and warnings (finish). The objective's pieces are linearise and
/// add_joint_priors; icp minimises it.
class PoseFitter {
 public:
  PoseFitter(const PosableBody& subject, const Eigen::MatrixXd& T, const PoseFitOptions& o)
      : subject(subject),
        T(T),
        o(o),
        V0(subject.rest_vertices()),
        part(subject.vertex_parts()),
        joints(subject.joint_centres()),
        pivots(subject.joint_pivots()),
        target_grid(T, surface_cell(T)),
        // A subsample of the target (at most 20,000 points) for the start hypotheses: its coarser
        // grid answers their long-range queries several times faster.
        T_coarse(T(Eigen::seq(0, T.rows() - 1, std::max<Eigen::Index>(1, T.rows() / 20000)), Eigen::all)),
        coarse_grid(T_coarse, surface_cell(T_coarse)) {
    // Which joints move each part: the chain up to the pelvis.
    for (int q = 0; q < kNumParts; ++q)
      for (int c = q; c > 0; c = part_parent(c)) chain[static_cast<size_t>(q)].push_back(c - 1);
    rest_pivot = (joints.row(kAbdomen - 1) + joints.row(kLeftThigh - 1) + joints.row(kRightThigh - 1)).transpose() / 3;
    find_bone_axes();
    find_hinge_axes();
    // Where the joint priors pull: the rest, or the pose the caller recognised (PoseFitOptions::prior_pose).
    for (int j = 0; j < kNumJoints; ++j)
      prior_centre[static_cast<size_t>(j)] = o.prior_pose ? o.prior_pose->joint(j) : Eigen::Vector3d::Zero();
  }

  /// The rest pose, its feet on the target's lowest points and its centre over the target's.
  PartPose standing_start() const {
    PartPose pose;
    std::vector<double> ty(static_cast<size_t>(T.rows())), vy(static_cast<size_t>(V0.rows()));
    for (Eigen::Index i = 0; i < T.rows(); ++i) ty[static_cast<size_t>(i)] = T(i, 1);
    for (Eigen::Index i = 0; i < V0.rows(); ++i) vy[static_cast<size_t>(i)] = V0(i, 1);
    const Eigen::RowVector3d tc = T.colwise().mean(), vc = V0.colwise().mean();
    pose.root_translation = Eigen::Vector3d(tc.x() - vc.x(), quantile(ty, 0.01) - quantile(vy, 0.0), tc.z() - vc.z());
    return pose;
  }

  /// Automatic start, no markers: the rest pose at four headings, then whole-body hypotheses (arms
  /// forward, arms up, a half squat, sitting, a stride either way) at the best one, each standing on
  /// the target's feet and refined briefly; the best of all (or options.start) is returned.
  PartPose search_start(const PartPose& standing) {
    PartPose pose = standing;
    // First the heading (the target may face any way about its vertical), standing at rest.
    double best = std::numeric_limits<double>::infinity();
    for (int quarter = 0; quarter < 4 && !o.start; ++quarter) {
      PartPose start = standing;
      start.root_rotation = quarter * M_PI / 2 * Eigen::Vector3d::UnitY();
      refine_and_keep(start, &best, &pose);
    }
    // Then whole-body hypotheses at that heading.
    const Eigen::Vector3d heading = pose.root_rotation;
    if (o.start) pose = *o.start;
    const Eigen::Vector3d X_ = Eigen::Vector3d::UnitX(), Z_ = Eigen::Vector3d::UnitZ();
    for (const auto& joints_deg :
         o.start ? std::vector<std::vector<std::pair<const char*, Eigen::Vector3d>>>{}
                 : std::vector<std::vector<std::pair<const char*, Eigen::Vector3d>>>{
                       {{"left_shoulder", -90 * X_}, {"right_shoulder", -90 * X_}},
                       {{"left_shoulder", 130 * Z_}, {"right_shoulder", -130 * Z_}},
                       {{"left_hip", -50 * X_},
                        {"right_hip", -50 * X_},
                        {"left_knee", 65 * X_},
                        {"right_knee", 65 * X_},
                        {"lower_back", 10 * X_},
                        {"left_shoulder", -30 * X_},
                        {"right_shoulder", -30 * X_}},
                       {{"left_hip", -90 * X_}, {"right_hip", -90 * X_}, {"left_knee", 90 * X_}, {"right_knee", 90 * X_}},
                       {{"left_hip", -30 * X_}, {"right_hip", 25 * X_}, {"left_knee", 15 * X_}, {"right_knee", 30 * X_}},  // striding
                       {{"left_hip", 25 * X_}, {"right_hip", -30 * X_}, {"left_knee", 30 * X_}, {"right_knee", 15 * X_}}}) {
      PartPose start = hypothesis(standing, joints_deg);
      start.root_rotation = heading;
      refine_and_keep(start, &best, &pose);
    }
    return pose;
  }

  /// The final refinement: the rest prior on swing and weighted twist from here on.
  int refine(PartPose* pose) {
    refining = true;
    return icp(*pose, o.iterations, o.refinement_model_samples, o.model_samples, o.max_distance_end, o.max_distance_end);
  }

  /// Residuals (each vertex to the target, the body posed in X) and the fraction of each part within 1 cm of it.
  void measure_residuals(const PartPose& pose, PoseFitResult* out) {
    subject.pose(pose, &X);
    out->residual.resize(X.rows());
    part_vertices.fill(0), part_covered.fill(0);
    for (Eigen::Index v = 0; v < X.rows(); ++v) {
      double sq = 0;
      target_grid.nearest(X.row(v).transpose(), &sq);
      out->residual[v] = std::sqrt(sq);
      if (part[v] >= 0 && part[v] < kNumParts)
        ++part_vertices[static_cast<size_t>(part[v])], part_covered[static_cast<size_t>(part[v])] += out->residual[v] < 0.01;
    }
  }

  /// A part the target does not show (cut off, hidden), nor any part beyond it, has its joint set by
  /// the priors and its neighbours' pairs alone: with the hands cut off the wrists came out 57 degrees
  /// off. Such a joint is held at its rest rotation (the least committal guess; at a recognised
  /// pose's, arms crossed with the hands cut off folded the forearms onto the upper arms) and the
  /// rest refined again. Returns the iterations made.
  int hold_unseen_parts(PartPose* pose, PoseFitResult* out) {
    for (int c = 1; c < kNumParts; ++c) {
      bool all = unseen(c);
      for (int d = c + 1; d < kNumParts && all; ++d)
        for (int a = d; a > 0 && all; a = part_parent(a))
          if (a == c) all = unseen(d);
      held[static_cast<size_t>(c - 1)] = all;
    }
    if (std::find(held.begin(), held.end(), true) == held.end()) return 0;
    for (int j = 0; j < kNumJoints; ++j)
      if (held[static_cast<size_t>(j)]) pose->joint(j).setZero();
    const int iterations =
        icp(*pose, std::max(1, o.iterations / 4), o.refinement_model_samples, o.model_samples, o.max_distance_end, o.max_distance_end);
    measure_residuals(*pose, out);
    return iterations;
  }

  /// The result: the posed body, its coverage and distances to the target, and the warnings.
  void finish(const PartPose& pose, PoseFitResult* out) const {
    out->pose = pose;
    out->V = X;
    int covered = 0;
    for (Eigen::Index v = 0; v < X.rows(); ++v) covered += out->residual[v] < 0.01;
    out->coverage = static_cast<double>(covered) / static_cast<double>(std::max<Eigen::Index>(1, X.rows()));
    const PointGrid body_grid(X, surface_cell(X));
    std::vector<double> to_body;
    for (Eigen::Index i = 0; i < T.rows(); i += std::max<Eigen::Index>(1, T.rows() / 20000)) {
      double sq = 0;
      body_grid.nearest(T.row(i).transpose(), &sq);
      to_body.push_back(std::sqrt(sq));
    }
    double sum = 0;
    for (double d : to_body) sum += d;
    out->target_mean = sum / static_cast<double>(std::max<size_t>(1, to_body.size()));
    out->target_p95 = quantile(to_body, 0.95);
    std::ostringstream msg;
    msg.precision(1);
    if (out->coverage < 0.6)
      msg << std::fixed << "only " << 100 * out->coverage
          << "% of the body lies within 1 cm of the target (holes, another body, or a wrong fit)",
          out->warnings.push_back(msg.str()), msg.str("");
    if (out->target_p95 > 0.03)
      msg << std::fixed << "a twentieth of the target lies over " << 1000 * out->target_p95 << " mm from the fitted body",
          out->warnings.push_back(msg.str()), msg.str("");
    for (int c = 1; c < kNumParts; ++c) {
      const size_t q = static_cast<size_t>(c);
      out->joint_guessed[q - 1] = unseen(c);
      if (unseen(c))
        msg << std::fixed << "only " << 100.0 * part_covered[q] / part_vertices[q] << "% of the " << part_name(c)
            << " lies within 1 cm of the target (cut off or hidden?): joint '" << joint_name(c - 1)
            << (held[q - 1] ? "' is held at its rest rotation" : "' is a guess"),
            out->warnings.push_back(msg.str()), msg.str("");
    }
    for (int j = 0; j < kNumJoints; ++j)
      if (pose.joint(j).norm() * 180 / M_PI > joint_limit_degrees(j) + 5)
        out->warnings.push_back("joint '" + joint_name(j) + "' ends beyond its range of motion: the fit is probably wrong there");
  }

 private:
  /// Each joint's bone axis at rest: from the joint to the centroid of the part it moves.
  void find_bone_axes() {
    std::array<Eigen::Vector3d, kNumParts> sum;
    std::array<int, kNumParts> count{};
    for (auto& v : sum) v.setZero();
    for (Eigen::Index v = 0; v < V0.rows(); ++v)
      if (part[v] >= 0 && part[v] < kNumParts)
        sum[static_cast<size_t>(part[v])] += V0.row(v).transpose(), ++count[static_cast<size_t>(part[v])];
    for (int j = 0; j < kNumJoints; ++j) {
      const size_t c = static_cast<size_t>(j + 1);
      const Eigen::Vector3d d = count[c] > 0 ? Eigen::Vector3d(sum[c] / count[c] - joints.row(j).transpose()) : Eigen::Vector3d::Zero();
      bone_axis[static_cast<size_t>(j)] = d.norm() > 1e-9 ? Eigen::Vector3d(d.normalized()) : Eigen::Vector3d::UnitY();
    }
  }

  /// Elbows and knees are hinges: they flex about an axis h across the limb and twist about the
  /// bone, but barely swing about the third axis (no varus or valgus). An elbow's h lies in the
  /// body's frontal plane across the arm (arm x forward, the arm from shoulder to wrist; the rest body
  /// faces +Z), whatever the arm's abduction; a knee's is the body's left-right axis, about which the
  /// pose library and the robustness set bend knees (across a leg leaning 5 degrees, a knee bent
  /// 138 degrees about it read as 8 degrees of varus). Per hinge joint (zero for the others) h and
  /// that third axis n = h x bone.
  void find_hinge_axes() {
    for (auto& n : hinge_axis) n.setZero();
    for (auto& n : off_hinge_axis) n.setZero();
    for (int c : {kLeftForearm, kRightForearm, kLeftShank, kRightShank}) {
      const Eigen::Vector3d& a = bone_axis[static_cast<size_t>(c - 1)];
      const Eigen::Vector3d limb =
          (joints.row(c) - joints.row(part_parent(c) - 1)).transpose().normalized();  // shoulder to wrist, hip to ankle
      const Eigen::Vector3d h = c == kLeftShank || c == kRightShank ? Eigen::Vector3d::UnitX() : limb.cross(Eigen::Vector3d::UnitZ());
      if (h.norm() > 0.5) {
        hinge_axis[static_cast<size_t>(c - 1)] = h.normalized();
        off_hinge_axis[static_cast<size_t>(c - 1)] = h.normalized().cross(a).normalized();
      }
    }
  }

  SwingTwist swing_twist(int j, const Eigen::Vector3d& r) const {
    const Eigen::Quaterniond q(Eigen::AngleAxisd(r.norm(), r.norm() > 1e-12 ? Eigen::Vector3d(r.normalized()) : Eigen::Vector3d::UnitX()));
    const Eigen::Vector3d& a = bone_axis[static_cast<size_t>(j)];
    Eigen::Quaterniond t(q.w(), 0, 0, 0);
    t.vec() = q.vec().dot(a) * a;
    if (t.norm() < 1e-12) return SwingTwist{r, 0.0};  // a half turn about an axis across the bone: all swing
    t.normalize();
    const Eigen::AngleAxisd s(q * t.conjugate());
    return SwingTwist{s.angle() * s.axis(), 2 * std::atan2(t.vec().dot(a), t.w())};
  }
  /// The final refinement's prior residual of a joint rotation: its swing plus its twist, weighted,
  /// along the bone.
  Eigen::Vector3d refinement_prior_residual(int j, const Eigen::Vector3d& r) const {
    const SwingTwist st = swing_twist(j, r);
    return Eigen::Vector3d(st.swing + o.refinement_twist_weight * st.twist * bone_axis[static_cast<size_t>(j)]);
  }
  /// The hinge prior's residual: the joint rotation as a flexion about h after a swing s across h
  /// (r = flex * s), s's part about n. Zero for any flexion alone, however deep; a twist about the
  /// bone is s about the bone, also free. (The swing left by twisting about the bone first grows
  /// with the flexion: a 138-degree knee bent about an axis 5 degrees off h showed a 25-degree twist,
  /// and the prior turned the squatting robustness bodies' thighs by 20 degrees.)
  Eigen::Vector3d off_hinge_residual(int j, const Eigen::Vector3d& r) const {
    const Eigen::Vector3d &h = hinge_axis[static_cast<size_t>(j)], &n = off_hinge_axis[static_cast<size_t>(j)];
    const Eigen::Quaterniond q(Eigen::AngleAxisd(r.norm(), r.norm() > 1e-12 ? Eigen::Vector3d(r.normalized()) : Eigen::Vector3d::UnitX()));
    Eigen::Quaterniond flex(q.w(), 0, 0, 0);
    flex.vec() = q.vec().dot(h) * h;
    if (flex.norm() < 1e-12) return Eigen::Vector3d(r.dot(n) * n);  // a half turn across h: all swing
    flex.normalize();
    const Eigen::AngleAxisd swing(flex.conjugate() * q);
    return Eigen::Vector3d((swing.angle() * swing.axis()).dot(n) * n);
  }

  /// How well a pose explains the target: the mean distance of target points to the body, each
  /// capped at 10 cm so that outliers and holes do not decide.
  double score(const PartPose& pose) {
    subject.pose(pose, &X);
    const PointGrid body(X, surface_cell(X));
    double sum = 0;
    long n = 0;
    for (Eigen::Index i = 0; i < T.rows(); i += std::max<Eigen::Index>(1, T.rows() / 3000)) {
      double sq = 0;
      sum += body.nearest(T.row(i).transpose(), &sq, 0.1) >= 0 ? std::sqrt(sq) : 0.1;
      ++n;
    }
    return sum / static_cast<double>(std::max<long>(n, 1));
  }

  /// One linearisation of the robust objective at a pose: pairs both ways (every sampled target
  /// point to its nearest body vertex; a sampled body vertex to its nearest target point where that is
  /// mutual), each costing rho(s) = sigma^2/2 log(1 + s/sigma^2) of s = (n.r)^2 + point_to_point |r|^2
  /// along the body's normal n; a sample with no pair within max_d costs rho(max_d^2). With the joint
  /// priors (add_joint_priors) this is the objective the Levenberg-Marquardt steps of icp decrease.
  Linearisation linearise(const Eigen::MatrixXd& target, const PointGrid& grid, const PartPose& pose, double max_d, double sigma,
                          Eigen::Index model_stride, Eigen::Index target_stride, double prior_scale, double p2p) {
    Linearisation L;
    subject.pose(pose, &X);
    const PartTransforms P = subject.part_motions(pose);
    std::array<Eigen::Vector3d, kNumJoints> centre;  // where each joint turns, posed
    for (int j = 0; j < kNumJoints; ++j) {
      const size_t q = static_cast<size_t>(part_parent(j + 1));
      centre[static_cast<size_t>(j)] = P.R[q] * pivots.row(j).transpose() + P.t[q];
    }
    const Eigen::Vector3d pivot = rest_pivot + pose.root_translation;
    const Eigen::MatrixXd normals = vertex_normals(X, subject.faces());
    const PointGrid model_grid(X, surface_cell(X));
    const double s2 = sigma * sigma;
    auto rho = [&](double s) { return 0.5 * s2 * std::log1p(s / s2); };
    // An unpaired sample costs as a point-to-point pair at max_d would (charging it the most a pair
    // can, rho((1 + p2p) max_d^2), fitted 0.1-0.2 mm worse over the 48 scans).
    const double unpaired = rho(max_d * max_d);
    // Per part, the pairs' normal equations in the twist (t, w) of a rigid motion about the origin,
    // J0 = [I, -[x]x]; a rotation w about a centre c is the twist ([c]x w, w), so each unknown's
    // columns are J0 [[c]x; I] and the 6 x 6 sums map to the unknowns once per part.
    struct Sums {
      std::array<Eigen::Matrix<double, 6, 6>, kNumParts> H;
      std::array<Eigen::Matrix<double, 6, 1>, kNumParts> b;
      double cost = 0, weight = 0;
    };
    auto add = [&](Sums& S, Eigen::Index v, const Eigen::Vector3d& y) {
      const Eigen::Vector3d x = X.row(v).transpose(), r = x - y, n = normals.row(v).transpose();
      const Eigen::Matrix3d M0 = n * n.transpose() + p2p * Eigen::Matrix3d::Identity();
      const double s = r.dot(M0 * r);
      S.cost += rho(s);
      const double w = 1 / (1 + s / s2);
      Eigen::Matrix<double, 3, 6> J0;
      J0.leftCols<3>().setIdentity();
      J0.rightCols<3>() = -cross_product_matrix(x);
      const Eigen::Matrix<double, 6, 3> J0tM = w * J0.transpose() * M0;
      const size_t q = static_cast<size_t>(part[v]);
      S.H[q].noalias() += J0tM * J0;
      S.b[q].noalias() += J0tM * r;
      S.weight += w;
    };
    // Every sampled target point is explained by the body (its nearest vertex); a sampled body vertex
    // pulls towards the target only where that is mutual (the target point's nearest vertex is close
    // by), so that body seen nowhere (holes, occluded sides) is not dragged onto other surfaces.
    // Samples 0..target_count-1 are target points, the rest body vertices; summed per block of
    // kBlock samples, the blocks in order.
    const Eigen::Index target_count = (target.rows() + target_stride - 1) / target_stride,
                       model_count = (X.rows() + model_stride - 1) / model_stride;
    constexpr Eigen::Index kBlock = 1024;
    const long blocks = static_cast<long>((target_count + model_count + kBlock - 1) / kBlock);
    std::vector<Sums> block_sums(static_cast<size_t>(blocks));
    parallel_for_ranges(
        blocks, o.threads,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            Sums& S = block_sums[static_cast<size_t>(k)];
            for (int q = 0; q < kNumParts; ++q) S.H[static_cast<size_t>(q)].setZero(), S.b[static_cast<size_t>(q)].setZero();
            for (Eigen::Index sample = k * kBlock; sample < std::min((k + 1) * kBlock, target_count + model_count); ++sample) {
              double sq = 0, back = 0;
              if (sample < target_count) {
                const Eigen::Index i = sample * target_stride;
                const int v = model_grid.nearest(target.row(i).transpose(), &sq, max_d);
                if (v >= 0) add(S, v, target.row(i).transpose());
                else S.cost += unpaired;
                continue;
              }
              const Eigen::Index v = (sample - target_count) * model_stride;
              const int t = grid.nearest(X.row(v).transpose(), &sq, max_d);
              const int u = t >= 0 ? model_grid.nearest(target.row(t).transpose(), &back, max_d) : -1;
              if (u >= 0 && (X.row(u) - X.row(v)).squaredNorm() <= o.mutual_distance * o.mutual_distance)
                add(S, v, target.row(t).transpose());
              else S.cost += unpaired;
            }
          }
        },
        2);
    std::array<Eigen::Matrix<double, 6, 6>, kNumParts> H;
    std::array<Eigen::Matrix<double, 6, 1>, kNumParts> b;
    for (int q = 0; q < kNumParts; ++q) H[static_cast<size_t>(q)].setZero(), b[static_cast<size_t>(q)].setZero();
    for (const Sums& S : block_sums) {
      for (int q = 0; q < kNumParts; ++q)
        H[static_cast<size_t>(q)] += S.H[static_cast<size_t>(q)], b[static_cast<size_t>(q)] += S.b[static_cast<size_t>(q)];
      L.cost += S.cost, L.data_weight += S.weight;
    }
    for (int q = 0; q < kNumParts; ++q) {
      // B maps the unknowns that move part q to its twist.
      Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxActive> B = Eigen::Matrix<double, 6, Eigen::Dynamic, 0, 6, kMaxActive>::Zero(6, 6);
      std::array<int, kMaxActive> column{};
      B.topLeftCorner<3, 3>().setIdentity();
      B.block<3, 3>(0, 3) = cross_product_matrix(pivot);
      B.block<3, 3>(3, 3).setIdentity();
      for (int k = 0; k < 6; ++k) column[static_cast<size_t>(k)] = k;
      for (int j : chain[static_cast<size_t>(q)]) {
        const Eigen::Index c = B.cols();
        B.conservativeResize(6, c + 3);
        B.block<3, 3>(0, c) = cross_product_matrix(centre[static_cast<size_t>(j)]);
        B.block<3, 3>(3, c).setIdentity();
        for (int k = 0; k < 3; ++k) column[static_cast<size_t>(c + k)] = 6 + 3 * j + k;
      }
      const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, 0, kMaxActive, kMaxActive> BtHB =
          B.transpose() * H[static_cast<size_t>(q)] * B;
      const Eigen::Matrix<double, Eigen::Dynamic, 1, 0, kMaxActive, 1> Btb = B.transpose() * b[static_cast<size_t>(q)];
      for (Eigen::Index a = 0; a < B.cols(); ++a) {
        L.g[column[static_cast<size_t>(a)]] += Btb[a];
        for (Eigen::Index k = 0; k < B.cols(); ++k) L.N(column[static_cast<size_t>(a)], column[static_cast<size_t>(k)]) += BtHB(a, k);
      }
    }
    add_joint_priors(pose, prior_scale, &L);
    return L;
  }

  /// Priors on the joint rotations, in the data term's scale: towards the rest (or the recognised
  /// pose), the hinge prior, the joint limits; joints of unseen parts held at rest.
  void add_joint_priors(const PartPose& pose, double prior_scale, Linearisation* lin) const {
    Linearisation& L = *lin;
    // Priors on the joint rotations, in the data term's scale.
    const auto R = part_rotations(pose);
    for (int j = 0; j < kNumJoints; ++j) {
      const Eigen::Vector3d& r = pose.joint(j);
      const Eigen::Matrix3d to_parent = R[static_cast<size_t>(part_parent(j + 1))].transpose();
      auto prior = [&](double weight, const Eigen::Vector3d& residual, const Eigen::Matrix3d& Jr) {
        L.N.block<3, 3>(6 + 3 * j, 6 + 3 * j) += weight * Jr.transpose() * Jr;
        L.g.segment<3>(6 + 3 * j) += weight * Jr.transpose() * residual;
        L.cost += 0.5 * weight * residual.squaredNorm();
      };
      // A prior on residual(j, r), its derivative by the world increment of this joint by central differences.
      auto prior_by_differences = [&](double weight, const auto& residual) {
        Eigen::Matrix3d Jr;
        const Eigen::Matrix3d Rr = rotation_from_axis_angle(r), P = to_parent.transpose();
        for (int k = 0; k < 3; ++k) {
          const Eigen::Vector3d e = Eigen::Vector3d::Unit(k) * 1e-6;
          Jr.col(k) = (residual(j, axis_angle_from_rotation(to_parent * rotation_from_axis_angle(e) * P * Rr)) -
                       residual(j, axis_angle_from_rotation(to_parent * rotation_from_axis_angle(-e) * P * Rr))) /
                      2e-6;
        }
        prior(weight, residual(j, r), Jr);
      };
      const Eigen::Vector3d& centre = prior_centre[static_cast<size_t>(j)];
      if (held[static_cast<size_t>(j)]) prior(o.limit_prior * prior_scale, r, to_parent);
      else if (refining)
        prior_by_differences(o.refinement_rest_prior * prior_scale, [&](int i, const Eigen::Vector3d& v) {
          return Eigen::Vector3d(refinement_prior_residual(i, v) - refinement_prior_residual(i, centre));
        });
      else prior(o.rest_prior * prior_scale, r - centre, to_parent);
      if (o.hinge_prior > 0 && off_hinge_axis[static_cast<size_t>(j)].squaredNorm() > 0)
        prior_by_differences(o.hinge_prior * prior_scale, [&](int i, const Eigen::Vector3d& v) { return off_hinge_residual(i, v); });
      const double limit = joint_limit_degrees(j) * M_PI / 180, angle = r.norm();
      if (angle > limit) {
        const Eigen::Vector3d axis = r / angle;
        prior(o.limit_prior * prior_scale, (angle - limit) * axis, axis * axis.transpose() * to_parent);
      }
    }
  }

  /// Articulated ICP from `pose`: Levenberg-Marquardt on the objective above, a step kept only when
  /// it lowers it; the correspondence distance shrinks from `d0` to `d1` over the first two thirds.
  /// Returns the linearisations made.
  int icp(PartPose& pose, int iterations, int model_samples, int target_samples, double d0, double d1) {
    const bool coarse = d0 != d1;
    const Eigen::MatrixXd& TT = coarse ? T_coarse : T;
    const PointGrid& grid = coarse ? coarse_grid : target_grid;
    const Eigen::Index model_stride = std::max<Eigen::Index>(1, V0.rows() / std::max(1, model_samples));
    const Eigen::Index target_stride = std::max<Eigen::Index>(1, TT.rows() / std::max(1, target_samples));
    // The priors' scale: a vertex 0.3 m from a joint, times the pairs there can be.
    const double prior_scale = 0.09 * static_cast<double>(TT.rows() / target_stride + V0.rows() / model_stride);
    auto shrinking = [&](int it) { return d0 + (d1 - d0) * std::min(1.0, it / (0.66 * std::max(1, iterations - 1))); };
    auto at = [&](const PartPose& p, double max_d) {
      return linearise(TT, grid, p, max_d, max_d / 3, model_stride, target_stride, prior_scale,
                       max_d != d1 ? o.point_to_point_start : o.point_to_point);
    };
    double damping = 1e-4, max_d = d0;
    int it = 0;
    std::vector<double> accepted;  // the objective after each step kept at the final distance
    Linearisation current = at(pose, max_d);
    if (current.data_weight <= 0)
      throw InvalidInput("fit: no target point within " + std::to_string(max_d) + " m of the body; is the target in metres and upright?");
    while (it < iterations) {
      System A = current.N;
      A.diagonal() += damping * current.N.diagonal() + Vector::Constant(1e-9 * current.N.diagonal().mean());
      const Vector step = A.ldlt().solve(-current.g);
      if (!step.allFinite()) break;
      PartPose trial = pose;
      apply_pose_increment(&trial, step);
      ++it;
      if (max_d != d1) {
        // While the distance shrinks the objective changes with it: every step is taken.
        pose = trial;
        max_d = shrinking(it);
        current = at(pose, max_d);
        continue;
      }
      Linearisation next = at(trial, max_d);
      if (next.cost < current.cost) {
        const double gain = current.cost - next.cost;
        pose = trial;
        current = std::move(next);
        damping = std::max(1e-7, damping / 3);
        if (gain < 1e-6 * current.cost) break;
        accepted.push_back(current.cost);
        const size_t window = static_cast<size_t>(std::max(1, o.stall_window));
        if (accepted.size() > window && accepted[accepted.size() - 1 - window] - current.cost < o.stall_gain * current.cost) break;
      } else {
        damping *= 8;  // rejected: a shorter, more gradient-like step
        if (damping > 1e4) break;
      }
    }
    return it;
  }

  /// The standing start with some joints set (degrees), back on the target's feet.
  PartPose hypothesis(const PartPose& standing, const std::vector<std::pair<const char*, Eigen::Vector3d>>& joints_deg) {
    const double deg = M_PI / 180;
    PartPose h = standing;
    for (const auto& [name, v] : joints_deg) h.joint(find_joint_index(name)) = v * deg;
    subject.pose(h, &X);
    std::vector<double> ty(static_cast<size_t>(T.rows())), xy(static_cast<size_t>(X.rows()));
    for (Eigen::Index i = 0; i < T.rows(); ++i) ty[static_cast<size_t>(i)] = T(i, 1);
    for (Eigen::Index i = 0; i < X.rows(); ++i) xy[static_cast<size_t>(i)] = X(i, 1);
    h.root_translation.y() += quantile(ty, 0.01) - quantile(xy, 0.0);
    return h;
  }
  /// A start refined briefly and scored; kept when the best so far.
  void refine_and_keep(PartPose start, double* best, PartPose* best_pose) {
    icp(start, std::max(1, o.search_iterations), o.model_samples / 2, o.model_samples / 2, o.max_distance_start, o.max_distance_end);
    const double e = score(start);
    if (e < *best) *best = e, *best_pose = start;
  }
  bool unseen(int c) const {
    return part_vertices[static_cast<size_t>(c)] > 0 && part_covered[static_cast<size_t>(c)] < 0.2 * part_vertices[static_cast<size_t>(c)];
  }

  const PosableBody& subject;
  const Eigen::MatrixXd& T;
  const PoseFitOptions& o;
  const Eigen::MatrixXd& V0;
  const Eigen::VectorXi& part;
  const Eigen::MatrixXd& joints;
  const Eigen::MatrixXd pivots;  // the Jacobian's centres of rotation
  const PointGrid target_grid;
  const Eigen::MatrixXd T_coarse;
  const PointGrid coarse_grid;
  std::array<std::vector<int>, kNumParts> chain;
  Eigen::Vector3d rest_pivot;
  std::array<Eigen::Vector3d, kNumJoints> bone_axis, hinge_axis, off_hinge_axis, prior_centre;
  bool refining = false;                // the final refinement: the rest prior on swing and weighted twist
  std::array<bool, kNumJoints> held{};  // joints of parts the target does not show: held at rest
  std::array<int, kNumParts> part_vertices{}, part_covered{};
  Eigen::MatrixXd X;  // the body as last posed
};

}  // namespace

PoseFitResult fit_pose(const PosableBody& subject, const Eigen::MatrixXd& T, const PoseFitOptions& o) {
  const Stopwatch t0;
  if (T.rows() < 100 || T.cols() != 3 || !T.allFinite())
    throw InvalidInput("fit: the target has " + std::to_string(T.rows()) + " points (at least 100 finite ones needed)");
  PoseFitter fitter(subject, T, o);
  PoseFitResult out;
  PartPose pose = fitter.search_start(fitter.standing_start());
  out.iterations = fitter.refine(&pose);
  fitter.measure_residuals(pose, &out);
  out.iterations += fitter.hold_unseen_parts(&pose, &out);
  fitter.finish(pose, &out);
  out.seconds = t0.seconds();
  return out;
}

}  // namespace posekit
