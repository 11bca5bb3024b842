#include "posekit/evaluation/pose_evaluation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"
#include "posekit/core/timer.h"
#include "posekit/core/units.h"
#include "posekit/datasets/dataset.h"
#include "posekit/datasets/remesh.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/layered_representation.h"

namespace fs = std::filesystem;

namespace posekit {

ErrorStats error_stats(const std::vector<double>& d) {
  ErrorStats s;
  s.count = static_cast<long>(d.size());
  if (d.empty()) return s;
  std::vector<double> sorted = d;
  double sum = 0;
  for (double x : d) sum += x;
  const size_t k = std::min(sorted.size() - 1, static_cast<size_t>(std::ceil(0.95 * static_cast<double>(sorted.size()))) - 1);
  std::nth_element(sorted.begin(), sorted.begin() + static_cast<long>(k), sorted.end());
  s.p95_mm = 1000 * sorted[k];
  s.max_mm = 1000 * *std::max_element(d.begin(), d.end());
  s.mean_mm = 1000 * sum / static_cast<double>(d.size());
  return s;
}

namespace {

struct Accumulator {
  std::vector<double> all;
  std::array<std::vector<double>, kNumParts> part;
  void add(const Eigen::MatrixXd& X, const Eigen::MatrixXd& truth, const Eigen::VectorXi& vertex_part) {
    for (Eigen::Index v = 0; v < X.rows(); ++v) {
      const double e = (X.row(v) - truth.row(v)).norm();
      all.push_back(e);
      part[static_cast<size_t>(vertex_part[v])].push_back(e);
    }
  }
  MethodErrors result(PoseMethod m) const {
    MethodErrors r{m, error_stats(all), {}};
    for (int p = 0; p < kNumParts; ++p) r.per_part[static_cast<size_t>(p)] = error_stats(part[static_cast<size_t>(p)]);
    return r;
  }
};

}  // namespace

namespace {

/// The kind of a pose by its name: "walk", "reach", "squat" (squats, lunge), "sit", "torso",
/// "combined" (random, guard, t_pose) or "single joint".
std::string pose_type(const std::string& name) {
  auto starts = [&](const char* prefix) { return name.rfind(prefix, 0) == 0; };
  if (starts("walk")) return "walk";
  if (starts("reach")) return "reach";
  if (starts("squat") || starts("lunge")) return "squat";
  if (starts("sit")) return "sit";
  if (starts("torso")) return "torso";
  if (starts("random") || starts("guard") || starts("t_pose")) return "combined";
  return "single joint";
}

}  // namespace

PoseEvaluation evaluate_poses(const std::string& dir, std::shared_ptr<const PoseModel> model, const PoseEvaluationOptions& options) {
  PoseEvaluation out;
  for (const char* type : {"single joint", "walk", "reach", "squat", "sit", "torso", "combined"}) {
    PoseTypeErrors t;
    t.type = type;
    t.template_mean_mm.assign(options.methods.size(), 0.0);
    t.subject_mean_mm.assign(options.methods.size(), 0.0);
    out.by_pose_type.push_back(t);
  }
  // Sums of per-vertex errors (m) and vertex counts per type, then means in mm.
  std::vector<long> template_vertices(out.by_pose_type.size(), 0), subject_vertices(out.by_pose_type.size(), 0);
  auto type_of = [&](const std::string& name) -> PoseTypeErrors& {
    for (auto& t : out.by_pose_type)
      if (t.type == pose_type(name)) return t;
    return out.by_pose_type.back();
  };
  auto add_type = [&](const std::string& name, size_t method, const Eigen::MatrixXd& X, const Eigen::MatrixXd& truth, bool subject) {
    PoseTypeErrors& t = type_of(name);
    (subject ? t.subject_mean_mm : t.template_mean_mm)[method] += (X - truth).rowwise().norm().sum();
    if (method == 0) (subject ? subject_vertices : template_vertices)[static_cast<size_t>(&t - out.by_pose_type.data())] += X.rows();
  };
  const PoseModel& M = *model;
  const nlohmann::json manifest = read_json_file((std::filesystem::path(dir) / "manifest.json").string());
  const TemplateAnnotations ann = load_template_annotations(dir);
  const Eigen::VectorXi template_vertex_part = ann.triangle_part.size() == M.template_F.rows()
                                                   ? vertex_labels_from_triangles(M.template_V, M.template_F, ann.triangle_part)
                                                   : vertex_labels_from_triangles(M.template_V, M.template_F, M.triangle_part);
  const Eigen::VectorXi& template_triangle_part = ann.triangle_part.size() == M.template_F.rows() ? ann.triangle_part : M.triangle_part;

  int total_steps = 0, step = 0;
  const PoseDataset data = options.template_poses ? load_pose_dataset(dir) : PoseDataset{};
  for (size_t i = 0; i < data.names.size(); ++i) total_steps += data.test[i] && data.has_pose[i];
  const auto subjects = manifest.value("subjects", nlohmann::json::array());
  if (options.subjects) total_steps += static_cast<int>(subjects.size());
  auto tick = [&](const std::string& what) {
    if (options.progress) options.progress(++step, total_steps, what);
  };

  if (options.template_poses) {
    const int rest = find_rest_example(data);
    if (rest < 0) throw InvalidInput(dir + ": the pose dataset has no rest example");
    const Eigen::MatrixXd& V0 = data.V[static_cast<size_t>(rest)];
    if (V0.rows() != M.template_V.rows() || data.F != M.template_F || (V0 - M.template_V).cwiseAbs().maxCoeff() > 1e-6)
      throw InvalidInput("the model was trained on another template than the pose dataset of " + dir + " (" +
                         std::to_string(M.template_V.rows()) + " vs " + std::to_string(V0.rows()) + " vertices)");
    TriangleMesh templ;
    templ.V = V0;
    templ.F = data.F;
    SubjectSetupOptions so;
    so.is_template = true;
    const PoseSynthesizer synth(model, templ, so);
    std::vector<Accumulator> acc(options.methods.size());
    for (size_t i = 0; i < data.names.size(); ++i) {
      if (!data.test[i] || !data.has_pose[i]) continue;
      for (size_t m = 0; m < options.methods.size(); ++m) {
        const Eigen::MatrixXd X = synth.pose(data.poses[i], options.methods[m]);
        acc[m].add(X, data.V[i], template_vertex_part);
        add_type(data.names[i], m, X, data.V[i], false);
      }
      ++type_of(data.names[i]).template_poses;
      ++out.test_poses;
      tick("template pose " + data.names[i]);
    }
    for (size_t m = 0; m < options.methods.size(); ++m) out.template_errors.push_back(acc[m].result(options.methods[m]));
  }

  if (options.subjects) {
    std::vector<Accumulator> pooled(options.methods.size());
    std::vector<double> pose_ms;
    for (const auto& s : subjects) {
      SubjectPoseReport report;
      report.id = s.value("id", "?");
      const TriangleMesh subject = load_subject_mesh((fs::path(dir) / s.at("rest").get<std::string>()).string());
      // Ground-truth vertex parts through the dataset's correspondence (when it has one).
      Eigen::VectorXi vertex_part = Eigen::VectorXi::Zero(subject.V.rows());
      Eigen::VectorXi truth_triangles;
      if (s.contains("correspondence") && template_triangle_part.size() == M.template_F.rows()) {
        const SurfacePoints corr = load_correspondence((fs::path(dir) / s["correspondence"].get<std::string>()).string());
        if (corr.face.size() == subject.V.rows() && corr.face.maxCoeff() < M.template_F.rows()) {
          for (Eigen::Index v = 0; v < subject.V.rows(); ++v) vertex_part[v] = template_triangle_part[corr.face[v]];
          truth_triangles.resize(subject.F.rows());
          for (Eigen::Index f = 0; f < subject.F.rows(); ++f) {
            const int a = vertex_part[subject.F(f, 0)], b = vertex_part[subject.F(f, 1)], c = vertex_part[subject.F(f, 2)];
            truth_triangles[f] = (b == c) ? b : a;
          }
        }
      }
      const Stopwatch t0;
      const PoseSynthesizer synth(model, subject);
      report.setup_seconds = t0.seconds();
      if (truth_triangles.size())
        report.segmentation_agreement = label_agreement(subject.V, subject.F, truth_triangles, synth.info().triangle_part);
      if (s.contains("joints") && fs::is_regular_file(fs::path(dir) / s["joints"].get<std::string>())) {
        const Eigen::MatrixXd J = read_joint_centres((fs::path(dir) / s["joints"].get<std::string>()).string());
        const Eigen::VectorXd e = (J - synth.info().joint_centres).rowwise().norm();
        report.joint_error_max_mm = 1000 * e.maxCoeff();
        report.joint_error_mean_mm = 1000 * e.mean();
      }
      std::vector<Accumulator> acc(options.methods.size());
      for (const auto& p : s.value("posed", nlohmann::json::array())) {
        const TriangleMesh truth = read_mesh((fs::path(dir) / p.at("mesh").get<std::string>()).string());
        const PartPose pose = read_part_pose((fs::path(dir) / p.at("pose_json").get<std::string>()).string());
        if (truth.V.rows() != subject.V.rows())
          throw InvalidInput(p.at("mesh").get<std::string>() + ": " + std::to_string(truth.V.rows()) + " vertices, the subject has " +
                             std::to_string(subject.V.rows()));
        for (size_t m = 0; m < options.methods.size(); ++m) {
          const Stopwatch t1;
          const Eigen::MatrixXd X = synth.pose(pose, options.methods[m]);
          if (options.methods[m] == PoseMethod::kLearned) pose_ms.push_back(1000 * t1.seconds());
          acc[m].add(X, truth.V, vertex_part);
          pooled[m].add(X, truth.V, vertex_part);
          add_type(p.value("pose", ""), m, X, truth.V, true);
        }
        ++type_of(p.value("pose", "")).subject_meshes;
      }
      for (size_t m = 0; m < options.methods.size(); ++m) report.methods.push_back(acc[m].result(options.methods[m]));
      out.subjects.push_back(std::move(report));
      tick("subject " + out.subjects.back().id);
    }
    for (size_t m = 0; m < options.methods.size(); ++m) out.subject_errors.push_back(pooled[m].result(options.methods[m]));
    if (!pose_ms.empty()) {
      std::nth_element(pose_ms.begin(), pose_ms.begin() + static_cast<long>(pose_ms.size() / 2), pose_ms.end());
      out.pose_ms_median = pose_ms[pose_ms.size() / 2];
    }
  }
  for (size_t t = 0; t < out.by_pose_type.size(); ++t)
    for (size_t m = 0; m < options.methods.size(); ++m) {
      auto& e = out.by_pose_type[t];
      e.template_mean_mm[m] = template_vertices[t] ? 1000 * e.template_mean_mm[m] / static_cast<double>(template_vertices[t]) : 0;
      e.subject_mean_mm[m] = subject_vertices[t] ? 1000 * e.subject_mean_mm[m] / static_cast<double>(subject_vertices[t]) : 0;
    }
  return out;
}

namespace {

/// Per vertex, its distance from `truth` after each part of X is aligned rigidly onto it.
Eigen::VectorXd part_aligned_errors(const Eigen::MatrixXd& X, const Eigen::MatrixXd& truth,
                                    const std::array<std::vector<int>, kNumParts>& part_vertices) {
  Eigen::VectorXd e = (X - truth).rowwise().norm();  // a part of under 3 vertices keeps its raw error
  for (const auto& idx : part_vertices) {
    if (idx.size() < 3) continue;
    Eigen::Matrix3Xd A(3, static_cast<Eigen::Index>(idx.size())), B(3, static_cast<Eigen::Index>(idx.size()));
    for (size_t k = 0; k < idx.size(); ++k) {
      A.col(static_cast<Eigen::Index>(k)) = X.row(idx[k]).transpose();
      B.col(static_cast<Eigen::Index>(k)) = truth.row(idx[k]).transpose();
    }
    const Eigen::Matrix4d T = Eigen::umeyama(A, B, false);
    const Eigen::Matrix3Xd aligned = (T.topLeftCorner<3, 3>() * A).colwise() + T.topRightCorner<3, 1>();
    for (size_t k = 0; k < idx.size(); ++k)
      e[idx[k]] = (aligned.col(static_cast<Eigen::Index>(k)) - B.col(static_cast<Eigen::Index>(k))).norm();
  }
  return e;
}

/// Where a pose puts each joint centre (#joints x 3): carried by its child part's T^R.
Eigen::MatrixXd posed_joint_centres(const PartPose& pose, const Eigen::MatrixXd& joint_centres) {
  const PartTransforms T = part_transforms(pose, joint_centres);
  Eigen::MatrixXd out(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) {
    const size_t child = static_cast<size_t>(j + 1);
    out.row(j) = (T.R[child] * joint_centres.row(j).transpose() + T.t[child]).transpose();
  }
  return out;
}

/// One held-out mesh posed by every method: its pose read off it, and per method the per-vertex raw
/// and part-aligned errors (m) and the joints read back off the posed body.
struct HeldOutScore {
  PartPoseEstimate estimate;
  Eigen::MatrixXd given_joints;  ///< #joints x 3, where the estimated pose puts them
  std::vector<Eigen::VectorXd> raw, shape;
  std::vector<Eigen::MatrixXd> joints;
};

/// Reads the pose of `truth` with `estimator`, poses `synth` at it with every method and scores the
/// result. The same estimator reads each posed body's joints: a method that reproduced `truth`
/// would put them where the pose does. Safe to call from several threads at once.
HeldOutScore score_held_out(const PoseSynthesizer& synth, const PartPoseEstimator& estimator, const std::vector<PoseMethod>& methods,
                            const Eigen::MatrixXd& truth, const std::array<std::vector<int>, kNumParts>& part_vertices) {
  HeldOutScore out;
  out.estimate = estimator.estimate(truth);
  out.given_joints = posed_joint_centres(out.estimate.pose, synth.info().joint_centres);
  for (PoseMethod method : methods) {
    const Eigen::MatrixXd X = synth.pose(out.estimate.pose, method);
    out.raw.push_back((X - truth).rowwise().norm());
    out.shape.push_back(part_aligned_errors(X, truth, part_vertices));
    out.joints.push_back(posed_joint_centres(estimator.estimate(X).pose, synth.info().joint_centres));
  }
  return out;
}

/// Every held-out mesh of `names` (`meshes` their vertices) scored on all cores, in order.
std::vector<HeldOutScore> score_all_held_out(const PoseSynthesizer& synth, const PartPoseEstimator& estimator,
                                             const std::vector<PoseMethod>& methods, const std::vector<const Eigen::MatrixXd*>& meshes,
                                             const std::array<std::vector<int>, kNumParts>& part_vertices) {
  std::vector<HeldOutScore> scores(meshes.size());
  parallel_for_each(static_cast<long>(meshes.size()), 0, [&](long i) {
    scores[static_cast<size_t>(i)] = score_held_out(synth, estimator, methods, *meshes[static_cast<size_t>(i)], part_vertices);
  });
  return scores;
}

/// Gathers scored held-out meshes, per method: raw and part-aligned errors per vertex, per part, per
/// mesh and per kind of pose, and where each method puts the joints.
class HeldOutScorer {
 public:
  explicit HeldOutScorer(std::vector<PoseMethod> methods) : methods_(std::move(methods)), samples_(methods_.size()) {}

