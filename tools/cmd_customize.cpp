// posekit customize: a body from a front and a side photo (section 3.2); customize train: the
// population model; customize eval: the dataset's subjects against ground truth.
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "fitted_input.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"
#include "posekit/core/timer.h"
#include "posekit/customization/model_silhouette_fit.h"
#include "posekit/customization/phone_set.h"
#include "posekit/customization/photo_evaluation.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/population/ansur.h"
#include "posekit/shape/measurements.h"

namespace posekit::cli {
namespace {

/// --method: "paper" (section 3.2, the learned model) or "model" (the body model fitted to the
/// silhouettes, which needs --body-model).
bool body_model_method(const ArgParser& args) {
  const std::string m = args.get("method");
  if (m != "paper" && m != "model") throw UsageError("--method expects paper or model");
  if (m == "model" && !args.has("body-model"))
    throw UsageError("--method model needs --body-model FILE (build one with posekit shape-space --ansur --out FILE)");
  return m == "model";
}

int customize_train(int argc, char** argv) {
  ArgParser args("customize train",
                 "Learns the photo customization model from a MakeHuman population (thousands of bodies across\n"
                 "all sliders and local modifiers, a seed the dataset's subjects do not use): each body rendered\n"
                 "to front and side silhouettes with the dataset's camera model, its 2-D features found, its\n"
                 "joints and levels regressed on them, and per layer of the representation a linear model and an\n"
                 "MLP (OpenCV ANN_MLP) predicting the section from the photos' widths and depths; the better on\n"
                 "the validation bodies (every fifth) is kept. Writes a .pkc model file.");
  args.output("out", "FILE", "model file to write", "customization.pkc")
      .option("bodies", "N", "population size", "2000")
      .option("seed", "S", "population seed", "20261124")
      .option("threads", "N", "threads", "2")
      .option("max-turn", "DEG", "each body turned about the vertical by up to this angle before rendering", "0")
      .option("cameras", "KIND",
              "dataset (level at mid-height, 2.6-3.4 m, the dataset's photos) or phone (held 1.0-1.5 m high, 2.2-2.5 m away, "
              "aimed at the body's middle)",
              "dataset")
      .option("population", "KIND",
              "makehuman (random sliders and local modifiers), ansur (MakeHuman fitted to surveyed adults drawn at random: real "
              "proportions) or both (--bodies of each)",
              "makehuman")
      .option("survey", "DIR|FILE", "--population ansur: ANSUR II's folder or a survey CSV (default: ansur2 beside the data root)")
      .option("leave-out-ids", "A,B", "--population ansur: never draw these SubjectIds (e.g. the bodies customize robustness photographs)")
      .option("leave-out", "WHAT", "none, obese (BMI 30 and over) or men (gender over 0.5): bodies outside the population", "none")
      .flag("linear-only", "train the linear models only (no MLPs)")
      .data_option()
      .example("posekit customize train --out customization.pkc");
  if (!args.parse(argc, argv)) return 0;
  CustomizationTrainingOptions o;
  o.data_root = find_data_root(args.get("data"));
  o.bodies = static_cast<int>(args.get_int("bodies"));
  o.seed = static_cast<unsigned>(args.get_int("seed"));
  o.threads = static_cast<int>(args.get_int("threads"));
  o.mlp = !args.flag_set("linear-only");
  o.max_turn_degrees = args.get_double("max-turn");
  if (!(o.max_turn_degrees >= 0 && o.max_turn_degrees <= 20)) throw UsageError("--max-turn: 0 to 20 degrees");
  const std::string cameras = args.get("cameras");
  if (cameras == "phone") o.cameras = CustomizationTrainingOptions::Cameras::kPhone;
  else if (cameras != "dataset") throw UsageError("--cameras expects dataset or phone");
  std::vector<std::string> leave_out_ids;
  if (args.has("leave-out-ids")) leave_out_ids = split_commas(args.get("leave-out-ids"));
  if (!leave_out_ids.empty() && args.get("population") == "makehuman")
    throw UsageError("--leave-out-ids draws from a survey: it needs --population ansur or both");
  o.specs = survey_population_specs(args, "population", o.bodies, o.seed, leave_out_ids, &o.specs_note);
  const std::string leave = args.get("leave-out");
  if (leave == "obese") {
    o.keep = [](int, double bmi, double) { return bmi < 30.0; };
    o.population_note = "BMI 30 and over left out";
  } else if (leave == "men") {
    o.keep = [](int, double, double gender) { return gender <= 0.5; };
    o.population_note = "men (gender over 0.5) left out";
  } else if (leave != "none") {
    throw UsageError("--leave-out expects none, obese or men");
  }
  std::optional<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress.emplace("customize train", total);
    progress->update(done);
  };
  const CustomizationModel m = train_customization_model(o);
  if (progress) progress->finish();
  save_customization_model(args.get("out"), m);
  int mlps = 0;
  double lin = 0, best = 0;
  for (const auto& L : m.layers) {
    mlps += L.use_mlp;
    lin += L.linear_error_mm;
    best += L.use_mlp ? L.mlp_error_mm : L.linear_error_mm;
  }
  std::cout << std::fixed << std::setprecision(2) << "population: " << m.population << "\n"
            << "joint and level regression: " << m.feature_error_mm << " mm mean joint error (validation)\n"
            << "sections: mean point error " << lin / m.layers.size() << " mm linear, " << best / m.layers.size()
            << " mm with the better model per layer (MLP kept on " << mlps << " of " << m.layers.size() << " layers)\n"
            << "trained in " << std::setprecision(1) << m.training_seconds << " s; wrote " << args.get("out") << " ("
            << std::filesystem::file_size(args.get("out")) / 1024 << " KiB)\n";
  return 0;
}

void print_evaluation(const PhotoEvaluation& ev, std::ostream& os) {
  os << (ev.label.empty() ? "variation " + std::string(photo_variation_name(ev.variation)) : ev.label) << "\n";
  os << "subject  stature  bust   waist  hip    surface  time    IoU  (errors in mm, customized - truth; IoU of the silhouettes)\n";
  for (const auto& r : ev.subjects) {
    os << std::left << std::setw(8) << r.id << std::right;
    if (!r.ok) {
      os << " FAILED: " << r.error << "\n";
      continue;
    }
    auto girth = [&](double v) {
      std::ostringstream t;
      t << std::fixed << std::setprecision(1) << std::setw(7);
      if (r.girths_measured) t << v;
      else t << "n/a";
      return t.str();
    };
    os << std::fixed << std::setprecision(1) << std::setw(7) << r.stature_mm << girth(r.bust_mm) << girth(r.waist_mm) << girth(r.hip_mm)
       << std::setw(8) << r.surface_mm << std::setw(7) << std::setprecision(2) << r.seconds << "s" << std::setw(7) << std::setprecision(3)
       << r.silhouette_iou
       << (!r.error.empty()     ? "  " + r.error
           : r.warnings.empty() ? ""
                                : "  warning: " + r.warnings.front())
       << "\n";
  }
  os << std::fixed << std::setprecision(1) << "mean |error|: stature " << ev.mean_abs_stature_mm << ", bust " << ev.mean_abs_bust_mm
     << ", waist " << ev.mean_abs_waist_mm << ", hip " << ev.mean_abs_hip_mm << " mm; surface " << ev.mean_surface_mm << " mm; worst girth "
     << ev.worst_girth_mm << " mm; bust, waist and hip within 2 cm on " << ev.within_2cm << "/" << ev.subjects.size()
     << (ev.girths_not_measured ? "; girths not measured on " + std::to_string(ev.girths_not_measured) : "")
     << (ev.failed ? "; " + std::to_string(ev.failed) + " failed" : "") << "\n\n";
}

nlohmann::json evaluation_json(const PhotoEvaluation& ev) {
  nlohmann::json j;
  j["variation"] = ev.label.empty() ? std::string(photo_variation_name(ev.variation)) : ev.label;
  j["units"] = "mm, customized - truth";
  for (const auto& r : ev.subjects)
    j["subjects"].push_back({{"id", r.id},
                             {"ok", r.ok},
                             {"error", r.error},
                             {"girths_measured", r.girths_measured},
                             {"stature", r.stature_mm},
                             {"bust", r.bust_mm},
                             {"waist", r.waist_mm},
                             {"hip", r.hip_mm},
                             {"surface", r.surface_mm},
                             {"seconds", r.seconds},
                             {"silhouette_iou", r.silhouette_iou},
                             {"photo_agreement", r.photo_agreement},
                             {"warnings", r.warnings}});
  j["mean_abs"] = {{"stature", ev.mean_abs_stature_mm},
                   {"bust", ev.mean_abs_bust_mm},
                   {"waist", ev.mean_abs_waist_mm},
                   {"hip", ev.mean_abs_hip_mm},
                   {"surface", ev.mean_surface_mm}};
  j["worst_girth"] = ev.worst_girth_mm;
  j["within_2cm"] = ev.within_2cm;
  j["failed"] = ev.failed;
  j["girths_not_measured"] = ev.girths_not_measured;
  return j;
}

int customize_eval(int argc, char** argv) {
  ArgParser args("customize eval",
                 "Customizes every subject of a dataset from its front and side photos and compares with the\n"
                 "ground truth: stature, bust, waist and hip errors (the result measured as any mesh), and the\n"
                 "mean distance of the subject's mesh to the result. Variations degrade the input the way real\n"
                 "photos do (masks eroded/dilated, stated height off by 1 cm, camera distance off by 20 cm, the\n"
                 "body turned 5 degrees, JPEG and sensor noise).");
  args.option("dataset", "DIR", "dataset folder (posekit dataset make)")
      .customization_model_option()
      .option("variation", "V",
              "photos, masks, erode2, dilate2, height+1cm, nearer20cm, farther20cm, turned5, jpeg-noise, camera1.30, camera1.30-aimed, "
              "camera1.00, room, phone, phone-masks, or all",
              "photos")
      .option("subjects", "A,B", "only these subjects")
      .option("method", "NAME", "paper (section 3.2's rules and learned sections) or model (the body model fitted to the silhouettes)",
              "paper")
      .body_model_option("for --method model")
      .data_option()
      .output("json", "FILE", "write the tables as JSON")
      .output_folder("inputs-out", "DIR", "write each subject's silhouettes and camera file as customized (DIR/VARIATION/ID/)")
      .example("posekit customize eval --dataset ds --model customization.pkc --variation all");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("dataset")) throw UsageError("customize eval needs --dataset DIR");
  const bool by_body_model = body_model_method(args);
  const std::unique_ptr<BodyModel> body_model = by_body_model ? load_body_model(args) : nullptr;
  const CustomizationModel model = by_body_model ? CustomizationModel{} : load_customization_model(args.get("model"));
  std::vector<PhotoVariation> variations;
  if (args.get("variation") == "all") variations = all_photo_variations();
  else variations.push_back(parse_photo_variation(args.get("variation")));
  const std::vector<std::string> ids = args.has("subjects") ? split_commas(args.get("subjects")) : std::vector<std::string>{};
  nlohmann::json all = nlohmann::json::array();
  for (PhotoVariation v : variations) {
    const PhotoEvaluation ev = evaluate_photo_customization(args.get("dataset"), model, v, ids,
                                                            args.has("inputs-out") ? args.get("inputs-out") : "", body_model.get());
    print_evaluation(ev, std::cout);
    std::cout.flush();
    all.push_back(evaluation_json(ev));
  }
  if (args.has("json")) {
    const std::string text = all.dump(2) + "\n";
    write_file_atomically(
        args.get("json"), [&](std::ostream& os) { os << text; }, false);
  }
  return 0;
}

