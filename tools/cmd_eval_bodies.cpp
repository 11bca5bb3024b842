// posekit eval bodies: body understanding on the robustness set, per variation.
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/data_root.h"
#include "posekit/evaluation/body_evaluation.h"
#include "posekit/fitting/body_model.h"
#include "posekit/io/atomic_file.h"

namespace posekit::cli {
namespace {

constexpr double kJointBar = 0.03, kAgreementBar = 0.95;  // the bars: 3 cm, 95% of the area
const char* kIsoGirths[] = {"bust", "waist", "hip"};

double median_of(std::vector<double> v) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return std::isnan(x); }), v.end());
  if (v.empty()) return std::nan("");
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

double mean_of(const std::vector<double>& v) {
  double sum = 0;
  for (double x : v) sum += x;
  return v.empty() ? std::nan("") : sum / static_cast<double>(v.size());
}

/// Counts over a group of bodies (a variation, or all).
struct Tally {
  int bodies = 0, meshes = 0, labelled = 0, frame_right = 0, measured = 0, segmented = 0, agree = 0, joints = 0, both = 0, silent = 0;
  int iso_within[3] = {0, 0, 0}, iso_measured[3] = {0, 0, 0};
  double abs_error_sum[3] = {0, 0, 0};  ///< m: ISO 20685-1's bar is on the mean absolute error
  /// angle: the mean joint-angle error of each body whose result was returned (a refused fit gives no
  /// pose; refusals count in `segmented` and the bars); angle_all: of every body.
  std::vector<double> joint_max, agreement, roughness, truth_roughness, angle, angle_all;
  /// |fitted minus rig| joint-to-joint lengths (m) of the segmented bodies, by kind of segment (both sides).
  std::map<std::string, std::vector<double>> segment_length_error;
  void add(const BodyResult& b) {
    ++bodies;
    // Bodies that get parts and joints: meshes, and scans too when the body model is fitted.
    const bool parted = b.kind == "mesh" || b.by_body_model;
    meshes += parted;
    labelled += !std::isnan(b.segmentation_agreement);
    if (!std::isnan(b.joint_angle_error_mean)) {
      angle_all.push_back(b.joint_angle_error_mean * 180 / M_PI);
      if (b.segmented) angle.push_back(angle_all.back());
    }
    frame_right += b.unit_right && b.orientation_right;
    measured += b.measured;
    segmented += b.segmented;
    agree += b.segmented && b.segmentation_agreement >= kAgreementBar;
    joints += b.segmented && b.joint_error_max <= kJointBar;
    both += b.segmented && (std::isnan(b.segmentation_agreement) || b.segmentation_agreement >= kAgreementBar) &&
            b.joint_error_max <= kJointBar;
    silent += !b.silent_nonsense.empty();
    if (parted) joint_max.push_back(b.joint_error_max), agreement.push_back(b.segmentation_agreement);
    if (b.segmented)
      for (const auto& [part, e] : b.segment_length_error)
        segment_length_error[part.substr(part.find('_') + 1)].push_back(std::abs(e));  // "left_forearm" -> "forearm"
    if (!std::isnan(b.border_roughness)) roughness.push_back(b.border_roughness);
    if (!std::isnan(b.truth_border_roughness)) truth_roughness.push_back(b.truth_border_roughness);
    for (int g = 0; g < 3; ++g) {
      auto it = b.girth_error.find(kIsoGirths[g]);
      if (it == b.girth_error.end()) continue;
      ++iso_measured[g];
      iso_within[g] += std::abs(it->second) <= iso_allowable_girth_error(kIsoGirths[g]);
      abs_error_sum[g] += std::abs(it->second);
    }
  }
  double mean_abs_error_mm(int g) const { return iso_measured[g] ? 1000 * abs_error_sum[g] / iso_measured[g] : std::nan(""); }
  nlohmann::ordered_json json() const {
    nlohmann::ordered_json iso;
    for (int g = 0; g < 3; ++g)
      iso[kIsoGirths[g]] = {{"measured", iso_measured[g]}, {"within_iso", iso_within[g]}, {"mean_abs_error_mm", mean_abs_error_mm(g)}};
    return {{"bodies", bodies},
            {"meshes", meshes},
            {"unit_and_orientation_right", frame_right},
            {"measured", measured},
            {"segmented", segmented},
            {"agreement_at_least_95", agree},
            {"joints_within_3cm", joints},
            {"agreement_and_joints", both},
            {"girths_iso_20685", iso},
            {"median_joint_error_max_mm", 1000 * median_of(joint_max)},
            {"median_agreement", median_of(agreement)},
            {"median_border_roughness", median_of(roughness)},
            {"median_truth_border_roughness", median_of(truth_roughness)},
            {"mean_joint_angle_error_deg", angle.empty() ? std::nan("") : mean_of(angle)},
            {"mean_joint_angle_error_deg_every_fit", angle_all.empty() ? std::nan("") : mean_of(angle_all)},
            {"median_segment_length_error_mm", segment_lengths_json()},
            {"silent_nonsense", silent}};
  }
  nlohmann::ordered_json segment_lengths_json() const {
    nlohmann::ordered_json j = nlohmann::ordered_json::object();
    for (const auto& [kind, e] : segment_length_error) j[kind] = 1000 * median_of(e);
    return j;
  }
};

