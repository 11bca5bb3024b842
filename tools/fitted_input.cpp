#include "fitted_input.h"

#include <algorithm>
#include <cmath>
#include <iostream>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/subjects.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/population/ansur.h"
#include "posekit/population/survey_fit.h"
#include "posekit/registration/shape_space.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::cli {

/// The survey's distribution, or why there is none: measuring must not depend on ANSUR II being there.
std::unique_ptr<SurveyDistribution> load_survey(const std::string& survey_arg, std::string* why_not) {
  try {
    std::string makehuman_root;
    try {
      makehuman_root = find_data_root("");
    } catch (const IoError&) {
    }
    const std::string path = find_ansur_root(survey_arg, makehuman_root);
    return std::make_unique<SurveyDistribution>(survey_distribution(read_survey(path), path));
  } catch (const Error& e) {
    if (!survey_arg.empty()) throw;  // the user named it: a bad survey is an error
    *why_not = e.what();
    return nullptr;
  }
}

std::vector<BodySpec> survey_population_specs(const ArgParser& args, const std::string& option, int count, unsigned seed,
                                              const std::vector<std::string>& leave_out_ids, std::string* note) {
  const std::string population = args.get(option);
  if (population == "makehuman") return {};
  if (population != "ansur" && population != "both")
    throw UsageError("--" + option + " is makehuman, ansur or both, not '" + population + "'");
  const std::string data_root = find_data_root(args.has("data") ? args.get("data") : "");
  const std::string survey_path = find_ansur_root(args.has("survey") ? args.get("survey") : "", data_root);
  std::vector<SurveySubject> survey = read_survey(survey_path);
  for (const std::string& id : leave_out_ids) {
    const auto it = std::find_if(survey.begin(), survey.end(), [&](const SurveySubject& s) { return s.id == id; });
    if (it == survey.end()) throw InvalidInput("--leave-out-ids: subject '" + id + "' is not in " + survey_path);
    survey.erase(it);
  }
  const SurveyBodyFitter fitter(load_makehuman_model(data_root));
  std::vector<BodySpec> specs;
  for (SurveyFit& fit : fit_survey(fitter, sample_survey(survey, count, seed))) specs.push_back(std::move(fit.spec));
  if (note)
    *note = "MakeHuman fitted to " + std::to_string(specs.size()) + " subjects of " + survey_path + " (seed " + std::to_string(seed) +
            (leave_out_ids.empty() ? "" : ", " + std::to_string(leave_out_ids.size()) + " left out") + ")";
  if (population == "both") {
    for (BodySpec& random : make_calibration_specs(seed, count)) specs.push_back(std::move(random));
    if (note) *note += " and " + std::to_string(count) + " random MakeHuman bodies";
  }
  return specs;
}

void add_body_model_options(ArgParser* args, bool data_option) {
  args->body_model_option("fitted to the body, its parts, joints and pose read off the fit")
      .flag("accept-poor", "with --body-model: give the result of a poor fit too (marked poor; exit status 0)");
  if (data_option) args->data_option("for --body-model");
  if (!args->declares("threads"))
    args->option("threads", "N", "with --body-model: threads of the fit (0: all cores; the same fit on any number)", "0");
}

int body_fit_threads(const ArgParser& args) {
  const long threads = args.get_int("threads");
  if (threads < 0 || threads > 4096) throw UsageError("--threads is 0 (all cores) or a number of threads, not " + std::to_string(threads));
  return static_cast<int>(threads);
}

std::unique_ptr<BodyModel> load_body_model(const ArgParser& args) {
  const auto makehuman = load_makehuman_model(find_data_root(args.get("data")), MakeHumanParts::kSkin);
  return std::make_unique<BodyModel>(read_shape_space(args.get("body-model")), *makehuman);
}

BodyFit fit_body_model_to_input(const BodyModel& model, const BodyInput& input, const std::string& path, const ArgParser& args,
                                const BodyFitOptions& options) {
  // An up axis given (--up) is the only one tried; auto: every axis direction.
  BodyFitOptions o = options;
  o.threads = body_fit_threads(args);
  if (const std::string& up = args.get("up"); !up.empty() && up != "auto" && o.up_candidates.empty()) o.up_candidates = {parse_axis(up)};
  const BodyFit fit =
      input.is_cloud ? fit_body_model(model, input.cloud.P, o) : fit_body_model_to_mesh(model, input.mesh.V, input.mesh.F, o);
  for (const auto& w : fit.warnings) std::cerr << "warning: " << path << ": " << w << "\n";
  if (fit.confident) return fit;
  std::string why;
  for (const auto& r : fit.reasons) why += (why.empty() ? "" : "; ") + r;
  if (!args.flag_set("accept-poor"))
    throw BelowConfidence(path + ": the body model's fit is poor (" + why +
                          "); nothing written (--accept-poor gives it anyway, marked as poor)");
  std::cerr << "warning: " << path << ": the body model's fit is poor (" << why << "); given as asked, marked poor\n";
  return fit;
}

void segment_subject_by_body_model(const BodyModel& model, const TriangleMesh& subject, const std::string& path, const ArgParser& args,
                                   Eigen::VectorXi* triangle_part, Eigen::MatrixXd* joint_centres) {
  BodyInput input;
  input.mesh = subject;
  const BodyFit fit = fit_body_model_to_input(model, input, path, args);
  *triangle_part = triangle_part_labels(subject.F, parts_of_every_vertex(model, fit, subject.V));
  *joint_centres = fit.joints;
  std::cerr << "posekit: " << path << ": parts and joints from the body model's fit (" << fit.start << ", "
            << static_cast<int>(std::lround(100 * fit.coverage)) << "% coverage)\n";
}

}  // namespace posekit::cli
