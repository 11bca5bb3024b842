// posekit shape-space --ansur: posekit's body model population, MakeHuman bodies fitted to the real
// proportions of an ANSUR II-style survey, and its principal components.
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "commands.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/population/limb_segments.h"
#include "posekit/population/survey_fit.h"

namespace posekit::cli {
namespace {

struct ResidualStats {
  double bias = 0, mae = 0, p95 = 0, worst = 0;
  int count = 0;
};

ResidualStats residual_stats(const std::vector<SurveyFit>& fits, const std::vector<SurveySubject>& subjects, int measure, int sex) {
  std::vector<double> r;
  for (size_t i = 0; i < fits.size(); ++i)
    if (sex < 0 || subjects[i].male == (sex == 1)) r.push_back(fits[i].residual[measure]);
  ResidualStats s;
  s.count = static_cast<int>(r.size());
  if (r.empty()) return s;
  std::vector<double> a;
  for (double v : r) s.bias += v, s.mae += std::abs(v), a.push_back(std::abs(v));
  s.bias /= r.size(), s.mae /= r.size();
  std::sort(a.begin(), a.end());
  s.p95 = a[std::min(a.size() - 1, static_cast<size_t>(std::ceil(0.95 * a.size())) - 1)];
  s.worst = a.back();
  return s;
}

nlohmann::ordered_json stats_json(const ResidualStats& s) {
  return {
      {"subjects", s.count}, {"bias_mm", 1000 * s.bias}, {"mae_mm", 1000 * s.mae}, {"p95_mm", 1000 * s.p95}, {"max_mm", 1000 * s.worst}};
}

/// The residuals per measure and sex, and the components' curve.
nlohmann::ordered_json fit_summary(const std::string& survey_path, const std::vector<SurveySubject>& subjects,
                                   const std::vector<SurveyFit>& fits, const PopulationSpaceReport& report) {
  int men = 0;
  for (const auto& s : subjects) men += s.male;
  nlohmann::ordered_json summary;
  summary["survey"] = survey_path;
  summary["subjects"] = subjects.size();
  summary["men"] = men;
  summary["women"] = static_cast<int>(subjects.size()) - men;
  for (int m = 0; m < kSurveyMeasureCount; ++m) {
    auto& j = summary["residuals"][survey_measure_name(static_cast<SurveyMeasure>(m))];
    j["column"] = survey_column(static_cast<SurveyMeasure>(m));
    j["men"] = stats_json(residual_stats(fits, subjects, m, 1));
    j["women"] = stats_json(residual_stats(fits, subjects, m, 0));
  }
  summary["varying_targets"] = report.varying_targets;
  summary["components"] = report.components;
  summary["variance_kept"] = report.variance_kept.empty() ? 0.0 : report.variance_kept.back();
  summary["worst_rms_mm"] = report.worst_rms.empty() ? 0.0 : 1000 * report.worst_rms.back();
  summary["mean_rms_mm"] = report.mean_rms.empty() ? 0.0 : 1000 * report.mean_rms.back();
  for (size_t k = 0; k < report.variance_kept.size(); ++k)
    summary["components_curve"].push_back({{"components", k + 1},
                                           {"variance_kept", report.variance_kept[k]},
                                           {"worst_rms_mm", 1000 * report.worst_rms[k]},
                                           {"mean_rms_mm", 1000 * report.mean_rms[k]}});
  return summary;
}

void print_residual_table(const nlohmann::ordered_json& summary) {
  std::cout << "Fit residuals (fitted body minus survey, mm): bias / mean absolute / 95th percentile\n\n"
            << "| measure | men | women |\n| --- | --- | --- |\n"
            << std::fixed << std::setprecision(1);
  for (const auto& [name, stats] : summary["residuals"].items()) {
    std::cout << "| " << name;
    for (const char* sex : {"men", "women"})
      std::cout << " | " << stats[sex]["bias_mm"].get<double>() << " / " << stats[sex]["mae_mm"].get<double>() << " / "
                << stats[sex]["p95_mm"].get<double>();
    std::cout << " |\n";
  }
  std::cout << "\nComponents: " << summary["components"].get<int>() << " keep " << std::setprecision(4)
            << 100 * summary["variance_kept"].get<double>() << "% of the variance; every body within " << std::setprecision(2)
            << summary["worst_rms_mm"].get<double>() << " mm RMS (mean " << summary["mean_rms_mm"].get<double>() << " mm)\n";
  std::cout << "Limb segment components (each segment's spread at the same 12 measurements and sex, mm):";
  for (const auto& [name, sd] : summary["limb_segment_spread_mm"].items())
    std::cout << " " << name << " " << (sd.is_null() ? std::string("not measured") : std::to_string(sd.get<double>()).substr(0, 4));
  std::cout << "\n";
  std::cout.unsetf(std::ios::fixed);
}

}  // namespace

ShapeSpace survey_shape_space(const std::string& survey_arg, const std::string& data_arg, long subjects_wanted, double max_rms_mm,
                              int max_components, int threads, const std::string& residuals_path, bool quiet,
                              const std::vector<std::string>& leave_out_ids) {
  const std::string data_root = find_data_root(data_arg);
  const std::string survey_path = find_ansur_root(survey_arg, data_root);
  std::vector<SurveySubject> all = read_survey(survey_path);
  for (const std::string& id : leave_out_ids) {  // held out, e.g. the bodies a test photographs
    const auto it = std::find_if(all.begin(), all.end(), [&](const SurveySubject& s) { return s.id == id; });
    if (it == all.end()) throw InvalidInput("--leave-out-ids: subject '" + id + "' is not in " + survey_path);
    all.erase(it);
  }
  std::vector<SurveySubject> subjects;
  const size_t wanted = subjects_wanted > 0 ? std::min<size_t>(subjects_wanted, all.size()) : all.size();
  for (size_t k = 0; k < wanted; ++k) subjects.push_back(all[k * all.size() / wanted]);  // evenly through the file(s)
  int men = 0;
  for (const auto& s : subjects) men += s.male;
  std::cerr << "posekit shape-space: " << subjects.size() << " subjects of " << survey_path << " (" << men << " men, "
            << subjects.size() - men << " women)\n";

  auto model = load_makehuman_model(data_root);
  const SurveyBodyFitter fitter(model);
  std::unique_ptr<Progress> progress;
  const std::vector<SurveyFit> fits = fit_survey(fitter, subjects, threads, [&](int done, int total) {
    if (!progress) progress = std::make_unique<Progress>("fitting MakeHuman sliders to the subjects", total);
    progress->update(done);
  });
  if (progress) progress->finish();

  std::vector<BodySpec> specs;
  for (const auto& f : fits) specs.push_back(f.spec);
  PopulationSpaceOptions po;
  po.max_rms = max_rms_mm / 1000.0;
  po.max_components = max_components;
  PopulationSpaceReport report;
  const std::string population = "MakeHuman bodies fitted to " + std::to_string(subjects.size()) + " subjects of " +
                                 std::filesystem::path(survey_path).filename().string() + " (" + std::to_string(men) + " men, " +
                                 std::to_string(subjects.size() - men) + " women; 12 measurements)";
  ShapeSpace space = population_shape_space(*model, specs, population, po, &report);
  // How the limbs divide: from every subject of the survey (the split leaves the fitted 12 alone).
  const std::array<double, kLimbSegmentCount> spread = limb_segment_spread(all);
  add_limb_segment_components(*model, spread, &space);

  nlohmann::ordered_json summary = fit_summary(survey_path, subjects, fits, report);
  for (int k = 0; k < kLimbSegmentCount; ++k)
    summary["limb_segment_spread_mm"][limb_segment_name(static_cast<LimbSegment>(k))] =
        std::isfinite(spread[k]) ? nlohmann::json(std::round(1e4 * spread[k]) / 10.0) : nlohmann::json(nullptr);
  if (!residuals_path.empty()) {
    nlohmann::ordered_json out = summary;
    for (size_t i = 0; i < fits.size(); ++i) {
      nlohmann::ordered_json s;
      s["id"] = subjects[i].id;
      s["male"] = subjects[i].male;
      std::vector<double> r;
      for (double v : fits[i].residual) r.push_back(std::round(1e4 * v) / 10.0);
      s["residual_mm"] = r;
      s["spec"] = nlohmann::json::parse(body_spec_to_json(fits[i].spec));
      out["fits"].push_back(s);
    }
    write_file_atomically(residuals_path, [&](std::ostream& o) { o << out.dump(1) << "\n"; });
  }
  if (!quiet) print_residual_table(summary);
  return space;
}

}  // namespace posekit::cli