  /// Adds one mesh's score (score_held_out with this scorer's methods); returns the mesh's row.
  FolderMeshErrors add(const std::string& name, const HeldOutScore& score, const Eigen::VectorXi& vertex_part) {
    FolderMeshErrors mesh;
    mesh.name = name;
    mesh.type = pose_type(name);
    mesh.pose_fit_rms_mm = 1000 * score.estimate.rms;
    mesh.problems = pose_estimate_problems(score.estimate);
    FolderTypeErrors& type = types_[mesh.type];
    type.type = mesh.type;
    type.raw_mean_mm.resize(methods_.size(), 0.0);
    type.shape_mean_mm.resize(methods_.size(), 0.0);
    ++type.meshes;
    for (size_t m = 0; m < methods_.size(); ++m) {
      const Eigen::VectorXd &raw = score.raw[m], &shape = score.shape[m];
      mesh.raw_mean_mm.push_back(1000 * raw.mean());
      mesh.shape_mean_mm.push_back(1000 * shape.mean());
      type.raw_mean_mm[m] += 1000 * raw.mean();
      type.shape_mean_mm[m] += 1000 * shape.mean();
      Sample& s = samples_[m];
      for (Eigen::Index v = 0; v < raw.size(); ++v) {
        s.raw.push_back(raw[v]);
        s.shape.push_back(shape[v]);
        s.raw_part[static_cast<size_t>(vertex_part[v])].push_back(raw[v]);
        s.shape_part[static_cast<size_t>(vertex_part[v])].push_back(shape[v]);
      }
      for (int j = 0; j < kNumJoints; ++j) {
        const double d = (score.joints[m].row(j) - score.given_joints.row(j)).norm();
        s.joints.push_back(d);
        s.joint[static_cast<size_t>(j)].push_back(d);
      }
    }
    for (int j = 0; j < kNumJoints; ++j) {
      double spread = 0;
      for (size_t a = 0; a < score.joints.size(); ++a)
        for (size_t b = a + 1; b < score.joints.size(); ++b)
          spread = std::max(spread, (score.joints[a].row(j) - score.joints[b].row(j)).norm());
      spread_.push_back(spread);
      mesh.joint_spread_max_mm = std::max(mesh.joint_spread_max_mm, 1000 * spread);
    }
    return mesh;
  }