int customize_robustness(int argc, char** argv) {
  ArgParser args("customize robustness",
                 "The robustness set of phone photos (issue 46, part 7), for both methods on the same photos:\n"
                 "bodies of ANSUR II proportions (MakeHuman fitted to surveyed adults drawn at random, and the\n"
                 "survey's extremes: the heaviest woman and man by BMI, the tallest man, the shortest woman),\n"
                 "optionally a dataset's subjects; each photographed at 3000 x 4000 from 2.2-2.5 m, the camera\n"
                 "1.0-1.5 m high aimed at the body's middle, f 2800-3200 px, by a renderer apart from the\n"
                 "dataset's (4 x 4 supersampled coverage, two lights, skin of four tones, a floor and a lit wall).\n"
                 "Conditions: masks (the true silhouettes), room (photos), phone (+ blur 0.6 px, noise 2, JPEG\n"
                 "70), turned (+ a turn of up to 5 degrees). Errors against each body's own mesh.");
  args.customization_model_option("the paper's method")
      .body_model_option("for --method model")
      .option("methods", "LIST", "paper, model or paper,model", "paper,model")
      .option("bodies", "N", "surveyed adults drawn at random", "12")
      .flag("no-extremes", "leave the survey's four extremes out")
      .option("dataset", "DIR", "also this dataset's subjects (older MakeHuman bodies)")
      .option("survey", "DIR|FILE", "ANSUR II's folder or a survey CSV (default: $POSEKIT_ANSUR, else ansur2 beside the data root)")
      .option("conditions", "LIST", "masks, room, phone, turned, comma-separated, or all", "all")
      .option("seed", "S", "the draw of bodies, cameras and turns", "46")
      .data_option()
      .output("json", "FILE", "write the tables as JSON")
      .output_folder("inputs-out", "DIR", "write each body's photos (or masks) and camera file (DIR/CONDITION/ID/)")
      .example("posekit customize robustness --model customization.pkc --body-model ansur.pks --json phone_set.json");
  if (!args.parse(argc, argv)) return 0;
  const std::vector<std::string> method_names = split_commas(args.get("methods"));
  std::vector<PhotoCustomizer> methods;
  std::unique_ptr<BodyModel> body_model;
  std::optional<CustomizationModel> model;
  std::unique_ptr<SurveyDistribution> survey;
  const std::string o_survey = find_ansur_root(args.has("survey") ? args.get("survey") : "", find_data_root(args.get("data")));
  for (const std::string& m : method_names) {
    if (m == "paper") {
      model = load_customization_model(args.get("model"));
      methods.push_back(
          [&](const Silhouette& f, const Silhouette& s, const PhotoCameras& c) { return customize_from_silhouettes(f, s, c, *model); });
    } else if (m == "model") {
      if (!args.has("body-model"))
        throw UsageError("--methods model needs --body-model FILE (build one with posekit shape-space --ansur --out FILE)");
      body_model = load_body_model(args);
      std::string no_survey;
      survey = load_survey(o_survey, &no_survey);
      methods.push_back([&](const Silhouette& f, const Silhouette& s, const PhotoCameras& c) {
        return customize_by_body_model(*body_model, f, s, c, 0, false, {}, survey.get());
      });
    } else {
      throw UsageError("--methods expects paper, model or paper,model");
    }
  }
  std::vector<PhoneCondition> conditions;
  if (args.get("conditions") == "all") conditions = all_phone_conditions();
  else
    for (const std::string& c : split_commas(args.get("conditions"))) conditions.push_back(parse_phone_condition(c));
  PhoneSetOptions o;
  o.data_root = find_data_root(args.get("data"));
  o.survey = o_survey;
  o.ansur_bodies = static_cast<int>(args.get_int("bodies"));
  o.extremes = !args.flag_set("no-extremes");
  if (args.has("dataset")) o.dataset_dir = args.get("dataset");
  o.seed = static_cast<unsigned>(args.get_int("seed"));
  const std::vector<PhoneSetBody> bodies = make_phone_set_bodies(o);
  std::string ids;
  for (const PhoneSetBody& b : bodies)
    if (!b.survey_id.empty()) ids += (ids.empty() ? "" : ",") + b.survey_id;
  std::cerr << "posekit customize robustness: " << bodies.size() << " bodies"
            << (ids.empty() ? ""
                            : "; a body model that has not seen them: posekit shape-space --ansur --leave-out-ids " + ids + " --out FILE")
            << "\n";
  nlohmann::json all = nlohmann::json::array();
  for (PhoneCondition c : conditions) {
    Progress progress(std::string("condition ") + phone_condition_name(c), static_cast<int>(bodies.size()));
    const std::vector<PhotoEvaluation> evs = evaluate_phone_set(
        bodies, c, methods, o.seed, [&](int done, int) { progress.update(done); }, args.has("inputs-out") ? args.get("inputs-out") : "");
    progress.finish();
    for (size_t m = 0; m < evs.size(); ++m) {
      PhotoEvaluation ev = evs[m];
      ev.label = std::string(phone_condition_name(c)) + " (" + method_names[m] + ")";
      print_evaluation(ev, std::cout);
      nlohmann::json j = evaluation_json(ev);
      j["condition"] = phone_condition_name(c);
      j["method"] = method_names[m];
      all.push_back(j);
    }
    std::cout.flush();
  }
  if (args.has("json")) {
    const std::string text = all.dump(2) + "\n";
    write_file_atomically(
        args.get("json"), [&](std::ostream& os) { os << text; }, false);
  }
  return 0;
}

}  // namespace

