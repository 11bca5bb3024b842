#include "posekit/population/survey_fit.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/QR>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <mutex>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"

namespace posekit {
namespace {

constexpr int kMacroSliders = 4;  // muscle, weight, height, proportions

/// A morph target restricted to the measured vertices.
struct ReducedTarget {
  std::vector<int> rows;
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> delta;
};

ReducedTarget reduce(const MorphTarget& t, const std::vector<int>& row_of_base) {
  ReducedTarget r;
  std::vector<Eigen::Index> kept;
  for (size_t i = 0; i < t.index.size(); ++i)
    if (row_of_base[t.index[i]] >= 0) r.rows.push_back(row_of_base[t.index[i]]), kept.push_back(static_cast<Eigen::Index>(i));
  r.delta.resize(static_cast<Eigen::Index>(kept.size()), 3);
  for (size_t k = 0; k < kept.size(); ++k) r.delta.row(static_cast<Eigen::Index>(k)) = t.delta.row(kept[k]);
  return r;
}

void add(Eigen::MatrixXd& P, const ReducedTarget& t, double w) {
  if (w == 0.0) return;
  for (size_t k = 0; k < t.rows.size(); ++k) P.row(t.rows[k]) += w * t.delta.row(static_cast<Eigen::Index>(k));
}

double clamp_slider(double v, bool macro) { return std::clamp(v, macro ? 0.0 : -1.0, 1.0); }

/// A macro target's variants as factors of the four fitted sliders (the others fixed per subject),
/// so that a weight costs a few multiplications, not string comparisons (macro_target_weight's rule).
struct MacroFactors {
  double fixed = 1;                          ///< the product of the variants of sex, age and ethnic mix
  std::vector<std::pair<int, int>> sliders;  ///< (slider 0..3, -1 low / 0 middle / 1 high)
};

MacroFactors macro_factors(const std::vector<std::string>& variants, const BodySpec& fixed) {
  static const char* const kNames[4][3] = {{"minmuscle", "averagemuscle", "maxmuscle"},
                                           {"minweight", "averageweight", "maxweight"},
                                           {"minheight", "", "maxheight"},
                                           {"uncommonproportions", "", "idealproportions"}};
  MacroFactors f;
  std::vector<std::string> others;
  for (const std::string& v : variants) {
    bool slider = false;
    for (int s = 0; s < 4 && !slider; ++s)
      for (int k = 0; k < 3; ++k)
        if (*kNames[s][k] && v == kNames[s][k]) f.sliders.push_back({s, k - 1}), slider = true;
    if (!slider) others.push_back(v);
  }
  f.fixed = macro_target_weight(others, fixed);
  return f;
}

double macro_weight(const MacroFactors& f, const double* sliders) {
  double w = f.fixed;
  for (const auto& [s, k] : f.sliders) {
    if (w == 0) break;
    const double x = sliders[s], lo = std::max(0.0, 1 - 2 * x), hi = std::max(0.0, 2 * x - 1);
    w *= k < 0 ? lo : k > 0 ? hi : 1 - lo - hi;
  }
  return w;
}

}  // namespace

std::vector<std::string> default_fitted_modifiers() {
  std::vector<std::string> names;
  for (const char* m : {"neck-circ", "neck-height", "upperarm-circ", "upperarm-length", "lowerarm-length", "frontchest-dist", "bust-circ",
                        "underbust-circ", "waist-circ", "napetowaist-dist", "waisttohip-dist", "shoulder-dist", "hips-circ",
                        "upperleg-height", "thigh-circ", "lowerleg-height", "calf-circ"})
    names.push_back(std::string("measure/measure-") + m + "-decr|incr");
  names.push_back("buttocks/buttocks-volume-decr|incr");
  names.push_back("torso/torso-scale-horiz-decr|incr");  // without it, women's shoulders stay 10 mm too broad
  return names;
}

struct SurveyBodyFitter::Reduced {
  TemplateAnthropometry anthropometry;
  Eigen::MatrixXd base;
  std::vector<ReducedTarget> macro;
  std::vector<ReducedTarget> modifier;  ///< parallel to model.modifier_targets
};

SurveyBodyFitter::SurveyBodyFitter(std::shared_ptr<const MakeHumanModel> model, SurveyFitOptions options)
    : model_(std::move(model)), options_(std::move(options)) {
  for (const std::string& name : options_.modifiers) {
    const auto* mod = model_->find_modifier(name);
    if (!mod) throw InvalidInput("survey fit: unknown modifier '" + name + "' (see 'posekit body --list-modifiers')");
    if (!mod->two_sided) throw InvalidInput("survey fit: modifier '" + name + "' is one-sided; fitted modifiers are two-sided");
  }
  for (int male = 0; male < 2; ++male) {
    BodySpec spec;
    spec.gender = male;
    auto r = std::make_unique<Reduced>();
    r->anthropometry = make_template_anthropometry(*model_, spec);
    std::vector<int> row_of_base(static_cast<size_t>(model_->base_V.rows()), -1);
    for (size_t i = 0; i < r->anthropometry.vertices.size(); ++i) row_of_base[r->anthropometry.vertices[i]] = static_cast<int>(i);
    r->base = gather_measured_vertices(r->anthropometry, model_->base_V);
    for (const auto& mt : model_->macro_targets) r->macro.push_back(reduce(mt.target, row_of_base));
    for (const auto& t : model_->modifier_targets) r->modifier.push_back(reduce(t, row_of_base));
    reduced_[male] = std::move(r);
  }
}

SurveyBodyFitter::~SurveyBodyFitter() = default;

const TemplateAnthropometry& SurveyBodyFitter::anthropometry(bool male) const { return reduced_[male]->anthropometry; }

SurveyValues SurveyBodyFitter::measure(const BodySpec& spec) const {
  const Reduced& r = *reduced_[spec.gender > 0.5];
  Eigen::MatrixXd P = r.base;
  for (size_t t = 0; t < model_->macro_targets.size(); ++t)
    add(P, r.macro[t], macro_target_weight(model_->macro_targets[t].variants, spec));
  for (const auto& [name, value] : spec.modifiers) {
    const auto* mod = model_->find_modifier(name);
    if (!mod) throw InvalidInput("body spec: unknown modifier '" + name + "'");
    if (value < 0 && mod->negative >= 0) add(P, r.modifier[mod->negative], -value);
    if (value > 0 && mod->positive >= 0) add(P, r.modifier[mod->positive], value);
  }
  return measure_template_body(r.anthropometry, P);
}

BodySpec SurveyBodyFitter::prior_spec(const SurveySubject& subject) const {
  BodySpec spec;
  spec.gender = subject.male ? 1.0 : 0.0;
  spec.african = spec.asian = spec.caucasian = 1.0 / 3;
  if (subject.race == 1) spec.african = spec.asian = 0, spec.caucasian = 1;
  if (subject.race == 2) spec.caucasian = spec.asian = 0, spec.african = 1;
  if (subject.race == 4) spec.african = spec.caucasian = 0, spec.asian = 1;
  for (const std::string& m : options_.modifiers) spec.modifiers[m] = 0;
  return spec;
}

SurveyFit SurveyBodyFitter::fit(const SurveySubject& subject) const {
  const Reduced& r = *reduced_[subject.male];
  const BodySpec prior = prior_spec(subject);
  const int n_mod = static_cast<int>(options_.modifiers.size()), n = kMacroSliders + n_mod;
  std::vector<const MakeHumanModel::Modifier*> mods;
  for (const std::string& m : options_.modifiers) mods.push_back(model_->find_modifier(m));
  std::vector<MacroFactors> factors;
  for (const auto& mt : model_->macro_targets) factors.push_back(macro_factors(mt.variants, prior));
  auto measure_params = [&](const Eigen::VectorXd& p) {
    Eigen::MatrixXd P = r.base;
    for (size_t t = 0; t < factors.size(); ++t) add(P, r.macro[t], macro_weight(factors[t], p.data()));
    for (int m = 0; m < n_mod; ++m) {
      const double v = p[kMacroSliders + m];
      if (v < 0) add(P, r.modifier[mods[m]->negative], -v);
      if (v > 0) add(P, r.modifier[mods[m]->positive], v);
    }
    return measure_template_body(r.anthropometry, P);
  };
  Eigen::VectorXd p0 = Eigen::VectorXd::Zero(n);
  p0.head(kMacroSliders).setConstant(0.5);
  const int rows = kSurveyMeasureCount + n;
  auto residuals = [&](const Eigen::VectorXd& p, SurveyValues* measured) {
    const SurveyValues m = measure_params(p);
    if (measured) *measured = m;
    Eigen::VectorXd f(rows);
    for (int k = 0; k < kSurveyMeasureCount; ++k) f[k] = m[k] - subject.values[k];
    f.tail(n) = options_.prior_cost * (p - p0);
    return f;
  };

  Eigen::VectorXd p = p0;
  Eigen::VectorXd f = residuals(p, nullptr);
  double cost = f.squaredNorm(), lambda = 1e-3;
  int iteration = 0;
  for (; iteration < options_.max_iterations; ++iteration) {
    Eigen::MatrixXd J(rows, n);
    for (int j = 0; j < n; ++j) {
      const bool macro = j < kMacroSliders;
      const double h = p[j] + 1e-4 > 1.0 ? -1e-4 : 1e-4;  // stay inside the slider's range
      Eigen::VectorXd q = p;
      q[j] = clamp_slider(q[j] + h, macro);
      J.col(j) = (residuals(q, nullptr) - f) / (q[j] - p[j]);
    }
    const Eigen::MatrixXd JtJ = J.transpose() * J;
    const Eigen::VectorXd g = J.transpose() * f;
    bool improved = false;
    double step = 0;
    for (int tries = 0; tries < 8 && !improved; ++tries) {
      Eigen::MatrixXd A = JtJ;
      A.diagonal() += lambda * (JtJ.diagonal().array() + 1e-12).matrix();
      const Eigen::VectorXd delta = A.ldlt().solve(-g);
      Eigen::VectorXd q = p + delta;
      for (int j = 0; j < n; ++j) q[j] = clamp_slider(q[j], j < kMacroSliders);
      const Eigen::VectorXd fq = residuals(q, nullptr);
      if (fq.squaredNorm() < cost) {
        step = (q - p).cwiseAbs().maxCoeff();
        p = q, f = fq, cost = fq.squaredNorm(), lambda = std::max(1e-7, lambda / 3), improved = true;
      } else {
        lambda *= 4;
      }
    }
    if (!improved || step < 1e-5) break;
  }

  SurveyFit out;
  out.spec = prior;
  out.spec.muscle = p[0], out.spec.weight = p[1], out.spec.height = p[2], out.spec.proportions = p[3];
  for (int m = 0; m < n_mod; ++m) out.spec.modifiers[options_.modifiers[m]] = p[kMacroSliders + m];
  residuals(p, &out.measured);
  for (int k = 0; k < kSurveyMeasureCount; ++k) out.residual[k] = out.measured[k] - subject.values[k];
  out.iterations = iteration;
  return out;
}

std::vector<SurveyFit> fit_survey(const SurveyBodyFitter& fitter, const std::vector<SurveySubject>& subjects, int threads,
                                  const std::function<void(int, int)>& progress) {
  std::vector<SurveyFit> fits(subjects.size());
  std::atomic<int> done{0};
  std::mutex progress_mutex;
  parallel_for_each(static_cast<long>(subjects.size()), threads, [&](long i) {
    fits[static_cast<size_t>(i)] = fitter.fit(subjects[static_cast<size_t>(i)]);
    const int d = ++done;
    if (progress) {
      std::lock_guard<std::mutex> lock(progress_mutex);
      progress(d, static_cast<int>(subjects.size()));
    }
  });
  return fits;
}

namespace {

/// Each body's weight of every target (#specs x (#macro + #modifier targets)): macro targets by the
/// product rule, modifiers by their side.
Eigen::MatrixXd target_weights(const MakeHumanModel& model, const std::vector<BodySpec>& specs) {
  const int n_macro = static_cast<int>(model.macro_targets.size());
  Eigen::MatrixXd W = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(specs.size()), n_macro + model.modifier_targets.size());
  for (size_t i = 0; i < specs.size(); ++i) {
    const auto row = static_cast<Eigen::Index>(i);
    for (int t = 0; t < n_macro; ++t) W(row, t) = macro_target_weight(model.macro_targets[t].variants, specs[i]);
    for (const auto& [name, value] : specs[i].modifiers) {
      const auto* mod = model.find_modifier(name);
      if (!mod) throw InvalidInput("population shape space: unknown modifier '" + name + "'");
      if (value < 0 && mod->negative >= 0) W(row, n_macro + mod->negative) += -value;
      if (value > 0 && mod->positive >= 0) W(row, n_macro + mod->positive) += value;
    }
  }
  return W;
}

/// The population's mean skin (#body vertices x 3) and the targets whose weight varies, as columns
/// of x0 y0 z0 x1 ... (`D`, 3 #body vertices x #varying), with the bodies' centred weights of them;
/// the same of the 15 joint centres (means of the rig's helper vertex groups, linear in the targets).
struct TargetSpan {
  Eigen::MatrixXd mean, D, centred_weights, joint_mean, joint_D;
};

TargetSpan target_span(const MakeHumanModel& model, const Eigen::MatrixXd& W) {
  const int n_macro = static_cast<int>(model.macro_targets.size()), nv = model.num_body_vertices;
  auto target_of = [&](Eigen::Index t) -> const MorphTarget& {
    return t < n_macro ? model.macro_targets[t].target : model.modifier_targets[t - n_macro];
  };
  const Eigen::RowVectorXd mean_w = W.colwise().mean();
  std::vector<Eigen::Index> varying;
  for (Eigen::Index t = 0; t < W.cols(); ++t)
    if ((W.col(t).array() - mean_w[t]).abs().maxCoeff() > 0) varying.push_back(t);
  TargetSpan span;
  // Each base vertex's share in the joints whose helper group holds it.
  std::vector<std::vector<std::pair<int, double>>> in_joint(static_cast<size_t>(model.base_V.rows()));
  const auto roots = part_root_bones(model.rig);
  for (int j = 0; j < kNumJoints; ++j) {
    const auto& group = model.rig.head_vertices[static_cast<size_t>(roots[static_cast<size_t>(j + 1)])];
    for (int v : group) in_joint[static_cast<size_t>(v)].emplace_back(j, 1.0 / static_cast<double>(group.size()));
  }
  // Adds `w` times a target's (or the base mesh's) displacement of the joints to column `col` of J (3 #joints rows).
  auto add_joints = [&](Eigen::Ref<Eigen::VectorXd> J, const std::vector<int>& index, const auto& delta, double w) {
    for (size_t k = 0; k < index.size(); ++k)
      for (const auto& [j, share] : in_joint[static_cast<size_t>(index[k])])
        J.segment<3>(3 * j) += w * share * delta.row(static_cast<Eigen::Index>(k)).transpose();
  };
  span.mean = model.base_V.topRows(nv);
  Eigen::VectorXd joint_mean = Eigen::VectorXd::Zero(3 * kNumJoints);
  {
    std::vector<int> all(static_cast<size_t>(model.base_V.rows()));
    for (size_t v = 0; v < all.size(); ++v) all[v] = static_cast<int>(v);
    add_joints(joint_mean, all, model.base_V, 1.0);
  }
  for (Eigen::Index t = 0; t < W.cols(); ++t) {
    const MorphTarget& target = target_of(t);
    for (size_t k = 0; k < target.index.size(); ++k)
      if (target.index[k] < nv) span.mean.row(target.index[k]) += mean_w[t] * target.delta.row(static_cast<Eigen::Index>(k));
    add_joints(joint_mean, target.index, target.delta, mean_w[t]);
  }
  span.joint_mean = joint_mean.reshaped(3, kNumJoints).transpose();
  const auto m = static_cast<Eigen::Index>(varying.size());
  span.D = Eigen::MatrixXd::Zero(3 * nv, m);
  span.joint_D = Eigen::MatrixXd::Zero(3 * kNumJoints, m);
  span.centred_weights.resize(W.rows(), m);
  for (Eigen::Index c = 0; c < m; ++c) {
    const MorphTarget& target = target_of(varying[c]);
    for (size_t k = 0; k < target.index.size(); ++k)
      if (target.index[k] < nv)
        for (int d = 0; d < 3; ++d) span.D(3 * target.index[k] + d, c) = target.delta(static_cast<Eigen::Index>(k), d);
    add_joints(span.joint_D.col(c), target.index, target.delta, 1.0);
    span.centred_weights.col(c) = W.col(varying[c]).array() - mean_w[varying[c]];
  }
  return span;
}

/// The fewest components (columns of U, by falling variance lambda) that reconstruct every body (rows
/// of M, in an orthonormal basis) within options.max_rms over `vertices` vertices, at most
/// options.max_components; the report gets the curve up to there.
int choose_components(const Eigen::MatrixXd& M, const Eigen::MatrixXd& U, const Eigen::VectorXd& lambda, int vertices,
                      const PopulationSpaceOptions& options, PopulationSpaceReport* r) {
  const double total = std::max(lambda.sum(), 1e-300);
  const int k_max = static_cast<int>(std::min<Eigen::Index>({options.max_components, U.cols(), M.rows() - 1}));
  Eigen::MatrixXd residual = M;  // rows: each body's part not yet explained
  double share = 0;
  for (int k = 0; k < k_max; ++k) {
    residual -= (residual * U.col(k)) * U.col(k).transpose();
    share += lambda[k] / total;
    const Eigen::VectorXd rms = (residual.rowwise().squaredNorm() / vertices).cwiseSqrt();
    r->variance_kept.push_back(share);
    r->worst_rms.push_back(rms.maxCoeff());
    r->mean_rms.push_back(rms.mean());
    if (rms.maxCoeff() <= options.max_rms) return k + 1;
  }
  return k_max;
}

}  // namespace

