// posekit shape-space: a shape space file (.pks) of MakeHuman bodies, of bodies fitted to an
// anthropometric survey (ANSUR II), or of registered meshes; and the --shape-space option of register.
#include <algorithm>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <memory>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/subjects.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/population/makehuman_shape_space.h"
#include "posekit/registration/shape_space.h"

namespace posekit::cli {
namespace fs = std::filesystem;

void set_population_leave_out(PopulationOptions& o, const std::string& what) {
  if (what == "men") {
    o.keep = [](const BodySpec& s, const TriangleMesh&) { return s.gender <= 0.5; };
    o.keep_note = "men (gender over 0.5) left out";
  } else if (what == "obese") {
    o.keep = [](const BodySpec&, const TriangleMesh& m) { return body_stats(m).bmi < 30.0; };
    o.keep_note = "BMI 30 and over left out";
  } else if (what == "local") {
    o.local_variation = false;
  } else if (what != "none") {
    throw UsageError("the shape space's leave-out is none, men, obese or local, not '" + what + "'");
  }
}

ShapeSpace make_makehuman_shape_space(const MakeHumanModel& model, PopulationOptions o, double variance_kept, int max_components) {
  std::unique_ptr<Progress> progress;
  o.progress = [&](int done, int total) {
    if (!progress) progress = std::make_unique<Progress>("shape space bodies", total);
    progress->update(done);
  };
  ShapeSpace space = makehuman_shape_space(model, o, variance_kept, max_components);
  if (progress) progress->finish();
  return space;
}

bool is_shape_space_file(const std::string& value) {
  return !value.empty() && value.find_first_not_of("0123456789", value[0] == '-' ? 1 : 0) != std::string::npos;
}

std::shared_ptr<const ShapeSpace> shape_space_option(const std::string& value, const std::string& leave_out, const std::string& data_root) {
  if (is_shape_space_file(value)) return std::make_shared<const ShapeSpace>(read_shape_space(value));
  const long bodies = value.empty() ? 0 : std::stol(value);
  if (bodies < 0 || bodies == 1) throw UsageError("--shape-space must be 0, at least 2 bodies, or a .pks file");
  if (bodies == 0) return nullptr;
  PopulationOptions po;
  po.count = static_cast<int>(bodies);
  set_population_leave_out(po, leave_out);
  return std::make_shared<const ShapeSpace>(make_makehuman_shape_space(*load_makehuman_model(find_data_root(data_root)), po));
}

namespace {

/// The BVH files `list` names (comma-separated files and folders, searched recursively); "auto": the
/// motions folder beside the data root and the data root's own poses and animations, where they are.
std::vector<std::string> motion_files(const std::string& list, const std::string& data_root) {
  std::vector<std::string> roots;
  if (list == "auto") {
    const fs::path data(data_root);
    for (const fs::path& p : {data.parent_path() / "motions", data / "poses", data / "animations"})
      if (fs::is_directory(p)) roots.push_back(p.string());
  } else {
    std::stringstream in(list);
    for (std::string item; std::getline(in, item, ',');)
      if (!item.empty()) roots.push_back(item);
  }
  std::vector<std::string> files;
  for (const std::string& root : roots) {
    if (!fs::exists(root)) throw UsageError("--motions: " + root + " does not exist");
    if (!fs::is_directory(root)) {
      files.push_back(root);
      continue;
    }
    for (const auto& e : fs::recursive_directory_iterator(root)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
      if (e.is_regular_file() && ext == ".bvh") files.push_back(e.path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

/// Every `every`-th frame of the motions retargeted to the space's mean body, the most distinct of
/// them (distinct_motion_poses) stored in the space for the body-model fit's search.
void add_motion_poses(const std::vector<std::string>& files, const std::string& data_root, int every, int max_poses, ShapeSpace* space) {
  std::vector<LibraryPose> frames;
  int used = 0;
  for (const std::string& file : files) {
    try {
      const LoadedPoses loaded = load_poses(file, "", data_root, space->joint_mean, "", "none");
      for (size_t f = 0; f < loaded.poses.size(); f += static_cast<size_t>(every)) {
        const std::string name = fs::path(file).stem().string() + (loaded.poses.size() > 1 ? " frame " + std::to_string(f) : "");
        frames.push_back({name, name, loaded.poses[f]});
      }
      ++used;
    } catch (const Error& e) {
      std::cerr << "warning: --motions: " << file << " left out: " << e.what() << "\n";
    }
  }
  const std::vector<LibraryPose> chosen = distinct_motion_poses(frames, pose_library(space->joint_mean), max_poses);
  space->poses.resize(static_cast<Eigen::Index>(chosen.size()), 3 * (1 + kNumJoints));
  space->pose_names.clear();
  for (size_t k = 0; k < chosen.size(); ++k) {
    space->poses.row(static_cast<Eigen::Index>(k)) = pose_row(chosen[k].pose);
    space->pose_names.push_back(chosen[k].name);
  }
  std::cerr << "posekit shape-space: " << chosen.size() << " poses for the fit's search, the most distinct of " << frames.size()
            << " frames (every " << every << ") of " << used << " motion files\n";
}

}  // namespace

int run_shape_space(int argc, char** argv) {
  ArgParser args("shape-space",
                 "Learns a shape space (principal components of a population of bodies in one topology) and writes\n"
                 "it to a .pks file for posekit register --shape-space FILE, which then skips the few seconds of\n"
                 "building it. The population: N MakeHuman bodies in its base topology (the dataset's template), or\n"
                 "your own registered bodies (--meshes: a folder of meshes sharing one topology, standing in one\n"
                 "pose, in any place, direction and unit; turned rigidly onto their mean before learning). Register\n"
                 "from the mesh those bodies were registered to.\n"
                 "--survey: posekit's body model population. MakeHuman's sliders (macros, measure-* modifiers, buttocks)\n"
                 "are fitted to each subject's stature, chest, waist (at the navel), buttock, thigh, calf, neck and flexed\n"
                 "biceps girths, crotch and acromial heights, biacromial breadth and sleeve outseam (ANSUR II columns),\n"
                 "the fit residuals are reported, and the components kept are the fewest that reconstruct every fitted\n"
                 "body within --max-rms-mm (docs/population.md).");
  args.output("out", "FILE", "the shape space file to write (.pks)")
      .option("bodies", "N", "MakeHuman bodies in the population", "300")
      .option("leave-out", "WHAT", "none, men, obese or local (the measure modifiers): what the MakeHuman population lacks", "none")
      .data_option()
      .option("meshes", "DIR", "learn from this folder of registered meshes (OBJ/PLY/OFF, one topology) instead of MakeHuman bodies")
      .option("unit", "U", "--meshes: their unit, m, dm, cm, mm, or auto (the first mesh's largest extent tells)", "auto")
      .flag("no-align", "--meshes: keep them where they stand (no rigid alignment onto their mean)")
      .flag("ansur", "learn from MakeHuman bodies fitted to ANSUR II's 6,068 adults (found as --survey says)")
      .option("survey", "DIR|FILE",
              "--ansur: ANSUR II's folder or one survey CSV with its columns (default: $POSEKIT_ANSUR, "
              "else ansur2 beside the data root)")
      .option("subjects", "N", "--ansur: that many subjects spread through the survey (0: all)", "0")
      .option("leave-out-ids", "A,B", "--ansur: leave these SubjectIds out (e.g. the bodies customize robustness photographs)")
      .option("max-rms-mm", "MM", "--ansur: keep the fewest components that reconstruct every fitted body within this RMS", "1")
      .output("residuals", "FILE", "--ansur: write the fit residuals and each subject's sliders (JSON)")
      .option("threads", "N", "--ansur: threads for the fits (0: all cores)", "0")
      .option("motions", "LIST",
              "--ansur: motion capture (BVH files or folders, comma-separated) whose most distinct frames join "
              "the body-model fit's pose library; auto: the motions folder beside the data root and the data root's poses "
              "and animations; none: the built-in library only",
              "auto")
      .option("motion-poses", "N",
              "--motions: poses kept at most (each at least 30 degrees at some joint from the others "
              "and the built-in library)",
              "40")
      .option("motion-every", "N", "--motions: every N-th frame is a candidate", "10")
      .option("variance", "F", "share of the population's variance the components keep", "0.99999")
      .option("max-components", "K", "components at most", "60")
      .flag("json", "summary as JSON on stdout")
      .example("posekit shape-space --out makehuman300.pks")
      .example("posekit shape-space --meshes my_registrations/ --unit mm --out mine.pks")
      .example("posekit shape-space --ansur --out ansur.pks --residuals ansur-fits.json");
  if (!args.parse(argc, argv)) return 0;
  if (!args.has("out")) throw UsageError("--out FILE is required");
  const double variance = args.get_double("variance");
  const long max_components = args.get_int("max-components");
  if (!(variance > 0 && variance <= 1)) throw UsageError("--variance must be in (0, 1]");
  if (max_components < 1) throw UsageError("--max-components must be at least 1");
  ShapeSpace space;
  if (args.flag_set("ansur") || args.has("survey")) {
    if (args.has("meshes")) throw UsageError("--ansur and --meshes are two populations: give one");
    const long subjects = args.get_int("subjects"), threads = args.get_int("threads");
    const double max_rms = args.get_double("max-rms-mm");
    if (subjects < 0 || subjects == 1) throw UsageError("--subjects must be 0 (all) or at least 2");
    if (!(max_rms > 0)) throw UsageError("--max-rms-mm must be positive");
    if (threads < 0) throw UsageError("--threads must be 0 (all cores) or more");
    const long motion_poses = args.get_int("motion-poses"), every = args.get_int("motion-every");
    if (motion_poses < 0) throw UsageError("--motion-poses must be 0 or more");
    if (every < 1) throw UsageError("--motion-every must be at least 1");
    const std::string data_root = find_data_root(args.get("data"));
    const std::vector<std::string> motions =
        args.get("motions") == "none" || motion_poses == 0 ? std::vector<std::string>{} : motion_files(args.get("motions"), data_root);
    space = survey_shape_space(args.has("survey") ? args.get("survey") : "", args.get("data"), subjects, max_rms,
                               static_cast<int>(max_components), static_cast<int>(threads),
                               args.has("residuals") ? args.get("residuals") : "", args.flag_set("json"),
                               args.has("leave-out-ids") ? split_commas(args.get("leave-out-ids")) : std::vector<std::string>{});
    if (!motions.empty()) add_motion_poses(motions, data_root, static_cast<int>(every), static_cast<int>(motion_poses), &space);
  } else if (args.has("meshes")) {
    const std::string dir = args.get("meshes");
    // Read in the file's numbers first when the unit is to be detected: the first mesh's extent tells.
    const bool automatic = args.get("unit") == "auto";
    PoseDataset data = load_pose_dataset(dir, automatic ? Unit::kMetre : parse_unit(args.get("unit")));
    if (automatic) {
      const double extent = robust_largest_extent(data.V.front());
      Unit unit = Unit::kMetre;
      if (!guess_body_unit(extent, &unit))
        throw InvalidInput(dir + ": cannot tell the meshes' unit from the first one's largest extent (" + std::to_string(extent) +
                           "): give --unit");
      for (Eigen::MatrixXd& V : data.V) V *= metres_per_unit(unit);
      std::cerr << "posekit shape-space: unit " << unit_name(unit) << " (detected from " << data.names.front() << "'s largest extent, "
                << extent << ")\n";
    }
    // One unit for all: a body 10 or 1000 times the first one's size is another unit, not a shape.
    const double first = robust_largest_extent(data.V.front());
    for (size_t b = 1; b < data.V.size(); ++b) {
      const double ratio = robust_largest_extent(data.V[b]) / first;
      if (!(ratio > 0.5 && ratio < 2))
        throw InvalidInput(dir + ": " + data.names[b] + " is " + std::to_string(ratio) + " times the size of " + data.names.front() +
                           ": the meshes must be in one unit (convert it, or learn without it)");
    }
    if (!args.flag_set("no-align")) align_bodies_rigidly(data.V);
    space = learn_shape_space(data.V, variance, static_cast<int>(max_components),
                              std::to_string(data.V.size()) + " registered meshes of " + dir);
    space.faces = data.F;
  } else {
    const long count = args.get_int("bodies");
    if (count < 2) throw UsageError("--bodies must be at least 2");
    PopulationOptions po;
    po.count = static_cast<int>(count);
    set_population_leave_out(po, args.get("leave-out"));
    space =
        make_makehuman_shape_space(*load_makehuman_model(find_data_root(args.get("data"))), po, variance, static_cast<int>(max_components));
  }
  write_shape_space(args.get("out"), space);
  double kept = 0;
  for (double v : space.variance_share) kept += v;
  if (args.flag_set("json")) {
    print_json({{"out", args.get("out")},
                {"population", space.population},
                {"bodies", space.bodies},
                {"vertices", space.vertices()},
                {"triangles", space.faces.rows()},
                {"components", space.components()},
                {"variance_kept", kept}});
    return 0;
  }
  std::cout << "wrote " << args.get("out") << ": " << space.components() << " components of " << space.population << " ("
            << space.vertices() << " vertices), " << std::setprecision(6) << 100 * kept << "% of its variance\n";
  return 0;
}

}  // namespace posekit::cli
