#include "posekit/population/survey_plausibility.h"

#include <Eigen/Cholesky>
#include <cmath>

#include "posekit/core/error.h"

namespace posekit {

SurveyDistribution survey_distribution(const std::vector<SurveySubject>& subjects, std::string source) {
  SurveyDistribution d;
  d.source = std::move(source);
  for (const auto& s : subjects) d.subjects[s.male].push_back(s.values);
  for (int sex = 0; sex < 2; ++sex) {
    const auto& values = d.subjects[sex];
    if (static_cast<int>(values.size()) <= kSurveyMeasureCount)
      throw InvalidInput("survey distribution: " + std::to_string(values.size()) + (sex ? " men" : " women") + " in " + d.source +
                         ", too few for the covariance of " + std::to_string(kSurveyMeasureCount) + " measures");
    Eigen::MatrixXd X(values.size(), kSurveyMeasureCount);
    for (size_t i = 0; i < values.size(); ++i)
      for (int m = 0; m < kSurveyMeasureCount; ++m) X(static_cast<Eigen::Index>(i), m) = values[i][m];
    d.mean[sex] = X.colwise().mean().transpose();
    const Eigen::MatrixXd centred = X.rowwise() - d.mean[sex].transpose();
    d.covariance[sex] = centred.transpose() * centred / static_cast<double>(values.size() - 1);
  }
  return d;
}

Plausibility judge_plausibility(const SurveyDistribution& distribution, const SurveyValues& values, const SurveyMask& given) {
  std::vector<int> idx;
  for (int m = 0; m < kSurveyMeasureCount; ++m)
    if (given[m]) {
      if (!std::isfinite(values[m]) || values[m] <= 0)
        throw InvalidInput(std::string("plausibility: ") + survey_measure_name(static_cast<SurveyMeasure>(m)) + " is " +
                           std::to_string(values[m]) + ", expected a positive length (m)");
      idx.push_back(m);
    }
  const int k = static_cast<int>(idx.size());
  if (k < 2) throw InvalidInput("plausibility: needs at least 2 measures, got " + std::to_string(k));
  Plausibility best;
  bool first = true;
  for (int sex = 0; sex < 2; ++sex) {
    Eigen::VectorXd mu(k), x(k);
    Eigen::MatrixXd S(k, k);
    for (int i = 0; i < k; ++i) {
      mu[i] = distribution.mean[sex][idx[i]], x[i] = values[idx[i]];
      for (int j = 0; j < k; ++j) S(i, j) = distribution.covariance[sex](idx[i], idx[j]);
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(S);
    const Eigen::MatrixXd P = ldlt.solve(Eigen::MatrixXd::Identity(k, k));
    auto distance_of = [&](const Eigen::VectorXd& v) { return std::sqrt(std::max(0.0, (v - mu).dot(P * (v - mu)))); };
    Plausibility p;
    p.male = sex == 1;
    p.measures = k;
    p.distance = distance_of(x);
    if (!first && p.distance >= best.distance) continue;
    int larger = 0;
    Eigen::VectorXd v(k);
    for (const SurveyValues& s : distribution.subjects[sex]) {
      for (int i = 0; i < k; ++i) v[i] = s[idx[i]];
      larger += distance_of(v) > p.distance;
    }
    p.more_unusual_share = static_cast<double>(larger) / static_cast<double>(distribution.subjects[sex].size());
    const Eigen::VectorXd Pr = P * (x - mu);
    for (int i = 0; i < k; ++i) {
      const double z = Pr[i] / std::sqrt(P(i, i));
      if (i == 0 || std::abs(z) > std::abs(p.most_unusual_z)) {
        p.most_unusual = static_cast<SurveyMeasure>(idx[i]);
        p.most_unusual_z = z;
        p.expected_given_others = x[i] - Pr[i] / P(i, i);
      }
    }
    best = p;
    first = false;
  }
  return best;
}

SurveyMask survey_values_of(const BodyMeasurements& measurements, SurveyValues* values) {
  SurveyMask given{};
  values->fill(0);
  if (measurements.stature_measured) {
    given[static_cast<int>(SurveyMeasure::kStature)] = true;
    (*values)[static_cast<int>(SurveyMeasure::kStature)] = measurements.stature;
  }
  const std::pair<const char*, SurveyMeasure> girths[] = {{"bust", SurveyMeasure::kChestCircumference},
                                                          {"hip", SurveyMeasure::kButtockCircumference},
                                                          {"thigh", SurveyMeasure::kThighCircumference},
                                                          {"calf", SurveyMeasure::kCalfCircumference},
                                                          {"neck", SurveyMeasure::kNeckCircumference}};
  for (const auto& [name, measure] : girths) {
    const Girth* g = measurements.find(name);
    if (g && g->measured) given[static_cast<int>(measure)] = true, (*values)[static_cast<int>(measure)] = g->value;
  }
  return given;
}

}  // namespace posekit
