// posekit body: shape the MakeHuman body from sliders, optionally pose it, write it.
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "cli.h"
#include "commands.h"
#include "posekit/body/anatomical_driving.h"
#include "posekit/body/body_spec.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/parts.h"
#include "posekit/body/pose_units.h"
#include "posekit/body/skinning.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/timer.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"

namespace posekit::cli {
namespace {

constexpr double kBodyDensityKgPerLitre = 1.01;

void apply_modifier_list(const std::string& list, BodySpec& spec) {
  std::stringstream in(list);
  std::string item;
  while (std::getline(in, item, ',')) {
    const size_t eq = item.find('=');
    if (eq == std::string::npos) throw UsageError("--modifiers expects name=value[,name=value...], got '" + item + "'");
    try {
      spec.modifiers[item.substr(0, eq)] = std::stod(item.substr(eq + 1));
    } catch (const std::exception&) {
      throw UsageError("--modifiers: '" + item + "' has no numeric value");
    }
  }
}

bool ends_with(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

}  // namespace

int run_body(int argc, char** argv) {
  ArgParser args("body",
                 "Builds a MakeHuman body (skin only, 13,380 vertices, metres) from slider values or a body spec,\n"
                 "optionally poses it (16-part pose JSON or a BVH of the MakeHuman skeleton) with linear blend or\n"
                 "dual quaternion skinning, and writes it. Prints stature, volume, mass at 1.01 kg/L and BMI.");
  args.data_option()
      .option("spec", "FILE", "body spec JSON (sliders and modifiers); flags below override it")
      .option("gender", "G", "0 female .. 1 male")
      .option("muscle", "M", "0 .. 1")
      .option("weight", "W", "0 .. 1")
      .option("height", "H", "0 .. 1")
      .option("proportions", "P", "0 .. 1")
      .option("african", "A", "ethnic mix weight")
      .option("asian", "A", "ethnic mix weight")
      .option("caucasian", "C", "ethnic mix weight")
      .option("modifiers", "LIST", "local modifiers name=value,... (see --list-modifiers)")
      .option("pose", "FILE", "16-part pose (.json) or MakeHuman-skeleton motion (.bvh)")
      .option("frame", "N", "BVH frame to use", "0")
      .option("pose-units", "LIST", "MakeHuman pose units Name=weight,... ('Left' units mirrored when named 'Right')")
      .option("skinning", "KIND", "lbs or dqs", "lbs")
      .option("driving", "RULE",
              "how a 16-part pose JSON drives the rig: rig (one bone per part, skinned by --skinning), anatomical or\n"
              "anatomical-alternative (spread over the bones as a body moves, skinned as posekit dataset make does)",
              "rig")
      .output("out", "FILE", "write the body mesh (.ply .obj .off .stl)")
      .option("unit", "U", "unit of the written mesh", "m")
      .output("save-spec", "FILE", "write the effective body spec JSON")
      .output("joints", "FILE", "write the 15 joint centres of the 16-part skeleton as JSON (m)")
      .flag("labels", "add the 16-part label of every vertex as scalar field 'part' (PLY)")
      .flag("list-modifiers", "list the local modifiers the data provides and exit")
      .flag("list-pose-units", "list the pose units the data provides and exit")
      .flag("json", "machine-readable report on stdout")
      .example("posekit body --gender 1 --weight 0.8 --out man.ply --labels")
      .example("posekit body --spec subject.json --pose walk.json --skinning dqs --out posed.ply")
      .example("posekit body --gender 0 --pose sitting.json --driving anatomical --out sitting.ply");
  if (!args.parse(argc, argv)) return 0;
  const Stopwatch t0;
  const auto model = load_makehuman_model(find_data_root(args.get("data")));
  const double load_s = t0.seconds();
  if (args.flag_set("list-modifiers")) {
    for (const auto& m : model->modifiers) std::cout << m.name << (m.two_sided ? "  [-1, 1]\n" : "  [0, 1]\n");
    return 0;
  }
  if (args.flag_set("list-pose-units")) {
    for (const auto& [name, bones] : read_pose_units(model->data_root + "/poseunits/body-poseunits.json").units)
      std::cout << name << "  (" << bones.size() << " bones)\n";
    return 0;
  }
  BodySpec spec = args.has("spec") ? read_body_spec(args.get("spec")) : BodySpec{};
  const std::pair<const char*, double*> sliders[] = {
      {"gender", &spec.gender},           {"muscle", &spec.muscle},   {"weight", &spec.weight}, {"height", &spec.height},
      {"proportions", &spec.proportions}, {"african", &spec.african}, {"asian", &spec.asian},   {"caucasian", &spec.caucasian}};
  for (const auto& [name, value] : sliders)
    if (args.has(name)) *value = args.get_double(name);
  if (args.has("modifiers")) apply_modifier_list(args.get("modifiers"), spec);
  spec = body_spec_from_json(body_spec_to_json(spec), "command line");  // validates ranges
  Body body = build_body(*model, spec);

  nlohmann::ordered_json report;
  report["vertices"] = body.mesh.num_vertices();
  report["triangles"] = body.mesh.num_faces();
  const double stature = body.mesh.V.col(1).maxCoeff() - body.mesh.V.col(1).minCoeff();
  const double litres = signed_volume(body.mesh.V, body.mesh.F) * 1000.0;
  const double mass = litres * kBodyDensityKgPerLitre;
  report["stature_m"] = stature;
  report["volume_litres"] = litres;
  report["mass_kg"] = mass;
  report["bmi"] = mass / (stature * stature);
  report["model_load_s"] = load_s;

  const Eigen::MatrixXd joints = joint_centres(model->rig, body);
  if (args.has("pose") && args.has("pose-units")) throw UsageError("give --pose or --pose-units, not both");
  const std::string driving_name = args.get("driving");
  if (!is_driving_name(driving_name)) throw UsageError(std::string("--driving expects ") + kDrivingNames + ", got '" + driving_name + "'");
  const std::optional<AnatomicalDriving> driving = anatomical_driving_by_name(driving_name, "--driving");
  if (driving && (!args.has("pose") || ends_with(args.get("pose"), ".bvh") || ends_with(args.get("pose"), ".BVH")))
    throw UsageError("--driving " + args.get("driving") + " drives a 16-part pose JSON: give --pose pose.json");
  if (args.has("pose") || args.has("pose-units")) {
    const std::string pose_path = args.has("pose") ? args.get("pose") : "pose units " + args.get("pose-units");
    BonePose pose;
    if (args.has("pose-units")) {
      std::vector<std::pair<std::string, double>> weighted;
      std::stringstream in(args.get("pose-units"));
      std::string item;
      while (std::getline(in, item, ',')) {
        const size_t eq = item.find('=');
        try {
          weighted.emplace_back(item.substr(0, eq), eq == std::string::npos ? 1.0 : std::stod(item.substr(eq + 1)));
        } catch (const std::exception&) {
          throw UsageError("--pose-units: '" + item + "' has no numeric weight");
        }
      }
      std::vector<std::string> skipped;
      pose = bone_pose_from_pose_units(model->rig, body, read_pose_units(model->data_root + "/poseunits/body-poseunits.json"), weighted,
                                       &skipped);
      if (!skipped.empty()) {
        report["pose_unit_bones_not_in_rig"] = skipped;
        std::cerr << "note: " << skipped.size() << " pose-unit bone(s) are not in the 163-bone rig and were skipped\n";
      }
    } else if (ends_with(pose_path, ".bvh") || ends_with(pose_path, ".BVH")) {
      const BvhMotion motion = read_bvh(pose_path, Unit::kDecimetre, io_warnings());
      pose = bone_pose_from_bvh(model->rig, motion, static_cast<int>(args.get_int("frame")));
    } else {
      const PartPose part_pose = read_part_pose(pose_path);
      pose = driving ? anatomical_bone_pose(model->rig, body, part_pose, *driving) : bone_pose_from_part_pose(model->rig, part_pose);
    }
    const BoneTransforms T = pose_bone_transforms(model->rig, body.bone_heads, pose);
    const std::string kind = driving ? (driving->dual_quaternion ? "dqs" : "lbs") : args.get("skinning");
    if (kind == "lbs") body.mesh.V = linear_blend_skinning(body.mesh.V, model->weights, T);
    else if (kind == "dqs") body.mesh.V = dual_quaternion_skinning(body.mesh.V, model->weights, T);
    else throw UsageError("--skinning must be lbs or dqs, got '" + kind + "'");
    report["pose"] = pose_path;
    report["skinning"] = kind;
    report["driving"] = args.get("driving");
  }
  if (args.flag_set("labels")) body.mesh.vertex_scalars["part"] = vertex_part_labels(*model).cast<double>();
  if (args.has("save-spec")) write_body_spec(args.get("save-spec"), spec);
  if (args.has("joints")) {
    nlohmann::ordered_json j;
    j["units"] = "m, rest pose";
    for (int k = 0; k < kNumJoints; ++k) j["joints"][joint_name(k)] = {joints(k, 0), joints(k, 1), joints(k, 2)};
    const std::string text = j.dump(2) + "\n";
    write_file_atomically(
        args.get("joints"), [&](std::ostream& out) { out << text; }, false);
  }
  if (args.has("out")) {
    write_mesh(args.get("out"), body.mesh, {parse_unit(args.get("unit")), MeshFormat::kAuto, true, io_warnings()});
    report["out"] = args.get("out");
  }
  if (args.flag_set("json")) {
    print_json(report);
    return 0;
  }
  std::cout << std::fixed << std::setprecision(3) << "body: " << body.mesh.num_vertices() << " vertices, " << body.mesh.num_faces()
            << " triangles\n  rest stature " << stature << " m, volume " << std::setprecision(1) << litres << " L, mass " << mass
            << " kg (1.01 kg/L), BMI " << mass / (stature * stature) << "\n";
  if (report.contains("pose")) std::cout << "  posed by " << args.get("pose") << " (" << args.get("skinning") << ")\n";
  if (report.contains("out")) std::cout << "  wrote " << args.get("out") << "\n";
  return 0;
}

}  // namespace posekit::cli