std::string percent(int part, int whole) {
  if (whole == 0) return "-";
  std::ostringstream s;
  s << part << "/" << whole << " (" << std::fixed << std::setprecision(0) << 100.0 * part / whole << "%)";
  return s.str();
}

void print_row(const std::string& name, const Tally& t) {
  std::cout << "| " << name << " | " << t.bodies << " | " << percent(t.frame_right, t.bodies) << " | " << percent(t.measured, t.bodies)
            << " | " << percent(t.segmented, t.meshes) << " | " << percent(t.agree, t.labelled) << " | " << percent(t.joints, t.meshes)
            << " | " << percent(t.both, t.meshes) << " |";
  auto one_decimal = [](double v) {
    if (std::isnan(v)) return std::string("-");
    std::ostringstream s;
    s << std::fixed << std::setprecision(1) << v;
    return s.str();
  };
  for (int g = 0; g < 3; ++g)
    std::cout << " " << percent(t.iso_within[g], t.iso_measured[g])
              << (t.iso_measured[g] ? ", MAE " + one_decimal(t.mean_abs_error_mm(g)) : "") << " |";
  std::cout << " " << one_decimal(1000 * median_of(t.joint_max)) << " | " << one_decimal(100 * median_of(t.agreement)) << " | "
            << one_decimal(t.angle.empty() ? std::nan("") : mean_of(t.angle)) << " | " << t.silent << " |\n";
}

}  // namespace

