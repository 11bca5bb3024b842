#include "posekit/deformation/pose_synthesis.h"

#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_topology.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/timer.h"
#include "posekit/deformation/poisson_solver.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/registration/correspondence.h"
#include "posekit/registration/ctffd.h"
#include "posekit/segmentation/body_segmentation.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/segmentation_prior.h"
#include "posekit/segmentation/skeleton_checks.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/layered_representation.h"
#include "simd.h"

namespace posekit {

PoseMethod parse_pose_method(const std::string& name) {
  if (name == "learned" || name == "ours") return PoseMethod::kLearned;
  if (name == "rigid") return PoseMethod::kRigid;
  if (name == "lbs") return PoseMethod::kLbs;
  throw InvalidInput("unknown pose method '" + name + "': expected learned, rigid or lbs");
}

const char* pose_method_name(PoseMethod method) {
  switch (method) {
    case PoseMethod::kLearned:
      return "learned";
    case PoseMethod::kRigid:
      return "rigid";
    case PoseMethod::kLbs:
      return "lbs";
  }
  return "?";
}

namespace {

/// Smooth skinning weights (#V x 16, rows sum to 1) diffused from per-vertex part labels by
/// `iterations` rounds of neighbour averaging.
Eigen::MatrixXd diffuse_part_weights(const Eigen::MatrixXi& F, const Eigen::VectorXi& vertex_part, int num_vertices, int iterations) {
  const Eigen::MatrixXi E = unique_edges(F);
  Eigen::VectorXd degree = Eigen::VectorXd::Zero(num_vertices);
  for (Eigen::Index e = 0; e < E.rows(); ++e) {
    degree[E(e, 0)] += 1;
    degree[E(e, 1)] += 1;
  }
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(num_vertices, kNumParts);
  for (int v = 0; v < num_vertices; ++v) W(v, vertex_part[v]) = 1;
  Eigen::MatrixXd sum(num_vertices, kNumParts);
  for (int it = 0; it < iterations; ++it) {
    sum.setZero();
    for (Eigen::Index e = 0; e < E.rows(); ++e) {
      sum.row(E(e, 0)) += W.row(E(e, 1));
      sum.row(E(e, 1)) += W.row(E(e, 0));
    }
    for (int v = 0; v < num_vertices; ++v)
      if (degree[v] > 0) W.row(v) = 0.5 * W.row(v) + 0.5 * sum.row(v) / degree[v];
  }
  for (int v = 0; v < num_vertices; ++v) W.row(v) /= W.row(v).sum();
  return W;
}

}  // namespace

struct PoseSynthesizer::Impl {
  std::shared_ptr<const PoseModel> model;
  Eigen::MatrixXd V;
  Eigen::MatrixXi F;
  SubjectSetupInfo info;
  Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> coefficients;  // #F x 63, from the template
  Eigen::Matrix<int, Eigen::Dynamic, 2, Eigen::RowMajor> triangle_joints;               // #F x 2
  Eigen::VectorXd pelvis_area;                                                          // #F: the area of pelvis triangles, 0 elsewhere
  /// #F: the part whose rotation carries each triangle's learned T^Q, its template triangle's (T^Q was
  /// learned in that part's frame), whatever part the subject's own segmentation gave the triangle.
  Eigen::VectorXi deformation_part;
  // PosePlacement::kParts (set_up_part_placement), all per row of the solver's factor (vertex
  // vertex_of_row[r]): its part, its core weight and its non-zero blend weights (blend_start[r] ..
  // blend_start[r + 1] in blend_part, blend_weight); per part its core's total weight and rest mean;
  // the LU of the core means of the blend weights.
  bool parts_placed = false;
  std::vector<int> vertex_of_row, part_of_row;
  std::vector<double> core_of_row;
  Eigen::Matrix<double, kNumParts, 1> part_core_total;
  std::array<Eigen::Vector3d, kNumParts> part_core_rest;
  std::vector<int> blend_start, blend_part;
  std::vector<double> blend_weight;
  Eigen::FullPivLU<Eigen::Matrix<double, kNumParts, kNumParts>> placement_system;
  void set_up_part_placement(const Eigen::VectorXd& face_area);
  /// X from Eq. 6's solution Y (factor order, any translation): each part moved so that its core's
  /// mean meets T^R's placement of it. The blend weights sum to 1, so Y's translation cancels.
  void place_parts(const PartTransforms& T, const double* Y, Eigen::MatrixXd* X) const;
  Eigen::VectorXi vertex_part;  // #V
  double offset_scale = 1;      // the subject's height over the template's, for joint offsets
  Eigen::MatrixXd lbs_weights;  // #V x 16
  std::unique_ptr<PoissonSolver> solver;
  /// Eq. 4 folded into the solver's right-hand side: B_kf e_c (x y z), B_kf the 3 x 3 map of feature
  /// f of triangle k and e_c the solver's weighted rest edge c, for c = 0, 1 only (a triangle's edges
  /// sum to zero, so B e_2 = -B e_0 - B e_1). Per triangle in order: the bias (f = 6), then for each
  /// of its joints (slot 0, then 1, if any) the three twist axes; two floats of padding at the end.
  /// Float: the regression's own residual is 1e4 times larger than the rounding.
  std::vector<float> edge_coefficients;
  /// The solver's right-hand side for the learned method (its per-thread buffer, see
  /// PoissonSolver::finish).
  double* right_hand_side(const PartPose& pose, const PartTransforms& T) const;
};

namespace {}  // namespace

PoseSynthesizer::PoseSynthesizer(std::shared_ptr<const PoseModel> model, const TriangleMesh& subject, const SubjectSetupOptions& options)
    : impl_(std::make_unique<Impl>()) {
  Impl& s = *impl_;
  if (!model) throw InvalidInput("PoseSynthesizer: no model");
  require_usable_mesh(subject, "subject mesh");
  s.model = model;
  s.V = subject.V;
  s.F = subject.F;
  const PoseModel& M = *model;
  Stopwatch t0;
  if (options.is_template) {
    if (subject.V.rows() != M.template_V.rows() || subject.F != M.template_F)
      throw InvalidInput("the mesh is not the model's template (" + std::to_string(subject.V.rows()) + " vertices, " +
                         std::to_string(subject.F.rows()) + " triangles; the model was trained on " + std::to_string(M.template_V.rows()) +
                         " and " + std::to_string(M.template_F.rows()) + ")");
    s.info.triangle_part = M.triangle_part;
    s.info.joint_centres = M.joint_centres;
    s.info.template_triangle = Eigen::VectorXi::LinSpaced(s.F.rows(), 0, static_cast<int>(s.F.rows()) - 1);
  } else {
    const BodyFeatures template_features = find_body_features(M.template_V, M.template_F);
    const LayeredRepresentation template_rep = build_layered_representation(M.template_V, M.template_F, template_features);
    const BodyFeatures features = find_body_features(s.V, s.F);
    const LayeredRepresentation rep = build_layered_representation(s.V, s.F, features);
    s.info.seconds_representation = t0.seconds();
    t0.restart();
    SegmentationPrior template_alone;  // a model without a prior: the template's own labelling
    if (M.segmentation_prior.bodies.empty())
      template_alone.bodies.push_back(make_calibration_body(M.template_V, M.template_F, M.triangle_part, M.joint_centres, template_rep));
    const SegmentationPrior& prior = template_alone.bodies.empty() ? M.segmentation_prior : template_alone;
    BodySegmentation result = segment_standing_body(s.V, s.F, rep, features, &prior);
    s.info.triangle_part = std::move(result.segmentation.triangle_part);
    s.info.joint_centres = std::move(result.joints);
    s.info.skeleton_problems = std::move(result.check.problems);
    s.info.seconds_segmentation = t0.seconds();
    t0.restart();
    // ct-FFD's target layers sit at the template's torso proportions (segmentation keeps the features').
    const LayeredRepresentation rep_in_proportion =
        build_layered_representation(s.V, s.F, torso_levels_in_proportion(features, template_features));
    const Eigen::MatrixXd deformed = ctffd_evaluate(ctffd_parametrize(M.template_V, template_rep), rep_in_proportion);
    s.info.template_triangle = nearest_centroid_correspondence(deformed, M.template_F, s.V, s.F, &s.info.normal_failures);
    s.info.seconds_correspondence = t0.seconds();
  }
  if (options.triangle_part.size()) {
    if (options.triangle_part.size() != s.F.rows() || options.triangle_part.minCoeff() < 0 || options.triangle_part.maxCoeff() >= kNumParts)
      throw InvalidInput("subject labels: expected " + std::to_string(s.F.rows()) + " labels in [0, 16)");
    s.info.triangle_part = options.triangle_part;
  }
  if (options.joint_centres.size()) {
    if (options.joint_centres.rows() != kNumJoints || options.joint_centres.cols() != 3)
      throw InvalidInput("subject joints: expected " + std::to_string(kNumJoints) + " x 3 joint centres");
    s.info.joint_centres = options.joint_centres;
  }
  if (options.template_triangle.size()) {
    if (options.template_triangle.size() != s.F.rows() || options.template_triangle.minCoeff() < 0 ||
        options.template_triangle.maxCoeff() >= M.template_F.rows())
      throw InvalidInput("subject correspondence: expected " + std::to_string(s.F.rows()) + " template triangle indices in [0, " +
                         std::to_string(M.template_F.rows()) + ")");
    s.info.template_triangle = options.template_triangle;
  }
  s.coefficients.resize(s.F.rows(), M.coefficients.cols());
  s.triangle_joints.resize(s.F.rows(), 2);
  s.deformation_part.resize(s.F.rows());
  for (Eigen::Index k = 0; k < s.F.rows(); ++k) {
    s.coefficients.row(k) = M.coefficients.row(s.info.template_triangle[k]);
    s.triangle_joints.row(k) = M.triangle_joints.row(s.info.template_triangle[k]);
    s.deformation_part[k] = M.triangle_part[s.info.template_triangle[k]];
  }
  s.vertex_part = vertex_labels_from_triangles(s.V, s.F, s.info.triangle_part);
  {
    const double height = s.V.col(1).maxCoeff() - s.V.col(1).minCoeff();
    const double template_height = M.template_V.col(1).maxCoeff() - M.template_V.col(1).minCoeff();
    s.offset_scale = template_height > 0 ? height / template_height : 1.0;
  }

  const Eigen::VectorXd face_area = face_areas(s.V, s.F);
  const Eigen::MatrixXi edges = unique_edges(s.F);
  Eigen::VectorXd edge_length(edges.rows());
  for (Eigen::Index e = 0; e < edges.rows(); ++e) edge_length[e] = (s.V.row(edges(e, 0)) - s.V.row(edges(e, 1))).norm();

  t0.restart();
  Eigen::VectorXd triangle_weight;
  if (options.weight_by_residuals) {
    const Eigen::VectorXd template_weight = eq6_triangle_weights(M);
    if (template_weight.size()) {
      triangle_weight.resize(s.F.rows());
      for (Eigen::Index k = 0; k < s.F.rows(); ++k) triangle_weight[k] = template_weight[s.info.template_triangle[k]];
    }
  }
  s.solver = std::make_unique<PoissonSolver>(s.V, s.F, Eigen::VectorXd(), triangle_weight);
  s.info.seconds_factorisation = t0.seconds();
  const PoissonSolver::EdgeMatrix& rest_edges = s.solver->weighted_rest_edges();
  s.edge_coefficients.clear();
  s.edge_coefficients.reserve(static_cast<size_t>(s.F.rows()) * 6 * kPoseFeatures + 2);
  for (Eigen::Index k = 0; k < s.F.rows(); ++k) {
    for (int f : {6, 0, 1, 2, 3, 4, 5}) {
      if (f < 6 && s.triangle_joints(k, f / 3) < 0) continue;
      Eigen::Matrix3d B;
      for (int m = 0; m < 9; ++m) B(m / 3, m % 3) = s.coefficients(k, m * kPoseFeatures + f);
      for (int c = 0; c < 2; ++c) {
        const Eigen::Vector3d b = B * rest_edges.row(k).segment<3>(4 * c).transpose();
        for (int d = 0; d < 3; ++d) s.edge_coefficients.push_back(static_cast<float>(b[d]));
      }
    }
  }
  s.edge_coefficients.insert(s.edge_coefficients.end(), 2, 0.0f);  // the last 8-float load stays inside

  s.pelvis_area = Eigen::VectorXd::Zero(s.F.rows());
  for (Eigen::Index k = 0; k < s.F.rows(); ++k)
    if (s.info.triangle_part[k] == kPelvis) s.pelvis_area[k] = face_area[k];
  if (!(s.pelvis_area.sum() > 0)) throw InvalidInput("subject mesh: no triangle was labelled pelvis; is it a standing body?");

  int iterations = options.lbs_smoothing_iterations;
  if (iterations <= 0) {
    const double mean_edge = edge_length.size() ? edge_length.mean() : 0.0;
    const double rings = 0.03 / std::max(mean_edge, 1e-6);  // blend over about 3 cm
    iterations = static_cast<int>(std::clamp(2 * rings * rings, 4.0, 400.0));
  }
  s.lbs_weights = diffuse_part_weights(s.F, s.vertex_part, static_cast<int>(s.V.rows()), iterations);
  if (options.placement == PosePlacement::kParts) s.set_up_part_placement(face_area);
}

void PoseSynthesizer::Impl::set_up_part_placement(const Eigen::VectorXd& face_area) {
  // Each vertex's sensitivity to the pose (its triangles' largest twist-coefficient norm) and area.
  Eigen::VectorXd sensitivity = Eigen::VectorXd::Zero(V.rows()), weight = Eigen::VectorXd::Zero(V.rows());
  for (Eigen::Index k = 0; k < F.rows(); ++k) {
    double sq = 0;
    for (int entry = 0; entry < 9; ++entry) sq += coefficients.row(k).segment<6>(entry * kPoseFeatures).squaredNorm();
    for (int c = 0; c < 3; ++c) {
      sensitivity[F(k, c)] = std::max(sensitivity[F(k, c)], std::sqrt(sq));
      weight[F(k, c)] += face_area[k] / 3;
    }
  }
  std::array<std::vector<double>, kNumParts> part_sensitivity;
  for (Eigen::Index v = 0; v < V.rows(); ++v) part_sensitivity[static_cast<size_t>(vertex_part[v])].push_back(sensitivity[v]);
  std::array<double, kNumParts> median{};
  for (size_t p = 0; p < part_sensitivity.size(); ++p) {
    std::vector<double>& values = part_sensitivity[p];
    if (values.empty()) continue;
    std::nth_element(values.begin(), values.begin() + static_cast<long>(values.size() / 2), values.end());
    median[p] = values[values.size() / 2];
  }
  Eigen::VectorXd core_weight(V.rows());
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    const double m = median[static_cast<size_t>(vertex_part[v])];
    const double r = m > 0 ? sensitivity[v] / m : 0;
    core_weight[v] = weight[v] * std::exp(-r * r);
  }
  // Per part its core's rest mean; the blend's non-zero weights per vertex; the system that maps the
  // parts' moves to their cores' mean moves (core means of the blend weights).
  part_core_total.setZero();
  part_core_rest.fill(Eigen::Vector3d::Zero());
  for (Eigen::Index v = 0; v < V.rows(); ++v) {
    const auto p = static_cast<size_t>(vertex_part[v]);
    part_core_rest[p] += core_weight[v] * V.row(v).transpose();
    part_core_total[static_cast<Eigen::Index>(p)] += core_weight[v];
  }
  const size_t n = static_cast<size_t>(V.rows());
  vertex_of_row.resize(n);
  for (size_t v = 0; v < n; ++v) vertex_of_row[static_cast<size_t>(solver->factor_rows()[v])] = static_cast<int>(v);
  part_of_row.resize(n), core_of_row.resize(n);
  blend_start.assign(n + 1, 0);
  blend_part.clear(), blend_weight.clear();
  Eigen::Matrix<double, kNumParts, kNumParts> system = Eigen::Matrix<double, kNumParts, kNumParts>::Zero();
  for (size_t r = 0; r < n; ++r) {
    const int v = vertex_of_row[r];
    part_of_row[r] = vertex_part[v], core_of_row[r] = core_weight[v];
    for (int q = 0; q < kNumParts; ++q)
      if (lbs_weights(v, q) > 0) {
        blend_part.push_back(q), blend_weight.push_back(lbs_weights(v, q));
        system(vertex_part[v], q) += core_weight[v] * lbs_weights(v, q);
      }
    blend_start[r + 1] = static_cast<int>(blend_part.size());
  }
  for (int p = 0; p < kNumParts; ++p) {
    if (part_core_total[p] > 0) {
      part_core_rest[static_cast<size_t>(p)] /= part_core_total[p];
      system.row(p) /= part_core_total[p];
    } else {
      system.row(p).setZero(), system(p, p) = 1;  // a part without vertices: no move
    }
  }
  placement_system = system.fullPivLu();
  if (!placement_system.isInvertible()) throw InvalidInput("subject mesh: its parts cannot be placed (a part without a core)");
  parts_placed = true;
}

