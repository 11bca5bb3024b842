// posekit measure <mesh|cloud>: stature and tape girths of a standing body, with the features used.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <future>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/fitting/fitted_measurements.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/population/survey_plausibility.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/measurements.h"

namespace posekit::cli {
namespace {

nlohmann::json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

/// A point of the results in the frame asked for.
nlohmann::json point_in(const BodyOrientation& frame, const Eigen::Vector3d& p) { return vec(in_file_frame(frame, p)); }

nlohmann::json plausibility_json(const Plausibility* p, const SurveyDistribution* survey, const std::string& no_survey) {
  if (!p) return {{"checked", false}, {"why", survey ? "fewer than 2 measures match the survey's" : no_survey}};
  return {{"survey", survey->source},
          {"as", p->male ? "man" : "woman"},
          {"measures", p->measures},
          {"distance", p->distance},
          {"more_unusual_share", p->more_unusual_share},
          {"least_expected", survey_measure_name(p->most_unusual)},
          {"z", p->most_unusual_z},
          {"expected_given_others", p->expected_given_others}};
}

/// A warning when the measurements are rarer than 1 in 1,000 of the survey's adults.
std::string plausibility_warning(const Plausibility& p) {
  if (p.more_unusual_share >= 0.001) return "";
  std::ostringstream o;
  o << std::fixed << std::setprecision(2) << "these proportions are rarer than 1 in 1,000 adults of the survey ("
    << (p.male ? "as a man" : "as a woman") << ": Mahalanobis distance " << p.distance << " over " << p.measures
    << " measures); the least expected is the " << survey_measure_name(p.most_unusual) << ", the others predict "
    << 100 * p.expected_given_others << " cm (z = " << std::setprecision(1) << p.most_unusual_z
    << "): check that measurement, or the body is outside the survey's adults";
  return o.str();
}

/// A torso girth the rule-based measurement puts this far (m) from the body model's: one is wrong.
constexpr double kCrossCheckDisagreement = 0.02;

/// The paper's rule-based pipeline on the body stood upright by `to_fit_frame` (the body model
/// fit's), for the cross-check below. It measures standing bodies only, and says why when it cannot.
struct RuleMeasurement {
  bool ran = false;
  std::string why;
  Eigen::Index thinned_to = 0;  ///< the points it measured when a dense scan was thinned; 0 otherwise
  BodyMeasurements m;
};

RuleMeasurement rule_measurement(const BodyInput& in, const Eigen::Matrix3d& to_fit_frame) {
  RuleMeasurement out;
  const Eigen::MatrixXd& T = in.is_cloud ? in.cloud.P : in.mesh.V;
  // A dense scan is thinned for it to 200,000 points (the rules cost a second per million).
  constexpr Eigen::Index kCrossCheckPoints = 200000;
  const Eigen::Index stride = in.is_cloud ? (T.rows() + kCrossCheckPoints - 1) / kCrossCheckPoints : 1;
  Eigen::MatrixXd upright(stride > 1 ? (T.rows() + stride - 1) / stride : T.rows(), 3);
  for (Eigen::Index i = 0; i < upright.rows(); ++i) upright.row(i) = T.row(i * stride) * to_fit_frame.transpose();
  if (stride > 1) out.thinned_to = upright.rows();
  try {
    out.m = in.is_cloud ? measure_point_cloud(upright) : measure_body(upright, in.mesh.F);
    out.ran = true;
  } catch (const InvalidInput& e) {
    out.why = e.what();
  }
  return out;
}

/// The rule-based measurement as a cross-check of the body model's torso girths `m`: a girth over
/// kCrossCheckDisagreement apart is a warning.
nlohmann::ordered_json rule_based_cross_check(const RuleMeasurement& rule, const BodyMeasurements& m, std::vector<std::string>* warnings) {
  nlohmann::ordered_json cross = {{"method", "rule-based (posekit measure without --body-model)"}};
  if (rule.thinned_to > 0) cross["thinned_to_points"] = rule.thinned_to;
  cross["ran"] = rule.ran;
  if (!rule.ran) {
    cross["why"] = rule.why;
    return cross;
  }
  for (const char* name : {"bust", "underbust", "waist", "hip"}) {
    const Girth *ours = m.find(name), *theirs = rule.m.find(name);
    if (!ours || !theirs || !ours->measured || !theirs->measured) continue;
    cross["girths"][name] = theirs->value;
    if (std::abs(theirs->value - ours->value) <= kCrossCheckDisagreement) continue;
    std::ostringstream w;
    w << std::fixed << std::setprecision(1) << "the rule-based measurement gives a " << name << " of " << 100 * theirs->value << " cm, "
      << 100 * (theirs->value - ours->value) << " cm from the body model's " << 100 * ours->value
      << " cm: one of the two is wrong there (look at the landmarks in --json)";
    warnings->push_back(w.str());
  }
  return cross;
}

/// measure --body-model: the body model fitted to the body; landmark levels from the fitted body,
/// girths on the body's own surface with the arms and the other leg left out by the fit's labels.
/// --contours FILE: each measured girth's tape path (a closed polyline) for other tools to draw over
/// the body: OBJ (one object per girth, `l` closing on its first corner) or JSON, by the extension;
/// `to_output` takes posekit's metres to the output's frame, `unit` the output's unit.
void write_contours(const std::string& path, const BodyMeasurements& m,
                    const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& to_output, Unit unit) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  if (ext != ".obj" && ext != ".json") throw UsageError("--contours " + path + ": expected a .obj or .json file");
  const double scale = 1.0 / metres_per_unit(unit);
  int written = 0;
  for (const Girth& g : m.girths) written += g.measured && g.tape.rows() >= 3;
  if (written == 0) throw InvalidInput("--contours: no girth was measured, so there is no tape line to write");
  write_file_atomically(path, [&](std::ostream& out) {
    if (ext == ".json") {
      nlohmann::ordered_json j = {{"unit", unit_name(unit)}, {"girths", nlohmann::ordered_json::object()}};
      for (const Girth& g : m.girths) {
        if (!g.measured || g.tape.rows() < 3) continue;
        nlohmann::ordered_json points = nlohmann::ordered_json::array();
        for (Eigen::Index k = 0; k < g.tape.rows(); ++k) {
          const Eigen::Vector3d p = scale * to_output(g.tape.row(k).transpose());
          points.push_back({p.x(), p.y(), p.z()});
        }
        j["girths"][g.name] = {{"value_m", g.value}, {"closed", true}, {"points", points}};
      }
      out << j.dump(1) << "\n";
      return;
    }
    out << "# posekit measure: each girth's tape path, a closed polyline, in " << unit_name(unit) << "\n";
    int next = 1;
    for (const Girth& g : m.girths) {
      if (!g.measured || g.tape.rows() < 3) continue;
      out << "o " << g.name << "\n# " << g.name << " " << 100 * g.value << " cm\n";
      for (Eigen::Index k = 0; k < g.tape.rows(); ++k) {
        const Eigen::Vector3d p = scale * to_output(g.tape.row(k).transpose());
        out << "v " << p.x() << " " << p.y() << " " << p.z() << "\n";
      }
      out << "l";
      for (Eigen::Index k = 0; k < g.tape.rows(); ++k) out << " " << next + k;
      out << " " << next << "\n";
      next += static_cast<int>(g.tape.rows());
    }
  });
}

int measure_by_body_model(const ArgParser& args, const SurveyDistribution* survey, const std::string& no_survey) {
  const std::string path = args.positionals()[0];
  if (args.get("frame") != "input")
    throw UsageError("--frame " + args.get("frame") + ": with --body-model the points are given in the file's frame (--frame input)");
  using Clock = std::chrono::steady_clock;
  auto since = [](Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); };
  const Clock::time_point t0 = Clock::now();
  BodyUnit unit;
  // The body model loads while the body is read (load_seconds: the wait after the read).
  std::future<std::unique_ptr<BodyModel>> loading = std::async(std::launch::async, [&] { return load_body_model(args); });
  const BodyInput in = read_body_input(path, args.get("unit"), "measure", &unit);
  const double read_seconds = since(t0);
  const std::unique_ptr<BodyModel> model = loading.get();
  const double load_seconds = since(t0) - read_seconds;
  // The rule cross-check runs beside the fit from the moment the fit has stood the body upright
  // (again after the fit when the fit was redone in another frame).
  const bool cross_check = !args.flag_set("no-cross-check");
  std::future<RuleMeasurement> early_rule;
  Eigen::Matrix3d early_frame = Eigen::Matrix3d::Identity();
  BodyFitOptions options;
  if (cross_check)
    options.frame_chosen = [&](const Eigen::Matrix3d& to_fit_frame) {
      if (early_rule.valid()) return;
      early_frame = to_fit_frame;
      early_rule = std::async(std::launch::async, [&in, to_fit_frame] { return rule_measurement(in, to_fit_frame); });
    };
  const BodyFit fit = fit_body_model_to_input(*model, in, path, args, options);
  const Eigen::MatrixXd& T = in.is_cloud ? in.cloud.P : in.mesh.V;
  const Eigen::MatrixXi no_faces;
  const Clock::time_point t_measure = Clock::now();
  const FittedMeasurements fm = measure_by_body_fit(*model, fit, T, in.is_cloud ? no_faces : in.mesh.F);
  const double measure_seconds = since(t_measure);
  const Clock::time_point t_cross = Clock::now();
  const BodyMeasurements& m = fm.target;
  std::vector<std::string> warnings;
  if (args.has("contours"))  // the fit works in the file's frame, in metres
    write_contours(
        args.get("contours"), m, [](const Eigen::Vector3d& p) { return p; }, unit.unit);

