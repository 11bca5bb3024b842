#pragma once
// How unusual a body's measurements are among real adults: the joint distribution of an ANSUR
// II-style survey's measurements, per sex, and where a body's measurements fall in it.
#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "posekit/population/ansur.h"
#include "posekit/shape/measurements.h"

namespace posekit {

/// Mean and covariance of the survey's measurements (m), per sex (0 women, 1 men), and each
/// subject's values for the survey's own distances.
struct SurveyDistribution {
  std::array<Eigen::VectorXd, 2> mean;
  std::array<Eigen::MatrixXd, 2> covariance;
  std::array<std::vector<SurveyValues>, 2> subjects;
  std::string source;  ///< what it was learned from
};

/// Throws InvalidInput when either sex has fewer subjects than measures plus one.
SurveyDistribution survey_distribution(const std::vector<SurveySubject>& subjects, std::string source);

using SurveyMask = std::array<bool, kSurveyMeasureCount>;  ///< which measures a body has

struct Plausibility {
  bool male = false;    ///< the sex among whose subjects the body is the less unusual
  int measures = 0;     ///< how many measures were judged
  double distance = 0;  ///< Mahalanobis distance from that sex's mean, over the measures given
  /// Share of the survey's subjects of that sex whose own distance (same measures) is larger: 0 means
  /// the body is more unusual than every one of them.
  double more_unusual_share = 0;
  /// The measure least expected given the others: its standard score conditional on the others
  /// (from the precision matrix), and the value the others predict for it (m).
  SurveyMeasure most_unusual = SurveyMeasure::kStature;
  double most_unusual_z = 0, expected_given_others = 0;
};

/// Judges measurements (m) against the distribution, over the measures `given` marks. Throws
/// InvalidInput for fewer than 2 measures or a value that is not finite and positive.
Plausibility judge_plausibility(const SurveyDistribution& distribution, const SurveyValues& values, const SurveyMask& given);

/// The measures of measure_body / measure_point_cloud defined as the survey's: stature (when measured),
/// chest (the bust girth), buttock (the hip girth), thigh, calf and neck, when measured. Not the waist
/// (posekit's is the narrowest level, ANSUR II's at the navel) nor the upper arm (relaxed; ANSUR II's
/// biceps is flexed). Returns which measures `values` (m) holds.
SurveyMask survey_values_of(const BodyMeasurements& measurements, SurveyValues* values);

}  // namespace posekit