Eigen::VectorXd eq6_triangle_weights(const PoseModel& model) {
  const Eigen::VectorXd& r = model.triangle_rms;
  if (r.size() == 0 || r.size() != model.template_F.rows()) return {};
  const double pooled = r.squaredNorm() / static_cast<double>(r.size());
  if (!(pooled > 0)) return Eigen::VectorXd::Ones(r.size());  // every T^Q exact: nothing to weigh
  return (pooled / (r.array().square() + pooled)).matrix();
}

PoseSynthesizer::~PoseSynthesizer() = default;

const Eigen::MatrixXd& PoseSynthesizer::rest_vertices() const { return impl_->V; }
const Eigen::MatrixXi& PoseSynthesizer::faces() const { return impl_->F; }
const Eigen::VectorXi& PoseSynthesizer::vertex_parts() const { return impl_->vertex_part; }

const SubjectSetupInfo& PoseSynthesizer::info() const { return impl_->info; }

namespace {
/// Per-thread buffers of pose(), so that posing a motion does not allocate per frame.
struct PoseScratch {
  Eigen::Matrix<double, Eigen::Dynamic, 12, Eigen::RowMajor> blend;
};
PoseScratch& pose_scratch() {
  thread_local PoseScratch scratch;
  return scratch;
}

/// The right-hand side of Eq. 6 for one learned pose, straight into the solver's buffer: per triangle
/// the transformed weighted edges e_c = R_part (sum_f x_f B_kf) e_c (Eq. 4 and Eq. 1, with the
/// products B_kf e_c precomputed) and their divergence at the corners.
struct RightHandSideInput {
  long triangles;
  const int* triangle_part;
  const int* triangle_joints;    // 2 per triangle, -1: none
  const float* coefficients;     // PoseSynthesizer::Impl::edge_coefficients
  const double* part_columns;    // per part the three columns of R, four doubles each (the fourth 0)
  const double* joint_rotation;  // 3 per joint
  const int* corners;            // PoissonSolver::factor_corners()
  double* rhs;                   // PoissonSolver::start_right_hand_side()
};

inline __attribute__((always_inline)) void right_hand_side_body(const RightHandSideInput& in) {
  using simd::Double4;
  const Double4* columns = reinterpret_cast<const Double4*>(in.part_columns);
  Double4* rows = reinterpret_cast<Double4*>(in.rhs);
  const float* b = in.coefficients;
  for (long k = 0; k < in.triangles; ++k) {
    // sum_f x_f B_kf e_c in float: one feature's six entries (edges 0 and 1; edge 2 is minus their
    // sum) in one 8-float register.
    simd::Float8u sum = *reinterpret_cast<const simd::Float8u*>(b);  // the bias
    int features = 1;
    for (int slot = 0; slot < 2; ++slot) {
      const int joint = in.triangle_joints[2 * k + slot];
      if (joint < 0) continue;
      for (int axis = 0; axis < 3; ++axis, ++features)
        sum += static_cast<float>(in.joint_rotation[3 * joint + axis]) * *reinterpret_cast<const simd::Float8u*>(b + 6 * features);
    }
    b += 6 * features;
    double g[6];
    for (int i = 0; i < 6; ++i) g[i] = sum[i];
    const Double4* R = columns + 3 * in.triangle_part[k];
    const Double4 e0 = g[0] * R[0] + g[1] * R[1] + g[2] * R[2];
    const Double4 e1 = g[3] * R[0] + g[4] * R[1] + g[5] * R[2];
    // Corner c gets e_{c-1} - e_c, with e_2 = -e_0 - e_1.
    const int* corner = in.corners + 3 * k;
    rows[corner[0]] -= e0 + e0 + e1;
    rows[corner[1]] += e0 - e1;
    rows[corner[2]] += e0 + e1 + e1;
  }
}
POSEKIT_TARGET_AVX2 void right_hand_side_avx2(const RightHandSideInput& in) { right_hand_side_body(in); }
void right_hand_side_portable(const RightHandSideInput& in) { right_hand_side_body(in); }
}  // namespace

