#pragma once
// --body-model in the commands: the body model fitted to a body file as the user gave it.
#include <memory>
#include <string>
#include <vector>

#include "cli.h"
#include "posekit/body/body_spec.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/population/survey_plausibility.h"

namespace posekit::cli {

/// The options every --body-model command takes: --body-model FILE, --accept-poor, --threads N
/// (unless the command has its own, which the fit then follows too), and unless the command has it
/// already (`data_option` false), --data DIR.
void add_body_model_options(ArgParser* args, bool data_option = true);

/// The survey's distribution (ANSUR II as find_ansur_root finds it, or `survey_arg`), or null with
/// why there is none in `why_not`: measuring must not depend on ANSUR II being there. A survey the
/// user named that cannot be read is an error.
std::unique_ptr<SurveyDistribution> load_survey(const std::string& survey_arg, std::string* why_not);

/// The bodies of a population as option `option` of `args` names it: "makehuman" gives none (the
/// caller's random MakeHuman bodies), "ansur" `count` MakeHuman bodies fitted to subjects drawn with
/// `seed` from the survey (--survey, else ANSUR II beside --data's root), "both" those and `count`
/// random ones. Subjects in `leave_out_ids` are never drawn (an unknown one is an error). `note`
/// (may be null) says what the bodies are.
std::vector<BodySpec> survey_population_specs(const ArgParser& args, const std::string& option, int count, unsigned seed,
                                              const std::vector<std::string>& leave_out_ids = {}, std::string* note = nullptr);

/// --threads of a --body-model command (0: all cores); UsageError when negative.
int body_fit_threads(const ArgParser& args);

/// The body model of --body-model (its MakeHuman data from --data).
std::unique_ptr<BodyModel> load_body_model(const ArgParser& args);

/// The body model fitted to `input` read from `path` (a mesh or a scan, any frame) on --threads. The fit's
/// warnings go to stderr; a poor fit throws BelowConfidence with its reasons unless --accept-poor,
/// when it is announced on stderr and returned (fit.confident false).
BodyFit fit_body_model_to_input(const BodyModel& model, const BodyInput& input, const std::string& path, const ArgParser& args,
                                const BodyFitOptions& options = {});

/// A subject's segmentation (#F) and joint centres read off the body model fitted to it (its own
/// frame), for SubjectSetupOptions: posing then needs no rule about its sections (arms close, a
/// natural stance). A poor fit as fit_body_model_to_input.
void segment_subject_by_body_model(const BodyModel& model, const TriangleMesh& subject, const std::string& path, const ArgParser& args,
                                   Eigen::VectorXi* triangle_part, Eigen::MatrixXd* joint_centres);

}  // namespace posekit::cli
