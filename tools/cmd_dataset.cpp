// posekit dataset make|info: generate the evaluation dataset, or check a folder in its layout.
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "posekit/body/anatomical_driving.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/datasets/dataset.h"
#include "posekit/datasets/robustness.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/io/atomic_file.h"
#include "posekit/population/survey_fit.h"

namespace posekit::cli {
namespace {

std::vector<std::string> split_list(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) items.push_back(item);
  return items;
}

int make_robustness(const ArgParser& args) {
  RobustnessOptions o;
  o.data_root = find_data_root(args.get("data"));
  const long seed = args.get_int("seed"), shapes = args.get_int("shapes");
  if (seed < 0) throw UsageError("--seed must be non-negative");
  if (shapes < 1 || shapes > 100) throw UsageError("--shapes must be 1..100");
  o.seed = static_cast<unsigned>(seed);
  o.shapes = static_cast<int>(shapes);
  o.only = split_list(args.get("variations"));
  o.force = args.flag_set("force");
  const std::string population = args.get("population");
  if (population == "ansur") {
    // Real proportions: MakeHuman fitted to survey subjects drawn with the seed, women and men alternately.
    const std::string survey = find_ansur_root(args.has("survey") ? args.get("survey") : "", o.data_root);
    const std::vector<SurveySubject> drawn = sample_survey(read_survey(survey), o.shapes, o.seed);
    const SurveyBodyFitter fitter(load_makehuman_model(o.data_root));
    std::string ids;
    for (const SurveySubject& subject : drawn) {
      o.shape_specs.push_back(fitter.fit(subject).spec);
      ids += (ids.empty() ? "" : " ") + subject.id;
    }
    o.shapes_source = "MakeHuman fitted to subjects of " + survey + ": " + ids;
  } else if (population != "makehuman") {
    throw UsageError("--population is makehuman or ansur, not '" + population + "'");
  }
  std::optional<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress.emplace("dataset make --robustness", total);
    progress->update(done);
  };
  const RobustnessSummary s = make_robustness_set(args.get("out"), o);
  if (progress) progress->finish();
  if (args.flag_set("json")) {
    print_json(
        {{"out", args.get("out")}, {"bodies", s.bodies}, {"shapes", s.shapes}, {"variations", s.variations}, {"seconds", s.seconds}});
    return 0;
  }
  std::cout << "wrote " << args.get("out") << ": robustness set of " << s.bodies << " bodies (" << s.shapes << " shapes x " << s.variations
            << " variations) in " << std::fixed << std::setprecision(1) << s.seconds << " s; evaluate with: posekit eval bodies --dataset "
            << args.get("out") << "\n";
  return 0;
}

int make_people(const ArgParser& args) {
  PeopleSetOptions o;
  o.data_root = find_data_root(args.get("data"));
  const long seed = args.get_int("seed"), people = args.get_int("people"), natural = args.get_int("natural-rest");
  if (seed < 0) throw UsageError("--seed must be non-negative");
  if (people < 2 || people > 16) throw UsageError("--people must be 2..16");
  if (natural < 0 || natural > people) throw UsageError("--natural-rest must be 0..--people");
  o.seed = static_cast<unsigned>(seed);
  o.people = static_cast<int>(people);
  o.natural_rest = static_cast<int>(natural);
  o.small = args.flag_set("small");
  o.driving = args.get("driving");
  o.force = args.flag_set("force");
  std::optional<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress.emplace("dataset make --people", total);
    progress->update(done);
  };
  const DatasetSummary s = make_people_set(args.get("out"), o);
  if (progress) progress->finish();
  if (args.flag_set("json")) {
    print_json(
        {{"out", args.get("out")}, {"people", s.subjects}, {"meshes_per_person", s.poses}, {"files", s.files}, {"seconds", s.seconds}});
    return 0;
  }
  std::cout << "wrote " << args.get("out") << ": " << s.subjects << " people, " << s.poses << " meshes each, in " << std::fixed
            << std::setprecision(1) << s.seconds << " s; evaluate with: posekit eval pose --dataset " << args.get("out") << " --people\n";
  return 0;
}