  /// Adds another scorer's meshes (same methods) to this one's.
  void merge(const HeldOutScorer& other) {
    for (size_t m = 0; m < methods_.size(); ++m) {
      Sample& s = samples_[m];
      const Sample& o = other.samples_[m];
      auto append = [](std::vector<double>* to, const std::vector<double>& from) { to->insert(to->end(), from.begin(), from.end()); };
      append(&s.raw, o.raw);
      append(&s.shape, o.shape);
      append(&s.joints, o.joints);
      for (size_t j = 0; j < kNumJoints; ++j) append(&s.joint[j], o.joint[j]);
      for (size_t p = 0; p < kNumParts; ++p) {
        append(&s.raw_part[p], o.raw_part[p]);
        append(&s.shape_part[p], o.shape_part[p]);
      }
    }
    spread_.insert(spread_.end(), other.spread_.begin(), other.spread_.end());
    for (const auto& [name, t] : other.types_) {
      FolderTypeErrors& mine = types_[name];
      mine.type = name;
      mine.raw_mean_mm.resize(methods_.size(), 0.0);
      mine.shape_mean_mm.resize(methods_.size(), 0.0);
      mine.meshes += t.meshes;
      for (size_t m = 0; m < methods_.size(); ++m) {
        mine.raw_mean_mm[m] += t.raw_mean_mm[m];
        mine.shape_mean_mm[m] += t.shape_mean_mm[m];
      }
    }
  }