/// The front and side silhouettes from the photos (or masks) given, read side by side: a 12-MP
/// photo's extraction is a third of the work.
void read_silhouettes(const ArgParser& args, Silhouette* front, Silhouette* side) {
  auto extraction = [&](const char* view) {
    SilhouetteOptions o;
    if (args.has(std::string(view) + "-background")) o.background_photo = args.get(std::string(view) + "-background");
    return o;
  };
  run_beside(
      2,
      [&] {
        *side = args.has("side-mask") ? read_silhouette_mask(args.get("side-mask"), "side mask")
                                      : silhouette_from_photo(args.get("side"), "side photo", extraction("side"));
      },
      [&] {
        *front = args.has("front-mask") ? read_silhouette_mask(args.get("front-mask"), "front mask")
                                        : silhouette_from_photo(args.get("front"), "front photo", extraction("front"));
      });
}

/// --debug's figures of a result: the fitted outline over each silhouette (model method) or the
/// features and layers drawn on them (paper method).
void write_result_figures(const std::string& dir, bool by_body_model, const Silhouette& front, const Silhouette& side,
                          const PhotoCameras& cams, const CustomizedBody& body) {
  const std::filesystem::path folder(dir);
  if (by_body_model) {
    const double k = body.scale;  // the fit as it stood in the photos' world
    TriangleMesh seen = body.mesh;
    seen.V = ((seen.V.rowwise() - body.scale_origin.transpose()) / k).rowwise() + body.scale_origin.transpose();
    write_outline_png((folder / "front_outline.png").string(), front, cams.front, seen);
    write_outline_png((folder / "side_outline.png").string(), side, cams.side, seen);
  } else {
    write_photo_features_png((folder / "front_features.png").string(), front, cams.front, body);
    write_photo_features_png((folder / "side_features.png").string(), side, cams.side, body);
  }
}