double* PoseSynthesizer::Impl::right_hand_side(const PartPose& pose, const PartTransforms& T) const {
  alignas(32) double part_columns[kNumParts * 12];
  for (int p = 0; p < kNumParts; ++p)
    for (int c = 0; c < 3; ++c) {
      for (int d = 0; d < 3; ++d) part_columns[12 * p + 4 * c + d] = T.R[static_cast<size_t>(p)](d, c);
      part_columns[12 * p + 4 * c + 3] = 0;
    }
  double* rhs = solver->start_right_hand_side();
  const RightHandSideInput input{F.rows(),     deformation_part.data(),       triangle_joints.data(),   edge_coefficients.data(),
                                 part_columns, pose.joint_rotation[0].data(), solver->factor_corners(), rhs};
  (simd::has_avx2() ? right_hand_side_avx2 : right_hand_side_portable)(input);
  return rhs;
}

void PoseSynthesizer::Impl::place_parts(const PartTransforms& T, const double* Y, Eigen::MatrixXd* X) const {
  const size_t n = vertex_of_row.size();
  Eigen::Matrix<double, kNumParts, 3> miss = Eigen::Matrix<double, kNumParts, 3>::Zero();
  for (size_t r = 0; r < n; ++r)
    for (int d = 0; d < 3; ++d) miss(part_of_row[r], d) -= core_of_row[r] * Y[4 * r + d];
  for (int p = 0; p < kNumParts; ++p) {
    const auto q = static_cast<size_t>(p);
    if (part_core_total[p] > 0) miss.row(p) = (T.R[q] * part_core_rest[q] + T.t[q]).transpose() + miss.row(p) / part_core_total[p];
  }
  const Eigen::Matrix<double, kNumParts, 3, Eigen::RowMajor> move = placement_system.solve(miss);
  X->resize(V.rows(), 3);
  double* x = X->data();
  const Eigen::Index stride = V.rows();
  for (size_t r = 0; r < n; ++r) {
    double y[3] = {Y[4 * r], Y[4 * r + 1], Y[4 * r + 2]};
    for (int k = blend_start[r]; k < blend_start[r + 1]; ++k) {
      const double w = blend_weight[static_cast<size_t>(k)];
      const double* m = move.data() + 3 * blend_part[static_cast<size_t>(k)];
      for (int d = 0; d < 3; ++d) y[d] += w * m[d];
    }
    const Eigen::Index v = vertex_of_row[r];
    for (int d = 0; d < 3; ++d) x[v + d * stride] = y[d];
  }
}