int dataset_make(int argc, char** argv) {
  std::string variations;
  for (const auto& v : robustness_variations()) variations += "\n      " + v.name + ": " + v.description;
  ArgParser args("dataset make",
                 "Generates the evaluation dataset from the MakeHuman model: the template, a registered pose\n"
                 "dataset (train/test split), customized subjects in the four BMI classes in their own topology\n"
                 "with ground-truth measurements, correspondence and posed meshes, simulated booth scans (mm)\n"
                 "and front/side photos with silhouette masks. Written to a temporary folder, renamed when done.\n\n"
                 "With --robustness, the robustness set instead: --shapes bodies (women, men, mixed; BMI about 15\n"
                 "to 40) each in every variation, with the rig's joints, girths and part labels as truth:" +
                     variations +
                     "\n\nWith --people N, N people of one topology instead (for posekit eval pose --people): a folder each\n"
                     "of the person at rest and in every pose (with its 16-part pose JSON); the last --natural-rest of them\n"
                     "stand with the arms 25 degrees closer and the elbows bent 25 degrees, posed from that rest.");
  args.output_folder("out", "DIR", "output folder (must not exist unless --force; its parent must, unless --mkdir)")
      .data_option()
      .option("seed", "N", "random seed (same seed, same bytes)", "1")
      .option("subjects", "N", "number of subjects (half female)", "16")
      .option("noise-mm", "S", "scan noise sigma along the ray (mm)", "1.5")
      .option("outliers", "F", "fraction of outlier points added to each scan", "0.001")
      .option("driving", "RULE",
              "how a 16-part pose drives the rig for the ground truth: rig (one bone per part), anatomical (girdle,\n"
              "                          spine, neck and limb twist spread over their bones) or anatomical-alternative (other\n"
              "                          fractions, linear blend skinning: the second generator of a cross-generator test)",
              "rig")
      .flag("small", "a third of the poses and 2 subjects (quick)")
      .flag("robustness", "write the robustness set (for posekit eval bodies) instead")
      .option("shapes", "N", "robustness set: body shapes, each in every variation", "10")
      .option("variations", "LIST", "robustness set: only these variations (comma-separated names)")
      .option("population", "P",
              "robustness set: the shapes' proportions: makehuman (random sliders) or ansur (MakeHuman fitted\n"
              "                          to ANSUR II subjects drawn with the seed, women and men alternately)",
              "makehuman")
      .option("survey", "DIR|FILE",
              "--population ansur: ANSUR II's folder or a survey CSV (default: $POSEKIT_ANSUR, else ansur2 "
              "beside the data root)")
      .option("people", "N", "write N people of one topology in the pose set instead (2..16)")
      .option("natural-rest", "K", "--people: how many of them (the last) stand in a natural rest", "1")
      .flag("force", "replace an existing output folder")
      .flag("json", "summary as JSON on stdout")
      .example("posekit dataset make --out dataset")
      .example("posekit dataset make --out small --small --seed 7")
      .example("posekit dataset make --out anatomical --driving anatomical")
      .example("posekit dataset make --robustness --out robustness")
      .example("posekit dataset make --robustness --population ansur --out robustness-ansur")
      .example("posekit dataset make --people 5 --driving anatomical --out people");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("out")) throw UsageError("--out DIR is required");
  if (args.flag_set("robustness") && args.has("people")) throw UsageError("give --robustness or --people, not both");
  if (args.flag_set("robustness")) return make_robustness(args);
  if (args.has("people")) return make_people(args);
  DatasetOptions o;
  o.data_root = find_data_root(args.get("data"));
  const long seed = args.get_int("seed");
  if (seed < 0) throw UsageError("--seed must be non-negative");
  o.seed = static_cast<unsigned>(seed);
  o.small = args.flag_set("small");
  o.driving = args.get("driving");
  if (!is_driving_name(o.driving)) throw UsageError(std::string("--driving expects ") + kDrivingNames + ", got '" + o.driving + "'");
  o.subjects = static_cast<int>(args.get_int("subjects"));
  if (o.subjects < 1 || o.subjects > 200) throw UsageError("--subjects must be 1..200");
  o.scan_noise_sigma = args.get_double("noise-mm") / 1000.0;
  o.scan_outlier_fraction = args.get_double("outliers");
  if (o.scan_noise_sigma < 0 || o.scan_outlier_fraction < 0 || o.scan_outlier_fraction > 0.5)
    throw UsageError("--noise-mm must be >= 0 and --outliers in [0, 0.5]");
  o.force = args.flag_set("force");
  std::optional<Progress> progress;
  o.progress = [&](int done, int total, const std::string&) {
    if (!progress) progress.emplace("dataset make", total);
    progress->update(done);
  };
  const DatasetSummary s = make_dataset(args.get("out"), o);
  if (progress) progress->finish();
  nlohmann::ordered_json j = {{"out", args.get("out")}, {"poses", s.poses},    {"test_poses", s.test_poses},
                              {"subjects", s.subjects}, {"scans", s.scans},    {"photo_pairs", s.photos / 2},
                              {"files", s.files},       {"seconds", s.seconds}};
  if (args.flag_set("json")) {
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::cout << "wrote " << args.get("out") << ": " << s.poses << " poses (" << s.test_poses << " held out), " << s.subjects << " subjects, "
            << s.scans << " scans, " << s.photos / 2 << " photo pairs, " << s.files << " files in " << std::fixed << std::setprecision(1)
            << s.seconds << " s\n";
  return 0;
}