/// The summary --json prints (and the text summary reads): method, scale, agreement, the paper
/// method's levels and population distance, warnings, the `times`, and with `measure` the girths.
nlohmann::ordered_json customization_summary(const CustomizedBody& body, const CustomizationModel& model, const PhotoCameras& cams,
                                             bool by_body_model, const nlohmann::ordered_json& times, bool measure) {
  const PhotoLandmarks& L = body.landmarks;
  nlohmann::ordered_json j;
  j["method"] = by_body_model ? "model" : "paper";
  j["stature_photos"] = by_body_model ? body.features.stature : L.stature;
  j["scale"] = body.scale;
  if (!by_body_model) {
    j["population_distance"] = body.population_distance;
    j["population_limit"] = model.descriptor_limit;
    j["population_range_excess"] = body.population_range_excess;
  }
  j["photo_agreement"] = body.photo_agreement;
  j["poor"] = body.photo_agreement < kMinPhotoAgreement;
  if (!by_body_model) {
    j["levels_y"] = {
        {"floor", L.floor_y},           {"crotch", L.crotch_y},          {"hip", L.hip_y},   {"waist", L.waist_y}, {"bust", L.bust_y},
        {"armpit_left", L.armpit_y[0]}, {"armpit_right", L.armpit_y[1]}, {"neck", L.neck_y}, {"crown", L.crown_y}};
    for (const auto& [lo, hi] : L.side_arm_occlusion) j["side_arm_occlusion_y"].push_back({lo, hi});
  }
  j["assumed"] = cams.assumed;
  j["warnings"] = body.warnings;
  for (const auto& [key, value] : times.items()) j[key] = value;
  if (!measure) return j;
  const BodyMeasurements m = measure_body(body.mesh.V, body.mesh.F);
  j["stature"] = m.stature;
  for (const char* name : {"bust", "waist", "hip"}) {
    const Girth* g = m.find(name);
    const double level = std::string(name) == "bust"    ? body.features.bust_y
                         : std::string(name) == "waist" ? body.features.waist_y
                                                        : body.features.hip_y;
    j["girths"][name] = {{"mesh", g && g->measured ? nlohmann::json(g->value) : nlohmann::json()}};
    if (!by_body_model) j["girths"][name]["representation"] = representation_torso_girth(body.representation, level);
  }
  return j;
}

