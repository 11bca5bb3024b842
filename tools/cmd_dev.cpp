// posekit dev: tools for posekit's developers. dev calibrate refits find_body_features' fitted
// constants from the population they were fitted to (shape/feature_calibration.h).
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/datasets/calibration_bodies.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/feature_calibration.h"

namespace posekit::cli {
namespace {

int run_calibrate(int argc, char** argv) {
  ArgParser args("dev calibrate",
                 "Refits the constants of the body features that were fitted to a population (the neck, shoulder,\n"
                 "knee and hip joints' regressions, the neck's depth and the knee and ankle offsets) from\n"
                 "MakeHuman calibration bodies (make_calibration_specs, not the test subjects), remeshed, against\n"
                 "their rig's joints. Prints each constant as shipped and refitted with the RMS error of what it\n"
                 "places; --cpp prints the refitted values as C++ for modules/shape/src/feature_constants.h.\n"
                 "After a change to the template, the remesher or the sections, shipped values worse than a refit\n"
                 "by more than --tolerance make the exit status 3 (below confidence); the elbow's path fraction, a\n"
                 "prior between MakeHuman's mean and real adults', is printed but not judged.");
  args.option("seed", "S", "the population's seed", "20131122")
      .option("bodies", "N", "bodies in the population", "120")
      .option("vertices", "V", "each body remeshed to about V vertices (0: MakeHuman's own mesh)", "12400")
      .option("threads", "T", "threads (0: all cores)", "0")
      .option("tolerance", "MM", "largest RMS error a shipped constant may have over its refit's", "1.5")
      .data_option()
      .flag("cpp", "print the refitted constants as C++")
      .flag("json", "results as JSON on stdout")
      .example("posekit dev calibrate --bodies 120 --cpp");
  if (!args.parse(argc, argv)) return 0;
  CalibrationBodiesOptions o;
  o.seed = static_cast<unsigned>(args.get_int("seed"));
  o.count = static_cast<int>(args.get_int("bodies"));
  o.remesh_vertices = static_cast<int>(args.get_int("vertices"));
  o.threads = static_cast<int>(args.get_int("threads"));
  const double tolerance = args.get_double("tolerance");
  if (o.count < 10) throw UsageError("--bodies must be at least 10 (the shoulder's regression has 6 coefficients per side)");
  if (o.remesh_vertices != 0 && o.remesh_vertices < 1000) throw UsageError("--vertices must be 0 or at least 1000");
  const auto model = load_makehuman_model(find_data_root(args.has("data") ? args.get("data") : ""));
  const Stopwatch t0;
  Progress progress("calibration bodies", o.count);
  o.progress = [&](int done, int) { progress.update(done); };
  std::vector<std::string> skipped;
  const std::vector<FeatureCalibrationSample> samples = make_feature_calibration_samples(*model, o, &skipped);
  progress.finish();
  std::vector<RefitConstant> constants = refit_feature_constants(samples);
  constants.push_back(refit_typical_torso_fractions(samples));
  std::vector<std::string> worse;
  for (const RefitConstant& c : constants)
    if (c.fit != "mean" && c.shipped_rms_mm > c.refit_rms_mm + tolerance) worse.push_back(c.name);  // a mean is a prior
  const std::string population = "make_calibration_specs(" + std::to_string(o.seed) + ", " + std::to_string(o.count) + ")" +
                                 (o.remesh_vertices > 0 ? ", remeshed to " + std::to_string(o.remesh_vertices) + " vertices" : "");
  if (args.flag_set("json")) {
    nlohmann::ordered_json j = {{"population", population},
                                {"bodies", samples.size()},
                                {"skipped", skipped},
                                {"seconds", t0.seconds()},
                                {"tolerance_mm", tolerance},
                                {"shipped_worse_than_refit", worse},
                                {"constants", nlohmann::ordered_json::array()}};
    for (const RefitConstant& c : constants)
      j["constants"].push_back({{"name", c.name},
                                {"predicts", c.what},
                                {"fit", c.fit},
                                {"samples", c.samples},
                                {"shipped", c.shipped},
                                {"refit", c.refit},
                                {"shipped_rms_mm", c.shipped_rms_mm},
                                {"refit_rms_mm", c.refit_rms_mm}});
    print_json(j);
  } else if (args.flag_set("cpp")) {
    std::cout << "// posekit dev calibrate: " << population << ", " << samples.size() << " bodies\n" << refit_constants_as_cpp(constants);
  } else {
    std::cout << population << ": " << samples.size() << " bodies in " << std::fixed << std::setprecision(0) << t0.seconds() << " s"
              << (skipped.empty() ? "" : " (" + std::to_string(skipped.size()) + " left out: their features were not found)") << "\n\n"
              << "| constant | samples | RMS shipped (mm) | RMS refit (mm) | shipped | refit |\n|---|---|---|---|---|---|\n";
    for (const RefitConstant& c : constants) {
      std::cout << "| " << c.name << " | " << c.samples << " | " << std::setprecision(1) << c.shipped_rms_mm << " | " << c.refit_rms_mm
                << " | " << std::setprecision(4);
      for (size_t k = 0; k < c.shipped.size(); ++k) std::cout << (k ? " " : "") << c.shipped[k];
      std::cout << " | ";
      for (size_t k = 0; k < c.refit.size(); ++k) std::cout << (k ? " " : "") << c.refit[k];
      std::cout << " |\n";
    }
    for (const std::string& s : skipped) std::cerr << "posekit dev calibrate: left out " << s << "\n";
  }
  if (!worse.empty()) {
    std::string names;
    for (const std::string& n : worse) names += (names.empty() ? "" : ", ") + n;
    throw BelowConfidence("the shipped " + names + " place their joints over " + std::to_string(tolerance).substr(0, 4) +
                          " mm RMS worse than a refit on " + population + ": refit them (--cpp)");
  }
  return 0;
}

}  // namespace

int run_dev(int argc, char** argv) {
  if (argc >= 1 && std::string(argv[0]) == "calibrate") return run_calibrate(argc - 1, argv + 1);
  std::cout << "usage: posekit dev calibrate [--bodies N] [--seed S] [--cpp] [--json]\n\n"
               "  calibrate  refit the body features' fitted constants from their calibration population\n";
  return argc >= 1 && (std::string(argv[0]) == "--help" || std::string(argv[0]) == "-h") ? 0 : 2;
}

}  // namespace posekit::cli