Eigen::MatrixXd PoseSynthesizer::pose(const PartPose& pose, PoseMethod method) const {
  Eigen::MatrixXd X;
  this->pose(pose, method, &X);
  return X;
}

void PoseSynthesizer::pose(const PartPose& pose, PoseMethod method, Eigen::MatrixXd* X) const {
  // The learned method places the joints where the examples showed them; the baselines do not.
  pose_with(pose, method, method == PoseMethod::kLearned ? impl_->model->joint_offsets : Eigen::MatrixXd(), X);
}

PartTransforms PoseSynthesizer::part_motions(const PartPose& pose, PoseMethod method) const {
  const Impl& s = *impl_;
  return part_transforms(pose, s.info.joint_centres, method == PoseMethod::kLearned ? s.model->joint_offsets : Eigen::MatrixXd(),
                         s.offset_scale);
}

Eigen::MatrixXd PoseSynthesizer::joint_pivots(PoseMethod method) const {
  const Impl& s = *impl_;
  Eigen::MatrixXd pivots = s.info.joint_centres;
  const Eigen::MatrixXd& offsets = s.model->joint_offsets;
  if (method != PoseMethod::kLearned || offsets.size() == 0) return pivots;
  for (int j = 0; j < kNumJoints; ++j) {
    // The linear part of an offset about a pivot D is [D]x (pivot_offset_coefficients): D from its
    // skew-symmetric part.
    Eigen::Matrix3d L;
    for (int d = 0; d < 3; ++d)
      for (int f = 0; f < 3; ++f) L(d, f) = offsets(j, d * kOffsetFeatures + f);
    const Eigen::Matrix3d S = 0.5 * (L - L.transpose());
    pivots.row(j) += s.offset_scale * Eigen::RowVector3d(S(2, 1), S(0, 2), S(1, 0));
  }
  return pivots;
}