/// The summary as text.
void print_customization(const nlohmann::ordered_json& j, const CustomizedBody& body, double height, bool by_body_model, bool measure,
                         const std::string& out) {
  const PhotoLandmarks& L = body.landmarks;
  std::cout << std::fixed << std::setprecision(3) << "stature from the photos " << j["stature_photos"].get<double>() << " m";
  if (height > 0) std::cout << " (scaled by " << std::setprecision(4) << body.scale << " to the stated " << height << " m)";
  std::cout << "\n";
  if (!by_body_model)
    std::cout << std::setprecision(3) << "levels (m): crotch " << L.crotch_y - L.floor_y << ", hip " << L.hip_y - L.floor_y << ", waist "
              << L.waist_y - L.floor_y << ", bust " << L.bust_y - L.floor_y << ", armpits " << L.armpit_y[0] - L.floor_y << " / "
              << L.armpit_y[1] - L.floor_y << ", neck " << L.neck_y - L.floor_y << " above the soles\n";
  if (measure) {
    std::cout << "girths (m)     mesh" << (by_body_model ? "" : "    representation") << "\n";
    for (const char* name : {"bust", "waist", "hip"}) {
      const auto& g = j["girths"][name];
      std::cout << std::left << std::setw(12) << name << std::right << std::setw(8)
                << (g["mesh"].is_null() ? std::string("-") : std::to_string(g["mesh"].get<double>()).substr(0, 5));
      if (!by_body_model) std::cout << std::setw(12) << std::to_string(g["representation"].get<double>()).substr(0, 5);
      std::cout << "\n";
    }
  }
  std::cout << std::setprecision(2) << "photos to mesh in " << j["seconds"].get<double>() << " s (model loaded in "
            << j["model_load_seconds"].get<double>() << " s)" << (out.empty() ? "" : "; wrote " + out) << "\n";
}