  nlohmann::ordered_json cross = {{"ran", false}, {"why", "--no-cross-check"}};
  if (cross_check) {
    const bool early = early_rule.valid();
    RuleMeasurement rule = early ? early_rule.get() : RuleMeasurement{};
    if (!early || !fit.to_fit_frame.isApprox(early_frame)) rule = rule_measurement(in, fit.to_fit_frame);
    cross = rule_based_cross_check(rule, m, &warnings);
  }
  const double cross_seconds = since(t_cross);
  SurveyValues survey_values;
  const SurveyMask given = survey_values_of(m, &survey_values);
  std::unique_ptr<Plausibility> plausibility;
  if (survey && std::count(given.begin(), given.end(), true) >= 2)
    plausibility = std::make_unique<Plausibility>(judge_plausibility(*survey, survey_values, given));
  if (plausibility && !plausibility_warning(*plausibility).empty()) warnings.push_back(plausibility_warning(*plausibility));

  if (args.flag_set("json")) {
    nlohmann::ordered_json j;
    j["file"] = path;
    j["kind"] = in.is_cloud ? "point cloud" : "mesh";
    j["method"] = "body model";
    j["body_model"] = args.get("body-model");
    j["units"] = "m";
    j["file_unit"] = {{"unit", unit_name(unit.unit)}, {"detected", unit.detected}, {"largest_extent", unit.extent}};
    j["frame"] = "input";
    j["fit"] = {{"confident", fit.confident}, {"reasons", fit.reasons},
                {"start", fit.start},         {"up", vec(fit.up)},
                {"coverage", fit.coverage},   {"target_p95_mm", 1000 * fit.target_p95},
                {"seconds", fit.seconds},     {"guessed_joints", joint_names_where(fit.joint_guessed)}};
    for (const auto& [stage, seconds] : fit.stage_seconds) j["fit"]["stage_seconds"][stage] = seconds;
    j["stature"] = m.stature;
    j["stature_note"] = m.stature_note;
    for (size_t k = 0; k < m.girths.size(); ++k) {
      const Girth& g = m.girths[k];
      nlohmann::ordered_json e = {{"measured", g.measured}, {"point", vec(g.point)}, {"normal", vec(g.normal)}};
      if (g.measured) e["value"] = g.value;
      if (std::isfinite(fm.as_posed[k])) e["as_posed"] = fm.as_posed[k];  // also where the girth standing is not given
      if (!g.note.empty()) e["note"] = g.note;
      if (const Girth* f = fm.fitted.find(g.name); f && f->measured) e["fitted_body"] = f->value;
      j["girths"][g.name] = e;
    }
    for (const auto& l : fm.landmarks) j["landmarks"][l.name] = vec(l.point);
    j["cross_check"] = cross;
    j["plausibility"] = plausibility_json(plausibility.get(), survey, no_survey);
    j["warnings"] = warnings;
    j["seconds"] = {{"read", read_seconds},       {"load_body_model", load_seconds}, {"fit", fit.seconds},
                    {"measure", measure_seconds}, {"cross_check", cross_seconds},    {"total", since(t0)}};
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::cout << path << " (" << (in.is_cloud ? "point cloud" : "mesh") << "), by the body model " << args.get("body-model")
            << (fit.confident ? "" : " (POOR FIT)") << "\n"
            << std::fixed << std::setprecision(1) << "  stature      " << m.stature * 100 << " cm (" << m.stature_note << ")\n";
  std::cout << "  girths standing (as posed on the surface; the fitted body's)\n";
  for (size_t k = 0; k < m.girths.size(); ++k) {
    const Girth& g = m.girths[k];
    std::cout << "  " << std::left << std::setw(12) << g.name << std::right << " ";
    if (g.measured) std::cout << g.value * 100 << " cm (" << 100 * fm.as_posed[k] << ")";
    else {
      std::cout << "not measured: " << g.note;
      if (std::isfinite(fm.as_posed[k])) std::cout << " (as posed " << 100 * fm.as_posed[k] << " cm)";
    }
    if (const Girth* f = fm.fitted.find(g.name); f && f->measured) std::cout << " (" << 100 * f->value << ")";
    if (g.measured && !g.note.empty()) std::cout << ": " << g.note;
    std::cout << "\n";
  }
  if (plausibility)
    std::cout << "  proportions  " << std::setprecision(1) << 100 * plausibility->more_unusual_share << "% of the survey's "
              << (plausibility->male ? "men" : "women") << " are more unusual (" << plausibility->measures << " measures)\n";
  for (const auto& w : warnings) std::cout << "  warning: " << w << "\n";
  return 0;
}

}  // namespace