int dataset_info(int argc, char** argv) {
  ArgParser args("dataset info",
                 "Checks a dataset folder (posekit's, or a user's folder of registered meshes with optional\n"
                 "16-part pose JSONs) and summarises it.");
  args.positional("dir", "dataset folder").option("unit", "U", "unit of user meshes", "m").flag("json", "JSON on stdout");
  if (!args.parse(argc, argv)) return 0;
  const std::string dir = args.positionals()[0];
  const PoseDataset ds = load_pose_dataset(dir, parse_unit(args.get("unit")));
  int test = 0, with_pose = 0;
  for (size_t i = 0; i < ds.names.size(); ++i) test += ds.test[i], with_pose += ds.has_pose[i];
  nlohmann::ordered_json j = {{"dir", dir},       {"pose_meshes", ds.names.size()},  {"with_pose_json", with_pose},
                              {"held_out", test}, {"vertices", ds.V.front().rows()}, {"triangles", ds.F.rows()}};
  const auto manifest = std::filesystem::path(dir) / "manifest.json";
  if (std::filesystem::is_regular_file(manifest)) {
    const auto m = nlohmann::json::parse(read_file_bytes(manifest.string()));
    j["subjects"] = m.value("subjects", nlohmann::json::array()).size();
    int missing = 0;
    for (const auto& f : m["files"])
      if (!std::filesystem::exists(std::filesystem::path(dir) / f["path"].get<std::string>())) ++missing;
    j["manifest_files"] = m["files"].size();
    j["missing_files"] = missing;
    if (missing) throw IoError(manifest.string() + ": " + std::to_string(missing) + " listed files are missing");
  }
  if (args.flag_set("json")) {
    std::cout << j.dump(2) << std::endl;
    return 0;
  }
  std::cout << dir << ": " << ds.names.size() << " registered meshes of " << ds.V.front().rows() << " vertices / " << ds.F.rows()
            << " triangles, " << with_pose << " with 16-part poses, " << test << " held out";
  if (j.contains("subjects")) std::cout << "; " << j["subjects"] << " subjects, all " << j["manifest_files"] << " listed files present";
  std::cout << "\n";
  return 0;
}

}  // namespace

int run_dataset(int argc, char** argv) {
  const std::string usage =
      "usage: posekit dataset <make|info> [options]\n\n  make   generate the evaluation dataset\n"
      "  info   check and summarise a dataset folder\n";
  if (argc < 1 || std::string(argv[0]) == "--help" || std::string(argv[0]) == "-h") {
    std::cout << usage;
    return argc < 1 ? 2 : 0;
  }
  const std::string what = argv[0];
  if (what == "make") return dataset_make(argc - 1, argv + 1);
  if (what == "info") return dataset_info(argc - 1, argv + 1);
  throw UsageError("unknown dataset command '" + what + "'\n" + usage);
}

}  // namespace posekit::cli