void PoseSynthesizer::pose_with_joint_offsets(const PartPose& pose, const Eigen::MatrixXd& joint_offsets, Eigen::MatrixXd* X) const {
  pose_with(pose, PoseMethod::kLearned, joint_offsets, X);
}

void PoseSynthesizer::pose_with(const PartPose& pose, PoseMethod method, const Eigen::MatrixXd& joint_offsets, Eigen::MatrixXd* X) const {
  const Impl& s = *impl_;
  validate_part_pose(pose, "pose");
  const PartTransforms T = part_transforms(pose, s.info.joint_centres, joint_offsets, s.offset_scale);
  PoseScratch& scratch = pose_scratch();
  if (method == PoseMethod::kRigid) {
    X->resize(s.V.rows(), 3);
    for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
      const size_t p = static_cast<size_t>(s.vertex_part[v]);
      X->row(v) = (T.R[p] * s.V.row(v).transpose() + T.t[p]).transpose();
    }
    return;
  }
  if (method == PoseMethod::kLbs) {
    // Per vertex the weighted sum of the 16 part motions [R_p | t_p], as one dense product.
    Eigen::Matrix<double, kNumParts, 12, Eigen::RowMajor> motions;
    for (int p = 0; p < kNumParts; ++p) {
      for (int m = 0; m < 9; ++m) motions(p, m) = T.R[static_cast<size_t>(p)](m / 3, m % 3);
      motions.row(p).tail<3>() = T.t[static_cast<size_t>(p)].transpose();
    }
    scratch.blend.noalias() = s.lbs_weights * motions;
    X->resize(s.V.rows(), 3);
    for (Eigen::Index v = 0; v < s.V.rows(); ++v) {
      const double* m = scratch.blend.data() + 12 * v;
      for (int d = 0; d < 3; ++d) (*X)(v, d) = m[3 * d] * s.V(v, 0) + m[3 * d + 1] * s.V(v, 1) + m[3 * d + 2] * s.V(v, 2) + m[9 + d];
    }
    return;
  }
  // Only the learned method goes through Eq. 6.
  double* rhs = s.right_hand_side(pose, T);
  if (s.parts_placed) {
    s.solver->solve_in_place(rhs);
    s.place_parts(T, rhs, X);
    return;
  }
  // Anchor: the pelvis where it stays rigid (T^Q near the identity), so that skin moving at the hips
  // does not drag the body along.
  Eigen::VectorXd anchor = s.pelvis_area;
  for (Eigen::Index k = 0; k < s.F.rows(); ++k) {
    if (!(anchor[k] > 0)) continue;
    Eigen::Matrix<double, kPoseFeatures, 1> x = Eigen::Matrix<double, kPoseFeatures, 1>::Zero();
    const int a = s.triangle_joints(k, 0), b = s.triangle_joints(k, 1);
    if (a >= 0) x.segment<3>(0) = pose.joint(a);
    if (b >= 0) x.segment<3>(3) = pose.joint(b);
    x[6] = 1;
    const Eigen::Map<const Eigen::Matrix<double, 9, kPoseFeatures, Eigen::RowMajor>> B(s.coefficients.row(k).data());
    const Eigen::Matrix<double, 9, 1> q = B * x;
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> Q(q.data());
    anchor[k] *= std::exp(-(Q - Eigen::Matrix3d::Identity()).squaredNorm() / (0.02 * 0.02));
  }
  if (!(anchor.sum() > 1e-6 * s.pelvis_area.sum())) anchor = s.pelvis_area;
  s.solver->finish(rhs, anchor, T.R[kPelvis], T.t[kPelvis], X);
}

}  // namespace posekit