  void finish(std::vector<FolderMethodErrors>* methods, std::vector<FolderTypeErrors>* by_pose_type, ErrorStats* joint_spread) const {
    for (size_t m = 0; m < methods_.size(); ++m) {
      FolderMethodErrors r;
      r.method = methods_[m];
      r.raw = error_stats(samples_[m].raw);
      r.shape = error_stats(samples_[m].shape);
      r.joints = error_stats(samples_[m].joints);
      for (size_t j = 0; j < kNumJoints; ++j) r.joints_per_joint[j] = error_stats(samples_[m].joint[j]);
      for (int p = 0; p < kNumParts; ++p) {
        r.raw_per_part[static_cast<size_t>(p)] = error_stats(samples_[m].raw_part[static_cast<size_t>(p)]);
        r.shape_per_part[static_cast<size_t>(p)] = error_stats(samples_[m].shape_part[static_cast<size_t>(p)]);
      }
      methods->push_back(r);
    }
    for (auto [name, t] : types_) {
      for (size_t m = 0; m < methods_.size(); ++m) {
        t.raw_mean_mm[m] /= t.meshes;
        t.shape_mean_mm[m] /= t.meshes;
      }
      by_pose_type->push_back(t);
    }
    *joint_spread = error_stats(spread_);
  }

