#pragma once
// posekit's body model population: MakeHuman bodies whose sliders are fitted to real people's
// measurements (an ANSUR II-style survey), and the principal components of those bodies.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "posekit/body/body_spec.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/population/ansur.h"
#include "posekit/population/template_anthropometry.h"
#include "posekit/registration/shape_space.h"

namespace posekit {

/// The local modifiers fitted besides the macro sliders muscle, weight, height and proportions:
/// MakeHuman's measure-* modifiers, the buttocks' volume and the torso's width.
std::vector<std::string> default_fitted_modifiers();

struct SurveyFitOptions {
  std::vector<std::string> modifiers = default_fitted_modifiers();
  /// Each unit a slider moves from its prior (0.5 for a macro slider, 0 for a modifier) costs as much
  /// as this much measurement error (m): it decides what the 12 measurements leave open.
  double prior_cost = 0.005;
  int max_iterations = 40;
};

struct SurveyFit {
  BodySpec spec;            ///< gender and ethnic mix from the subject, the rest fitted
  SurveyValues measured{};  ///< the fitted body's measurements (m)
  SurveyValues residual{};  ///< measured minus the survey's (m)
  int iterations = 0;
};

/// Fits MakeHuman sliders to survey subjects by Levenberg-Marquardt on the 12 measurements with a
/// Gaussian prior on the sliders, the sliders kept in range. Bodies are evaluated on only the
/// vertices the measurements read (TemplateAnthropometry of a man's and of a woman's template), so a
/// fit takes milliseconds. Thread-safe after construction.
class SurveyBodyFitter {
 public:
  /// Throws InvalidInput for an unknown modifier or a template that cannot be measured.
  SurveyBodyFitter(std::shared_ptr<const MakeHumanModel> model, SurveyFitOptions options = {});
  ~SurveyBodyFitter();

  SurveyFit fit(const SurveySubject& subject) const;
  /// The measurements of the body `spec` makes, as measure_template_body takes them on the full body
  /// (the template of the spec's sex: gender over 0.5 is a man's).
  SurveyValues measure(const BodySpec& spec) const;
  /// The spec a fit starts from: the subject's sex, the ethnic mix of their DODRace (white:
  /// caucasian, black: african, asian: asian, others an equal mix), every other slider at its prior.
  BodySpec prior_spec(const SurveySubject& subject) const;
  const TemplateAnthropometry& anthropometry(bool male) const;
  const SurveyFitOptions& options() const { return options_; }

 private:
  struct Reduced;
  std::shared_ptr<const MakeHumanModel> model_;
  SurveyFitOptions options_;
  std::unique_ptr<Reduced> reduced_[2];  ///< woman's, man's
};

/// Fits every subject on `threads` threads (0: the hardware's); `progress(done, total)` when given.
/// The same result on any thread count.
std::vector<SurveyFit> fit_survey(const SurveyBodyFitter& fitter, const std::vector<SurveySubject>& subjects, int threads = 0,
                                  const std::function<void(int, int)>& progress = nullptr);

struct PopulationSpaceOptions {
  /// Keep the fewest components that reconstruct every body of the population within this RMS
  /// vertex distance (m)...
  double max_rms = 0.001;
  int max_components = 100;  ///< ... but no more than these
};

struct PopulationSpaceReport {
  /// For k = 1..K computed: the share of variance the first k keep, and the worst and mean body's
  /// RMS reconstruction error (m).
  std::vector<double> variance_kept, worst_rms, mean_rms;
  int components = 0;       ///< kept
  int varying_targets = 0;  ///< morph targets whose weight varies over the population (the span's dimension)
};

/// Principal components of the skin of the bodies `specs` make (#body vertices of the template
/// topology, faces recorded). Exact and fast: a body is the base mesh plus targets times their
/// weights, so the population's covariance is that of the weights mapped through an orthonormal basis
/// of the targets' span (QR). Throws InvalidInput for fewer than 2 specs.
ShapeSpace population_shape_space(const MakeHumanModel& model, const std::vector<BodySpec>& specs, std::string population,
                                  const PopulationSpaceOptions& options = {}, PopulationSpaceReport* report = nullptr);

}  // namespace posekit