int run_measure(int argc, char** argv) {
  ArgParser args("measure",
                 "Measures a standing body (A-pose, in any axis convention) from its geometry alone: stature and the\n"
                 "girths bust, underbust, waist, hip, thigh, knee, calf, ankle, upper arm, wrist, neck (convex-hull\n"
                 "perimeters, definitions in the README), and the features they hang on. Works on meshes of any\n"
                 "topology and on scans (point clouds): a girth whose scan section has a hole is reported, not guessed.\n"
                 "With --body-model, the body model is fitted first (any pose, any axes, arms touching the torso):\n"
                 "the landmark levels come from the fitted body, and the girths are taken on the file's own surface\n"
                 "with the arms and the other leg left out by the fit's part labels, and given standing: a standing\n"
                 "body in its own stance with the arms at rest, a kneeling, sitting or bending one at rest (the pose's\n"
                 "change to the fitted body's section is taken off; --json gives the girth as posed too). A poor fit\n"
                 "exits with status 3.");
  args.positional("file", "body mesh (OBJ/PLY/OFF/STL) or scan (PCD/PLY/XYZ)")
      .option("unit", "U", "unit of the file: m, dm, cm, mm, or auto (its largest extent tells)", "auto")
      .flag("json", "machine-readable results on stdout (metres)")
      .option("frame", "F",
              "frame of the points in the results: input (the file's axes) or posekit (Y up, facing +Z; levels_y are always heights in it)",
              "input")
      .option("survey", "DIR|FILE",
              "judge the proportions against this survey (ANSUR II's folder or a CSV in its columns; "
              "default: $POSEKIT_ANSUR, else ansur2 beside the data root, skipped when absent)")
      .flag("no-cross-check", "with --body-model: skip the rule-based measurement it is compared with")
      .output("contours", "FILE", "write each girth's tape path (a closed polyline) as OBJ lines or JSON, in the file's axes and unit")
      .example("posekit measure subjects/f01/rest.ply")
      .example("posekit measure scans/f01/rest.pcd --json")
      .example("posekit measure registration_x_up.ply --up +X --forward -Z")
      .example("posekit measure scan_arms_close.ply --body-model ansur.pks")
      .example("posekit measure subjects/f01/rest.ply --contours f01_tapes.obj");
  add_body_model_options(&args);
  add_orientation_options(&args);
  if (!args.parse(argc, argv)) return 0;
  if (args.has("body-model")) {
    std::string no_survey;
    const std::unique_ptr<SurveyDistribution> survey = load_survey(args.has("survey") ? args.get("survey") : "", &no_survey);
    return measure_by_body_model(args, survey.get(), no_survey);
  }
  const std::string path = args.positionals()[0];
  BodyUnit unit;
  BodyInput in = read_body_input(path, args.get("unit"), "measure", &unit);
  const std::string frame = args.get("frame");
  if (frame != "input" && frame != "posekit") throw UsageError("--frame expects input or posekit, got '" + frame + "'");
  const BodyOrientation orientation = orient_body_input(&in, args.get("up"), args.get("forward"), path, "measure");
  const BodyOrientation shown = frame == "input" ? orientation : BodyOrientation{};
  const bool cloud = in.is_cloud;
  std::string no_survey;  // read before measuring: a survey the user named and that is not there fails at once
  const std::unique_ptr<SurveyDistribution> survey = load_survey(args.has("survey") ? args.get("survey") : "", &no_survey);
  const BodyMeasurements m = cloud ? measure_point_cloud(in.cloud.P) : measure_body(in.mesh.V, in.mesh.F);
  const BodyFeatures& f = m.features;
  SurveyValues survey_values;
  const SurveyMask given = survey_values_of(m, &survey_values);
  const int given_count = static_cast<int>(std::count(given.begin(), given.end(), true));
  std::unique_ptr<Plausibility> plausibility;
  if (survey && given_count >= 2) plausibility = std::make_unique<Plausibility>(judge_plausibility(*survey, survey_values, given));
  std::vector<std::string> warnings = f.warnings;
  if (plausibility && !plausibility_warning(*plausibility).empty()) warnings.push_back(plausibility_warning(*plausibility));
  if (args.has("contours"))  // as the other points: the file's axes and unit (--frame input) or posekit's frame in metres
    write_contours(
        args.get("contours"), m, [&](const Eigen::Vector3d& p) { return Eigen::Vector3d(in_file_frame(shown, p)); },
        frame == "input" ? unit.unit : Unit::kMetre);
  if (args.flag_set("json")) {
    nlohmann::ordered_json j;
    j["file"] = path;
    j["kind"] = cloud ? "point cloud" : "mesh";
    j["units"] = "m";
    j["file_unit"] = {{"unit", unit_name(unit.unit)}, {"detected", unit.detected}, {"largest_extent", unit.extent}};
    j["orientation"] = orientation_json(orientation);
    j["frame"] = frame;
    j["stature"] = m.stature;
    if (!m.stature_measured) j["stature_note"] = m.stature_note + " (not measured)";
    for (const auto& g : m.girths) {
      nlohmann::ordered_json e = {{"measured", g.measured}, {"point", point_in(shown, g.point)}, {"normal", point_in(shown, g.normal)}};
      if (g.measured) e["value"] = g.value;
      else e["note"] = g.note;
      j["girths"][g.name] = e;
    }
    j["levels_y"] = {{"crotch", f.crotch_y},       {"hip", f.hip_y},     {"waist", f.waist_y},
                     {"underbust", f.underbust_y}, {"bust", f.bust_y},   {"arms_separate", f.arms_separate_y},
                     {"neck", f.neck_y},           {"floor", f.floor_y}, {"top", f.top_y}};
    j["features"] = {{"crotch", point_in(shown, f.crotch)},
                     {"neck_base", point_in(shown, f.neck_base)},
                     {"neck_joint", point_in(shown, f.neck_joint)},
                     {"head_joint", point_in(shown, f.head_joint)},
                     {"left_armpit", point_in(shown, f.armpit[kLeft])},
                     {"right_armpit", point_in(shown, f.armpit[kRight])},
                     {"left_shoulder", point_in(shown, f.shoulder[kLeft])},
                     {"right_shoulder", point_in(shown, f.shoulder[kRight])},
                     {"left_elbow", point_in(shown, f.elbow[kLeft])},
                     {"right_elbow", point_in(shown, f.elbow[kRight])},
                     {"left_wrist", point_in(shown, f.wrist[kLeft])},
                     {"right_wrist", point_in(shown, f.wrist[kRight])},
                     {"left_hip_joint", point_in(shown, f.hip[kLeft])},
                     {"right_hip_joint", point_in(shown, f.hip[kRight])},
                     {"left_knee", point_in(shown, f.knee[kLeft])},
                     {"right_knee", point_in(shown, f.knee[kRight])},
                     {"left_ankle", point_in(shown, f.ankle[kLeft])},
                     {"right_ankle", point_in(shown, f.ankle[kRight])}};
    j["plausibility"] = plausibility_json(plausibility.get(), survey.get(), no_survey);
    j["warnings"] = warnings;
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::cout << path << " (" << (cloud ? "point cloud" : "mesh") << ")\n"
            << std::fixed << std::setprecision(1) << "  stature      " << m.stature * 100 << " cm"
            << (m.stature_measured ? "" : " (not measured: " + m.stature_note + ")") << "\n";
  for (const auto& g : m.girths) {
    std::cout << "  " << std::left << std::setw(12) << g.name << std::right << " ";
    if (g.measured) std::cout << g.value * 100 << " cm\n";
    else std::cout << "not measured: " << g.note << "\n";
  }
  if (plausibility)
    std::cout << "  proportions  " << std::setprecision(1) << 100 * plausibility->more_unusual_share << "% of the survey's "
              << (plausibility->male ? "men" : "women") << " are more unusual (" << plausibility->measures << " measures)\n";
  for (const auto& w : warnings) std::cout << "  warning: " << w << "\n";
  return 0;
}

}  // namespace posekit::cli
