// posekit info <file>: what a mesh or point cloud file holds and whether it is usable.
#include <algorithm>
#include <iomanip>
#include <iostream>
#include <nlohmann/json.hpp>

#include "cli.h"
#include "commands.h"
#include "posekit/body/bvh_retarget.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/io/bvh.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/registration/shape_space.h"
#include "posekit/shape/body_orientation.h"

namespace posekit::cli {
namespace {

nlohmann::json box_json(const BoundingBox& b, double to_unit) {
  auto v = [&](const Eigen::Vector3d& x) { return nlohmann::json{x.x() * to_unit, x.y() * to_unit, x.z() * to_unit}; };
  return {{"min", v(b.min)}, {"max", v(b.max)}, {"extent", v(b.extent())}};
}

/// A BVH motion: its skeleton, frames and rate, and how it maps onto the 16 parts.
int info_bvh(const std::string& path, bool json) {
  const BvhMotion motion = read_bvh(path, Unit::kMetre, io_warnings());
  nlohmann::ordered_json report;
  report["file"] = path;
  report["kind"] = "BVH motion";
  report["joints"] = motion.joints.size();
  int channels = 0, six = 0, roots = 0;
  for (const auto& j : motion.joints) {
    channels += static_cast<int>(j.channels.size());
    six += j.channels.size() == 6;
    roots += j.parent < 0;
  }
  report["channels"] = channels;
  report["joints_with_6_channels"] = six;
  report["root"] = motion.joints.empty() ? "" : motion.joints.front().name;
  report["frames"] = motion.num_frames();
  report["frame_time_s"] = motion.frame_time;
  report["fps"] = motion.frame_time > 0 ? 1.0 / motion.frame_time : 0.0;
  report["duration_s"] = motion.frame_time * motion.num_frames();
  // Rest skeleton (OFFSETs alone): its height in the file's own unit.
  Eigen::MatrixXd rest(static_cast<Eigen::Index>(motion.joints.size()), 3);
  for (size_t j = 0; j < motion.joints.size(); ++j) {
    const auto& b = motion.joints[j];
    rest.row(static_cast<Eigen::Index>(j)) =
        (b.parent < 0 ? Eigen::Vector3d::Zero() : Eigen::Vector3d(rest.row(b.parent).transpose())) + b.offset;
  }
  const Eigen::Vector3d extent =
      rest.rows() ? Eigen::Vector3d(rest.colwise().maxCoeff() - rest.colwise().minCoeff()) : Eigen::Vector3d::Zero();
  report["rest_extent_file_units"] = {extent.x(), extent.y(), extent.z()};
  nlohmann::ordered_json mapping;
  std::string mapping_error;
  if (motion.find_joint("upperarm01.L") >= 0) {
    mapping = "MakeHuman's own skeleton (bone by bone through its rig)";
  } else {
    try {
      const BvhPartMap map = map_bvh_skeleton(motion);
      for (int p = 0; p < kNumParts; ++p)
        mapping[part_name(p)] =
            map.joint[static_cast<size_t>(p)] >= 0 ? motion.joints[static_cast<size_t>(map.joint[static_cast<size_t>(p)])].name : "";
      report["mapping_notes"] = map.notes;
    } catch (const InvalidInput& e) {
      mapping_error = e.what();
    }
  }
  report["parts"] = mapping_error.empty() ? mapping : nlohmann::ordered_json(nullptr);
  if (!mapping_error.empty()) report["mapping_error"] = mapping_error;
  if (json) {
    std::cout << report.dump(2) << std::endl;
    return 0;
  }
  std::cout << path << ": BVH motion, " << motion.joints.size() << " joints (root '" << report["root"].get<std::string>() << "', "
            << channels << " channels, " << six << " with position and rotation), " << motion.num_frames() << " frames at " << std::fixed
            << std::setprecision(1) << report["fps"].get<double>() << " fps (" << std::setprecision(2) << report["duration_s"].get<double>()
            << " s)\n"
            << "rest skeleton extent (file units): " << std::setprecision(3) << extent.x() << " x " << extent.y() << " x " << extent.z()
            << "\n";
  if (!mapping_error.empty()) {
    std::cout << "16-part mapping: none: " << mapping_error << "\n";
  } else if (mapping.is_string()) {
    std::cout << "16-part mapping: " << mapping.get<std::string>() << "\n";
  } else {
    std::cout << "16-part mapping:";
    for (const auto& [part, joint] : mapping.items())
      std::cout << " " << part << "=" << (joint.get<std::string>().empty() ? "(follows its parent)" : joint.get<std::string>());
    std::cout << "\n";
    for (const auto& n : report["mapping_notes"]) std::cout << "note: " << n.get<std::string>() << "\n";
  }
  return 0;
}

/// A trained model: a pose model (.pkm, posekit train), a photo customization model (.pkc) or a
/// shape space (.pks, posekit shape-space).
int info_model(const std::string& path, const std::string& ext, bool json) {
  nlohmann::ordered_json report;
  report["file"] = path;
  if (ext == ".pks") {
    const ShapeSpace s = read_shape_space(path);
    double kept = 0;
    for (double v : s.variance_share) kept += v;
    report["kind"] = "shape space (register --shape-space)";
    report["population"] = s.population;
    report["bodies"] = s.bodies;
    report["vertices"] = s.vertices();
    report["triangles"] = s.faces.rows();
    report["components"] = s.components();
    report["variance_kept"] = kept;
    report["first_components_variance"] =
        std::vector<double>(s.variance_share.begin(), s.variance_share.begin() + std::min<size_t>(5, s.variance_share.size()));
    report["joints"] = s.joint_mean.rows();
    report["motion_poses"] = s.poses.rows();  // the body-model fit's search, beside its built-in library
    if (s.poses.rows() > 0)
      report["first_motion_poses"] =
          std::vector<std::string>(s.pose_names.begin(), s.pose_names.begin() + std::min<size_t>(5, s.pose_names.size()));
  } else if (ext == ".pkm") {
    const PoseModel m = read_pose_model(path);
    int offsets = 0;
    for (Eigen::Index j = 0; j < m.joint_offsets.rows(); ++j) offsets += m.joint_offsets.row(j).squaredNorm() > 0;
    report["kind"] = "pose model (Eq. 3-5)";
    report["template_vertices"] = m.template_V.rows();
    report["template_triangles"] = m.template_F.rows();
    report["joints"] = m.joint_centres.rows();
    report["training_poses"] = m.training_poses;
    report["fit_rms"] = m.fit_rms;
    // Eq. 6 weighted by these (eq6_triangle_weights); a model of an older posekit has none.
    report["eq6_weights"] = m.triangle_rms.size() ? "training residuals" : "area (no residuals stored)";
    report["joints_with_learned_offsets"] = offsets;
    report["segmentation_prior_bodies"] = m.segmentation_prior.bodies.size();
  } else {
    const CustomizationModel m = load_customization_model(path);
    double linear = 0, mlp = 0;
    int mlps = 0;
    for (const auto& l : m.layers) linear += l.linear_error_mm, mlp += l.mlp_error_mm, mlps += l.use_mlp;
    const double n = static_cast<double>(std::max<size_t>(1, m.layers.size()));
    report["kind"] = "photo customization model";
    report["template_vertices"] = m.template_mesh.V.rows();
    report["layers"] = m.layers.size();
    report["layers_using_mlp"] = mlps;
    report["points_per_layer"] = m.points_per_layer;
    report["training_bodies"] = m.bodies;
    report["validation_bodies"] = m.validation_bodies;
    report["population"] = m.population;
    report["seed"] = m.seed;
    report["training_seconds"] = m.training_seconds;
    report["validation_feature_error_mm"] = m.feature_error_mm;
    report["validation_layer_error_mm"] = {{"linear", linear / n}, {"mlp", mlp / n}};
  }
  if (json) {
    std::cout << report.dump(2) << std::endl;
    return 0;
  }
  std::cout << path << ": " << report["kind"].get<std::string>() << "\n";
  for (const auto& [key, value] : report.items())
    if (key != "file" && key != "kind") std::cout << "  " << key << ": " << value.dump() << "\n";
  return 0;
}

}  // namespace

/// The report of a mesh or point cloud as text.
void print_geometry_report(const nlohmann::json& report, const std::string& path, Unit unit) {
  std::cout << std::fixed << std::setprecision(4);
  std::cout << path << " (" << report["kind"].get<std::string>() << ", coordinates in " << unit_name(unit) << ")\n";
  if (report["kind"] == "point cloud") {
    std::cout << "  points:      " << report["points"] << "\n";
  } else {
    if (report.contains("groups_triangles")) {
      std::cout << "  groups:      " << report["groups_triangles"].size() << " (";
      int shown = 0;
      for (auto it = report["groups_triangles"].begin(); it != report["groups_triangles"].end() && shown < 6; ++it, ++shown)
        std::cout << (shown ? ", " : "") << it.key() << ": " << it.value() << " triangles";
      std::cout << (report["groups_triangles"].size() > 6 ? ", ...)\n" : ")\n");
    }
    if (report.contains("group")) std::cout << "  group:       " << report["group"].get<std::string>() << "\n";
    const auto& v = report["validity"];
    std::cout << "  vertices:    " << report["vertices"] << "\n  triangles:   " << report["triangles"] << "\n";
    std::cout << "  validity:    " << (v["usable"].get<bool>() ? "usable" : "NOT usable") << ", "
              << (v["watertight"].get<bool>() ? "watertight" : "not watertight") << "\n";
    for (const char* key : {"out_of_range_indices", "non_finite_vertices", "degenerate_faces", "duplicate_faces", "unreferenced_vertices",
                            "boundary_edges", "boundary_loops", "non_manifold_edges", "components"})
      std::cout << "    " << key << ": " << v[key] << "\n";
    std::cout << "  area:        " << report["surface_area_m2"].get<double>() << " m^2\n";
    if (report.contains("volume_litres")) std::cout << "  volume:      " << report["volume_litres"].get<double>() << " L\n";
  }
  std::string kept;
  for (const auto& [key, what] : {std::pair<const char*, const char*>{"has_normals", "normals"},
                                  {"has_colors", "colours"},
                                  {"has_texture_coordinates", "texture coordinates"}})
    if (report.value(key, false)) kept += std::string(kept.empty() ? "" : ", ") + what;
  std::cout << "  per vertex:  " << (kept.empty() ? "positions only" : "positions, " + kept) << "\n";
  if (!report["scalar_fields"].empty()) std::cout << "  scalars:     " << report["scalar_fields"].dump() << "\n";
  if (report.contains("face_fields") && !report["face_fields"].empty())
    std::cout << "  face fields: " << report["face_fields"].dump() << "\n";
  if (report.contains("bounding_box")) {
    const auto& b = report["bounding_box"];
    auto d = [&](const char* key, int i) { return b[key][i].get<double>(); };
    std::cout << "  bbox min:    " << d("min", 0) << " " << d("min", 1) << " " << d("min", 2) << " " << unit_name(unit) << "\n";
    std::cout << "  bbox max:    " << d("max", 0) << " " << d("max", 1) << " " << d("max", 2) << " " << unit_name(unit) << "\n";
    std::cout << "  extent:      " << d("extent", 0) << " x " << d("extent", 1) << " x " << d("extent", 2) << " " << unit_name(unit)
              << "\n";
  }
  if (report.contains("orientation_guess_for_a_body"))
    std::cout << "  as a body:   " << report["orientation_guess_for_a_body"].get<std::string>() << "\n";
  if (report.contains("warning")) std::cout << "  warning:     " << report["warning"].get<std::string>() << "\n";
}

int run_info(int argc, char** argv) {
  ArgParser args("info",
                 "Reports what a mesh (OBJ, PLY, OFF, STL) or point cloud (PCD, PLY, XYZ) holds: counts,\n"
                 "groups, scalar fields, bounding box, the unit it seems to be in, and a validity report\n"
                 "(out-of-range indices, non-finite coordinates, degenerate and duplicate faces,\n"
                 "boundaries, non-manifold edges, components, watertightness, area, volume). For a BVH\n"
                 "motion: joints, channels, frames, rate, and how its skeleton maps onto the 16 parts. For a\n"
                 "trained model (.pkm pose model, .pkc photo customization model, .pks shape space): what it\n"
                 "was trained on.");
  args.positional("file", "mesh, point cloud, BVH motion, trained model or shape space")
      .option("unit", "U", "unit the file is written in: m, dm, cm, mm", "m")
      .option("group", "NAME", "report only this OBJ group (e.g. body)")
      .flag("json", "machine-readable report on stdout")
      .example("posekit info ../shared/datasets/makehuman/3dobjs/base.obj --unit dm --group body")
      .example("posekit info scan.pcd --unit mm --json")
      .example("posekit info ../shared/datasets/motions/cmu/01_01.bvh");
  if (!args.parse(argc, argv)) return 0;
  const std::string path = args.positionals()[0];
  {
    std::string ext = path.size() >= 4 ? path.substr(path.size() - 4) : "";
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (ext == ".bvh") return info_bvh(path, args.flag_set("json"));
    if (ext == ".pkm" || ext == ".pkc" || ext == ".pks") return info_model(path, ext, args.flag_set("json"));
  }
  const Unit unit = parse_unit(args.get("unit"));
  const double to_unit = 1.0 / metres_per_unit(unit);
  nlohmann::json report;
  report["file"] = path;
  report["unit"] = unit_name(unit);
  report["coordinates_unit_in_report"] = unit_name(unit);
  BodyInput in = read_body_input(path, unit);
  const bool as_cloud = in.is_cloud;
  TriangleMesh& mesh = in.mesh;
  const PointCloud& cloud = in.cloud;
  Eigen::MatrixXd points;
  if (as_cloud) {
    report["kind"] = "point cloud";
    report["points"] = cloud.size();
    report["has_normals"] = cloud.has_normals();
    report["has_colors"] = cloud.has_colors();
    std::vector<std::string> names;
    for (const auto& kv : cloud.point_scalars) names.push_back(kv.first);
    report["scalar_fields"] = names;
    points = cloud.P;
  } else {
    report["kind"] = "triangle mesh";
    if (!mesh.group_names.empty()) {
      nlohmann::json groups = nlohmann::json::object();
      Eigen::VectorXi counts = Eigen::VectorXi::Zero(static_cast<Eigen::Index>(mesh.group_names.size()));
      for (Eigen::Index f = 0; f < mesh.face_group.size(); ++f) ++counts[mesh.face_group[f]];
      for (size_t g = 0; g < mesh.group_names.size(); ++g) groups[mesh.group_names[g]] = counts[g];
      report["groups_triangles"] = groups;
    }
    if (args.has("group")) {
      mesh = extract_group(mesh, args.get("group"));
      report["group"] = args.get("group");
    }
    const MeshReport r = validate_mesh(mesh);
    report["vertices"] = r.num_vertices;
    report["triangles"] = r.num_faces;
    report["has_normals"] = mesh.has_normals();
    report["has_colors"] = mesh.has_colors();
    report["has_texture_coordinates"] = mesh.has_uv();
    std::vector<std::string> names, face_names;
    for (const auto& kv : mesh.vertex_scalars) names.push_back(kv.first);
    for (const auto& kv : mesh.face_scalars) face_names.push_back(kv.first);
    report["scalar_fields"] = names;
    report["face_fields"] = face_names;
    report["validity"] = {{"usable", r.usable()},
                          {"out_of_range_indices", r.out_of_range_indices},
                          {"non_finite_vertices", r.non_finite_vertices},
                          {"degenerate_faces", r.degenerate_faces},
                          {"duplicate_faces", r.duplicate_faces},
                          {"unreferenced_vertices", r.unreferenced_vertices},
                          {"boundary_edges", r.boundary_edges},
                          {"boundary_loops", r.boundary_loops},
                          {"non_manifold_edges", r.non_manifold_edges},
                          {"components", r.components},
                          {"watertight", r.watertight}};
    report["surface_area_m2"] = r.surface_area;
    if (r.watertight) report["volume_litres"] = r.signed_volume * 1000.0;
    points = mesh.V;
  }
  if (points.rows() > 0) {
    const BoundingBox box = bounding_box(points);
    report["bounding_box"] = box_json(box, to_unit);
    Unit guess;
    const double extent_in_file_units = robust_largest_extent(points) * to_unit;  // as measure and compare tell it
    if (guess_body_unit(extent_in_file_units, &guess)) {
      report["unit_guess_for_a_body"] = unit_name(guess);
      try {  // which way a body in this file stands, as measure, segment and compare will find it
        const BodyOrientation o = as_cloud ? detect_body_orientation(points) : detect_mesh_orientation(mesh.V, mesh.F);
        report["orientation_guess_for_a_body"] = o.describe();
        if (!o.warnings.empty()) report["orientation_doubts"] = o.warnings;
      } catch (const InvalidInput& e) {
        report["orientation_guess_for_a_body"] = std::string("none: ") + e.what();
      }
      if (guess != unit)
        report["warning"] = "largest extent " + std::to_string(extent_in_file_units) + " " + unit_name(unit) +
                            ": if this is a human body, the file is probably in " + unit_name(guess) + " (pass --unit " + unit_name(guess) +
                            ")";
    }
  }
  if (args.flag_set("json")) {
    print_json(report);
    return 0;
  }
  print_geometry_report(report, path, unit);
  return 0;
}

}  // namespace posekit::cli