ShapeSpace population_shape_space(const MakeHumanModel& model, const std::vector<BodySpec>& specs, std::string population,
                                  const PopulationSpaceOptions& options, PopulationSpaceReport* report) {
  if (specs.size() < 2) throw InvalidInput("population shape space: needs at least 2 bodies, got " + std::to_string(specs.size()));
  const TargetSpan span = target_span(model, target_weights(model, specs));
  const Eigen::Index m = span.D.cols();
  // Bodies minus the mean are Wc D^T = Wc R^T Q^T with Q orthonormal: the PCA of M = Wc R^T is the PCA of the bodies.
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(span.D);
  const Eigen::MatrixXd R = qr.matrixQR().topRows(m).triangularView<Eigen::Upper>();
  const Eigen::MatrixXd M = span.centred_weights * R.transpose();
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(M.transpose() * M / static_cast<double>(specs.size() - 1));
  const Eigen::VectorXd lambda = eig.eigenvalues().reverse().cwiseMax(0.0);
  const Eigen::MatrixXd U = eig.eigenvectors().rowwise().reverse();

  PopulationSpaceReport r;
  const int kept = choose_components(M, U, lambda, model.num_body_vertices, options, &r);
  r.components = kept;
  r.varying_targets = static_cast<int>(m);
  ShapeSpace space;
  space.mean = span.mean;
  const Eigen::MatrixXd Q = qr.householderQ() * Eigen::MatrixXd::Identity(span.D.rows(), m);
  space.basis = Q * (U.leftCols(kept) * lambda.head(kept).cwiseSqrt().asDiagonal());
  // The joints' basis: the least-squares map from the bodies' coefficients to their joints (exact with
  // every component kept; the coefficients are uncorrelated with unit variance, so it is a covariance).
  const Eigen::MatrixXd C = M * U.leftCols(kept) * lambda.head(kept).cwiseMax(1e-300).cwiseSqrt().cwiseInverse().asDiagonal();
  space.joint_mean = span.joint_mean;
  space.joint_basis = span.joint_D * (span.centred_weights.transpose() * C) / static_cast<double>(specs.size() - 1);
  const double total = std::max(lambda.sum(), 1e-300);
  for (int k = 0; k < kept; ++k) space.variance_share.push_back(lambda[k] / total);
  space.bodies = static_cast<int>(specs.size());
  space.population = std::move(population);
  space.faces = model.body_F;
  if (report) *report = std::move(r);
  return space;
}

}  // namespace posekit