 private:
  struct Sample {
    std::vector<double> raw, shape, joints;
    std::array<std::vector<double>, kNumParts> raw_part, shape_part;
    std::array<std::vector<double>, kNumJoints> joint;
  };
  std::vector<PoseMethod> methods_;
  std::vector<Sample> samples_;
  std::vector<double> spread_;  ///< per mesh and joint
  std::map<std::string, FolderTypeErrors> types_;
};

/// The vertices of each part, and each vertex's part, from per-triangle labels.
std::array<std::vector<int>, kNumParts> vertices_of_parts(const Eigen::MatrixXd& V, const Eigen::MatrixXi& F,
                                                          const Eigen::VectorXi& triangle_part, Eigen::VectorXi* vertex_part) {
  *vertex_part = vertex_labels_from_triangles(V, F, triangle_part);
  std::array<std::vector<int>, kNumParts> out;
  for (Eigen::Index v = 0; v < vertex_part->size(); ++v) out[static_cast<size_t>((*vertex_part)[v])].push_back(static_cast<int>(v));
  return out;
}

}  // namespace

FolderPoseEvaluation evaluate_registered_folder(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                                const std::vector<PoseMethod>& methods) {
  FolderPoseEvaluation out;
  const Stopwatch clock;
  PreparedTraining prepared = prepare_training(dir, base, options, &out.training);
  PoseDataset& data = prepared.data;
  std::vector<size_t> held_out;
  int training = 0;
  for (size_t i = 0; i < data.names.size(); ++i) {
    if (data.test[i]) held_out.push_back(i);
    else if (static_cast<int>(i) != prepared.rest && data.has_pose[i]) ++training;
  }
  if (held_out.empty()) throw InvalidInput(dir + ": no held-out example to evaluate on (name them, or hold out every N-th)");
  if (training == 0) throw InvalidInput(dir + ": nothing left to train on besides the rest example and the held-out ones");
  const auto model = std::make_shared<const PoseModel>(train_pose_model(data, prepared.options));
  out.training_poses = model->training_poses;
  out.train_seconds = clock.seconds();

  // The held-out poses from their vertices, always (a given JSON need not be the pose its mesh shows).
  const Eigen::MatrixXd& V0 = data.V[static_cast<size_t>(prepared.rest)];
  PartPoseEstimator estimator(V0, data.F, prepared.options.triangle_part, prepared.options.joint_centres, options.fit);
  std::vector<const Eigen::MatrixXd*> training_meshes;
  for (size_t i = 0; i < data.names.size(); ++i)
    if (!data.test[i]) training_meshes.push_back(&data.V[i]);
  estimator.learn_rigid_cores(training_meshes);

  TriangleMesh rest;
  rest.V = V0;
  rest.F = data.F;
  SubjectSetupOptions so;
  so.is_template = true;
  const PoseSynthesizer synth(model, rest, so);
  Eigen::VectorXi vertex_part;
  const auto part_vertices = vertices_of_parts(V0, data.F, prepared.options.triangle_part, &vertex_part);
  std::vector<const Eigen::MatrixXd*> held_out_meshes;
  for (size_t i : held_out) held_out_meshes.push_back(&data.V[i]);
  const std::vector<HeldOutScore> scores = score_all_held_out(synth, estimator, methods, held_out_meshes, part_vertices);
  HeldOutScorer scorer(methods);
  for (size_t k = 0; k < held_out.size(); ++k) out.meshes.push_back(scorer.add(data.names[held_out[k]], scores[k], vertex_part));
  scorer.finish(&out.methods, &out.by_pose_type, &out.joint_spread);
  return out;
}

PeoplePoseEvaluation evaluate_registered_people(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                                const std::vector<PoseMethod>& methods,
                                                const std::function<void(int, int, const std::string&)>& progress) {
  if (!options.held_out.empty() || options.hold_out_every > 0)
    throw InvalidInput("several people: each person is held out in turn; no other split can be given");
  if (base.learn_joint_offsets) throw InvalidInput("several people: joint offsets are learned on one person; train without them");
  PeoplePoseEvaluation out;
  std::vector<fs::path> folders;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_directory()) folders.push_back(e.path());
  if (ec) throw IoError(dir + ": " + ec.message());
  std::sort(folders.begin(), folders.end());
  if (folders.size() < 2)
    throw InvalidInput(dir + ": " + std::to_string(folders.size()) +
                       " person folders; several people need one folder of registered meshes each, at least two");
  // Each person read on their own: unit, axes, rest example, segmentation, joints and poses.
  const int steps = 2 * static_cast<int>(folders.size());
  std::vector<PreparedTraining> person;
  for (const fs::path& f : folders) {
    DatasetTrainingReport report;
    person.push_back(prepare_training(f.string(), base, options, &report));
    out.people.push_back(f.filename().string());
    out.reports.push_back(std::move(report));
    if (progress) progress(static_cast<int>(person.size()), steps, "read " + out.people.back());
    if (person.back().data.F != person.front().data.F)
      throw InvalidInput(f.string() + ": another topology than " + folders.front().string() +
                         " (several people must share one: registered meshes)");
  }
  const Eigen::MatrixXi& F = person.front().data.F;
  const Eigen::Index nf = F.rows();
  Eigen::VectorXi identity(nf);
  for (Eigen::Index k = 0; k < nf; ++k) identity[k] = static_cast<int>(k);
  HeldOutScorer pooled(methods);
  for (size_t p = 0; p < person.size(); ++p) {
    // The others' examples in one dataset, each measured from its own person's rest; the first
    // other person's rest, labels and joints are the template's.
    PoseDataset others;
    others.F = F;
    const size_t template_person = p == 0 ? 1 : 0;
    for (size_t q = 0; q < person.size(); ++q) {
      if (q == p) continue;
      const PoseDataset& d = person[q].data;
      const int rest_index = static_cast<int>(others.names.size());
      auto push = [&](size_t i) {
        const bool rest = static_cast<int>(i) == person[q].rest;
        others.names.push_back(out.people[q] + "/" + d.names[i]);
        others.V.push_back(d.V[i]);
        others.has_pose.push_back(true);
        others.poses.push_back(rest ? PartPose{} : d.poses[i]);
        others.test.push_back(false);
        others.rest_of.push_back(rest_index);
      };
      push(static_cast<size_t>(person[q].rest));
      if (q == template_person) others.rest_name = others.names.back();
      for (size_t i = 0; i < d.names.size(); ++i)
        if (static_cast<int>(i) != person[q].rest && d.has_pose[i]) push(i);
    }
    const Stopwatch clock;
    const auto model = std::make_shared<const PoseModel>(train_pose_model(others, person[template_person].options));
    FolderPoseEvaluation result;
    result.training_poses = model->training_poses;
    result.train_seconds = clock.seconds();
    result.training = out.reports[p];
    // This person's rest mesh, posed by the others' model through the known correspondence (one
    // topology), at each of this person's poses estimated from their meshes.
    const PreparedTraining& me = person[p];
    const Eigen::MatrixXd& V0 = me.data.V[static_cast<size_t>(me.rest)];
    TriangleMesh rest;
    rest.V = V0;
    rest.F = F;
    SubjectSetupOptions so;
    so.triangle_part = me.options.triangle_part;
    so.joint_centres = me.options.joint_centres;
    so.template_triangle = identity;
    const PoseSynthesizer synth(model, rest, so);
    PartPoseEstimator estimator(V0, F, me.options.triangle_part, me.options.joint_centres, options.fit);
    std::vector<const Eigen::MatrixXd*> meshes;
    for (const auto& V : me.data.V) meshes.push_back(&V);
    estimator.learn_rigid_cores(meshes);
    Eigen::VectorXi vertex_part;
    const auto part_vertices = vertices_of_parts(V0, F, me.options.triangle_part, &vertex_part);
    std::vector<size_t> posed;
    std::vector<const Eigen::MatrixXd*> posed_meshes;
    for (size_t i = 0; i < me.data.names.size(); ++i)
      if (static_cast<int>(i) != me.rest) posed.push_back(i), posed_meshes.push_back(&me.data.V[i]);
    const std::vector<HeldOutScore> scores = score_all_held_out(synth, estimator, methods, posed_meshes, part_vertices);
    HeldOutScorer scorer(methods);
    for (size_t k = 0; k < posed.size(); ++k) result.meshes.push_back(scorer.add(me.data.names[posed[k]], scores[k], vertex_part));
    scorer.finish(&result.methods, &result.by_pose_type, &result.joint_spread);
    pooled.merge(scorer);
    out.per_person.push_back(std::move(result));
    if (progress) progress(static_cast<int>(person.size() + p + 1), steps, "evaluated " + out.people[p]);
  }
  pooled.finish(&out.methods, &out.by_pose_type, &out.joint_spread);
  return out;
}

}  // namespace posekit