int run_customize(int argc, char** argv) {
  if (argc >= 1 && std::string(argv[0]) == "train") return customize_train(argc - 1, argv + 1);
  if (argc >= 1 && std::string(argv[0]) == "eval") return customize_eval(argc - 1, argv + 1);
  if (argc >= 1 && std::string(argv[0]) == "robustness") return customize_robustness(argc - 1, argv + 1);
  ArgParser args("customize",
                 "Customizes the template body to a person from two orthogonal photos (section 3.2): a front photo\n"
                 "(facing the camera, standard pose, arms away from the body, feet apart) and a side photo (the\n"
                 "left side towards the camera), tight clothing; or their silhouettes. The background may show\n"
                 "the floor and a wall lit unevenly; for a textured wall give photos of the empty scene. 2-D\n"
                 "features on both silhouettes place the layered representation, each layer's section is\n"
                 "predicted from the photos' widths and depths by the learned model, and the template is deformed\n"
                 "to it by ct-FFD. The scale comes from the camera file, or from the stated height.\n"
                 "Subcommands: 'customize train' (the model), 'customize eval' (against a dataset's truth),\n"
                 "'customize robustness' (phone photos of bodies of real proportions, both methods).");
  args.option("front", "IMG", "front photo")
      .option("side", "IMG", "side photo")
      .option("front-mask", "IMG", "front silhouette (person white) instead of the photo")
      .option("side-mask", "IMG", "side silhouette instead of the photo")
      .option("front-background", "IMG", "photo of the empty scene from the front camera's place (a textured wall or a room)")
      .option("side-background", "IMG", "photo of the empty scene from the side camera's place")
      .option("camera", "FILE", "camera file (the dataset's camera.json: K, R, t of both views)")
      .option("height", "M", "the person's stature (m): scales the body; without --camera, sets the scale")
      .option("distance", "M", "without --camera: camera distance to the person", "3.0")
      .option("focal", "PX", "without --camera: focal length in pixels (default: from the stated height)")
      .customization_model_option()
      .option("method", "NAME",
              "paper (section 3.2's rules and learned sections) or model (the body model's shape and pose fitted to both silhouettes)",
              "paper")
      .body_model_option("for --method model")
      .data_option()
      .output("out", "FILE", "customized body mesh (PLY/OBJ/OFF/STL)")
      .output_folder("debug", "DIR", "write the silhouettes and the features drawn on them")
      .flag("measure", "print girths of the result beside those of the photos' representation")
      .flag("accept-poor", "write a result that does not look like the photos too (marked poor; exit status 0)")
      .flag("json", "summary as JSON on stdout")
      .example("posekit customize --front f.png --side s.png --camera camera.json --out body.ply --measure")
      .example("posekit customize --front f.jpg --side s.jpg --height 1.68 --out body.ply");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("front") && !args.has("front-mask")) throw UsageError("customize needs --front IMG (or --front-mask IMG)");
  if (!args.has("side") && !args.has("side-mask")) throw UsageError("customize needs --side IMG (or --side-mask IMG)");
  if (!args.has("camera") && !args.has("height")) throw UsageError("customize needs --camera FILE or --height M (the scale)");
  if ((args.has("front-background") && !args.has("front")) || (args.has("side-background") && !args.has("side")))
    throw UsageError("customize: --front-background / --side-background go with the photos (--front / --side), not masks");
  const bool by_body_model = body_model_method(args);
  const auto t_load = std::chrono::steady_clock::now();
  const std::unique_ptr<BodyModel> body_model = by_body_model ? load_body_model(args) : nullptr;
  const CustomizationModel model = by_body_model ? CustomizationModel{} : load_customization_model(args.get("model"));
  std::string no_survey;
  const std::unique_ptr<SurveyDistribution> survey = by_body_model ? load_survey("", &no_survey) : nullptr;
  const auto t0 = std::chrono::steady_clock::now();
  Silhouette front, side;
  read_silhouettes(args, &front, &side);
  const auto t_silhouettes = std::chrono::steady_clock::now();
  const double height = args.has("height") ? args.get_double("height") : 0;
  const PhotoCameras cams = args.has("camera") ? read_photo_cameras(args.get("camera"))
                                               : cameras_from_stature(front, side, height, args.get_double("distance"),
                                                                      args.has("focal") ? args.get_double("focal") : 0);
  for (const auto& a : cams.assumed) std::cerr << "posekit customize: assumed " << a << "\n";
  if (args.has("debug")) {  // the silhouettes first: they tell why the features may not be found
    create_folders(args.get("debug"));
    write_silhouette_png((std::filesystem::path(args.get("debug")) / "front_mask.png").string(), front);
    write_silhouette_png((std::filesystem::path(args.get("debug")) / "side_mask.png").string(), side);
  }
  const CustomizedBody body =
      by_body_model ? customize_by_body_model(*body_model, front, side, cams, height, args.flag_set("accept-poor"), {}, survey.get())
                    : customize_from_silhouettes(front, side, cams, model, height, args.flag_set("accept-poor"));
  const double seconds = seconds_between(t0, std::chrono::steady_clock::now());
  for (const auto& w : body.warnings) std::cerr << "posekit customize: warning: " << w << "\n";
  if (args.has("debug")) write_result_figures(args.get("debug"), by_body_model, front, side, cams, body);
  if (args.has("out")) write_mesh(args.get("out"), body.mesh, {Unit::kMetre, MeshFormat::kAuto, true, io_warnings()});
  const nlohmann::ordered_json times = {{"seconds", seconds},
                                        {"model_load_seconds", seconds_between(t_load, t0)},
                                        {"silhouette_seconds", seconds_between(t0, t_silhouettes)}};
  const nlohmann::ordered_json j = customization_summary(body, model, cams, by_body_model, times, args.flag_set("measure"));
  if (args.flag_set("json")) {
    std::cout << j.dump(2) << "\n";
    return 0;
  }
  print_customization(j, body, height, by_body_model, args.flag_set("measure"), args.has("out") ? args.get("out") : "");
  return 0;
}

}  // namespace posekit::cli