int run_eval_bodies(int argc, char** argv) {
  ArgParser args("eval bodies",
                 "Body understanding on the robustness set (posekit dataset make --robustness): every body is read as\n"
                 "a user's file (unit and orientation detected), measured, segmented into 16 parts (Eq. 2) with its\n"
                 "skeleton embedded and checked, and compared with the rig's truth. Prints, per variation, how many\n"
                 "bodies got the right unit and orientation, were measured, were segmented (passing the sanity\n"
                 "checks), agree with the rig's labels on >= 95% of the area, have every joint within 3 cm, both, and have\n"
                 "bust, waist and hip girths within the ISO 20685-1 allowable errors (15, 12, 12 mm); then every\n"
                 "failure with its message, and every result returned as good that is far off (silent nonsense).");
  args.option("dataset", "DIR", "a robustness set folder")
      .pose_model_option("its segmentation prior labels the bodies (as posekit segment --model)")
      .body_model_option("fitted to every body, meshes and scans (as posekit segment --body-model)")
      .data_option("for --body-model")
      .option("variations", "LIST", "only these variations (comma-separated)")
      .output("report", "FILE", "also write the full results as JSON")
      .flag("json", "results as JSON on stdout")
      .example("posekit eval bodies --dataset robustness --model model.pkm")
      .example("posekit eval bodies --dataset robustness --variations scanner,thighs_touch");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("--dataset DIR is required");
  BodyEvaluationOptions o;
  o.model_path = args.get("model");
  std::unique_ptr<BodyModel> body_model;
  if (args.has("body-model")) {
    body_model = std::make_unique<BodyModel>(read_shape_space(args.get("body-model")),
                                             *load_makehuman_model(find_data_root(args.get("data")), MakeHumanParts::kSkin));
    o.body_model = body_model.get();
  }
  std::stringstream list(args.get("variations"));
  for (std::string item; std::getline(list, item, ',');)
    if (!item.empty()) o.only.push_back(item);
  std::unique_ptr<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress = std::make_unique<Progress>("eval bodies", total);
    progress->update(done);
  };
  const BodyEvaluation ev = evaluate_bodies(args.get("dataset"), o);
  if (progress) progress->finish();
  Tally all;
  std::vector<Tally> per(ev.variations.size());
  for (const auto& b : ev.bodies) {
    all.add(b);
    const size_t v = static_cast<size_t>(std::find(ev.variations.begin(), ev.variations.end(), b.variation) - ev.variations.begin());
    if (v < per.size()) per[v].add(b);
  }
  nlohmann::ordered_json out;
  out["dataset"] = args.get("dataset");
  out["model"] = o.model_path;
  out["seconds"] = ev.seconds;
  out["all"] = all.json();
  for (size_t v = 0; v < per.size(); ++v) out["variations"][ev.variations[v]] = per[v].json();
  nlohmann::ordered_json bodies = nlohmann::ordered_json::array();
  for (const auto& b : ev.bodies) {
    nlohmann::ordered_json j = {{"name", b.name},
                                {"variation", b.variation},
                                {"kind", b.kind},
                                {"unit_right", b.unit_right},
                                {"orientation_right", b.orientation_right},
                                {"orientation", b.orientation},
                                {"measured", b.measured},
                                {"segmented", b.segmented},
                                {"seconds", b.seconds}};
    if (b.by_body_model) j["fit_start"] = b.fit_start;
    if (!std::isnan(b.fit_seconds)) j["fit_seconds"] = b.fit_seconds;
    if (!std::isnan(b.joint_angle_error_mean)) j["joint_angle_error_mean_deg"] = b.joint_angle_error_mean * 180 / M_PI;
    for (const auto& [joint, e] : b.joint_angle_error) j["joint_angle_error_deg"][joint] = e * 180 / M_PI;
    if (!b.measure_error.empty()) j["measure_error"] = b.measure_error;
    if (!b.segment_error.empty()) j["segment_error"] = b.segment_error;
    if (!std::isnan(b.segmentation_agreement)) j["segmentation_agreement"] = b.segmentation_agreement;
    if (!std::isnan(b.border_roughness)) j["border_roughness"] = b.border_roughness;
    if (!std::isnan(b.truth_border_roughness)) j["truth_border_roughness"] = b.truth_border_roughness;
    if (!std::isnan(b.joint_error_max)) {
      j["joint_error_max_mm"] = 1000 * b.joint_error_max;
      j["joint_error_mean_mm"] = 1000 * b.joint_error_mean;
      j["worst_joint"] = b.worst_joint;
      for (const auto& [name, e] : b.joint_error) j["joint_error_mm"][name] = 1000 * e;
      if (b.by_body_model) j["guessed_joints"] = b.guessed_joints;
      for (const auto& [part, e] : b.segment_length_error) j["segment_length_error_mm"][part] = 1000 * e;
    }
    for (const auto& [name, e] : b.girth_error) j["girth_error_mm"][name] = 1000 * e;
    for (const auto& [name, note] : b.girth_not_measured) j["girth_not_measured"][name] = note;
    j["warnings"] = b.warnings;
    j["silent_nonsense"] = b.silent_nonsense;
    bodies.push_back(j);
  }
  out["bodies"] = bodies;
  if (args.has("report")) {
    const std::string text = out.dump(2) + "\n";
    write_file_atomically(
        args.get("report"), [&](std::ostream& os) { os << text; }, false);
  }
  if (args.flag_set("json")) {
    print_json(out);
    return 0;
  }
  std::cout << "robustness set " << args.get("dataset") << ": " << ev.bodies.size() << " bodies in " << std::fixed << std::setprecision(0)
            << ev.seconds << " s; segmentation "
            << (o.body_model           ? "by the body model " + args.get("body-model")
                : o.model_path.empty() ? "without a model"
                                       : "with " + o.model_path)
            << "\n\n| variation | bodies | unit+orientation | measured | segmented (checked) | agreement >= 95% | "
               "joints <= 3 cm | both | bust ISO, MAE mm | waist ISO, MAE mm | hip ISO, MAE mm | median worst joint mm | median agreement "
               "% | mean joint angle error deg (returned fits) | "
               "silent nonsense |\n"
               "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (size_t v = 0; v < per.size(); ++v) print_row(ev.variations[v], per[v]);
  print_row("**all**", all);
  std::cout << (o.body_model ? "\nsegmented (a confident fit), agreement (meshes) and joints count meshes and scans; both: agreement and\n"
                               "joints on the same body; joint angles where the truth has the pose (the pose kinds), over the results\n"
                               "returned (a refused fit gives no pose; it counts in segmented and both; --report has every fit's too);\n"
                             : "\nsegmented, agreement and joints count meshes (scans are measured only); both: agreement and joints\n"
                               "on the same body;")
            << (o.body_model ? "" : " ")
            << "a girth's ISO column counts the bodies where it was measured within ISO 20685-1's allowable error, and gives\n"
               "their mean absolute error (the standard's bar: 15 mm bust, 12 waist and hip).\n"
            << "part borders' roughness (edge length over the hull's perimeter, median of the joints' borders; 1 is a\n"
               "smooth ring): median "
            << std::setprecision(3) << median_of(all.roughness) << " ours, " << median_of(all.truth_roughness) << " the rig's labels\n";
  if (!all.segment_length_error.empty()) {
    std::cout << "limb segments, joint to joint, |ours - the rig's| median over the segmented bodies (mm):";
    for (const auto& [kind, e] : all.segment_length_error) std::cout << " " << kind << " " << std::setprecision(1) << 1000 * median_of(e);
    std::cout << "\n";
  }
  std::vector<double> fit_seconds;
  for (const auto& b : ev.bodies)
    if (!std::isnan(b.fit_seconds)) fit_seconds.push_back(b.fit_seconds);
  if (!fit_seconds.empty())
    std::cout << "the body model's fits: median " << std::setprecision(2) << median_of(fit_seconds) << " s, slowest "
              << *std::max_element(fit_seconds.begin(), fit_seconds.end()) << " s, "
              << std::count_if(fit_seconds.begin(), fit_seconds.end(), [](double s) { return s > 3; }) << " of " << fit_seconds.size()
              << " over 3 s\n";
  bool header = false;
  for (const auto& b : ev.bodies) {
    if (b.measured && (b.segmented || (b.kind == "scan" && !b.by_body_model)) && b.silent_nonsense.empty()) continue;
    if (!header) std::cout << "\nfailures:\n", header = true;
    if (!b.measure_error.empty()) std::cout << "  " << b.name << ": measure: " << b.measure_error << "\n";
    if (!b.segment_error.empty()) std::cout << "  " << b.name << ": segment: " << b.segment_error << "\n";
    for (const auto& s : b.silent_nonsense) std::cout << "  " << b.name << ": SILENT: " << s << "\n";
  }
  return 0;
}

}  // namespace posekit::cli
