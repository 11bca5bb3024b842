#include "posekit/datasets/dataset.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "json_helpers.h"
#include "posekit/body/anatomical_driving.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/skinning.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/rasterizer.h"
#include "posekit/core/timer.h"
#include "posekit/datasets/pose_set.h"
#include "posekit/datasets/remesh.h"
#include "posekit/datasets/scanner.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/image_io.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"

namespace posekit {
using datasets_detail::vec;
namespace fs = std::filesystem;

namespace {

/// The subjects' posed ground truth and scans use these held-out poses.
const char* kSubjectTestPoses[] = {"walk_phase_1", "reach_forward", "squat_half"};
/// With anatomical driving, subjects are also posed (not scanned) in these held-out poses, so that
/// every pose type has subjects: sit, torso, single joints, a reach across the body.
const char* kSubjectExtraPoses[] = {"sitting", "torso_bend_right_20", "reach_left_low", "right_shoulder_raise_120", "left_hip_flex_75"};

class DatasetWriter {
 public:
  explicit DatasetWriter(fs::path root) : root_(std::move(root)) {}

  void text(const std::string& rel, const std::string& content, const std::string& kind, const std::string& meaning) {
    ensure_parent(rel);
    write_file_atomically((root_ / rel).string(), [&](std::ostream& out) { out << content; }, false);
    add(rel, kind, meaning);
  }
  void mesh(const std::string& rel, const TriangleMesh& m, const std::string& kind, const std::string& meaning) {
    ensure_parent(rel);
    write_mesh((root_ / rel).string(), m);
    add(rel, kind, meaning);
  }
  void cloud(const std::string& rel, const PointCloud& c, const std::string& meaning) {
    ensure_parent(rel);
    write_point_cloud((root_ / rel).string(), c, {Unit::kMillimetre});
    add(rel, "scan", meaning);
  }
  void png(const std::string& rel, int w, int h, const std::vector<std::uint8_t>& px, const std::string& kind, const std::string& meaning) {
    ensure_parent(rel);
    write_gray_png((root_ / rel).string(), w, h, px);
    add(rel, kind, meaning);
  }
  const nlohmann::ordered_json& files() const { return files_; }

 private:
  void ensure_parent(const std::string& rel) { fs::create_directories((root_ / rel).parent_path()); }
  void add(const std::string& rel, const std::string& kind, const std::string& meaning) {
    files_.push_back({{"path", rel}, {"kind", kind}, {"meaning", meaning}});
  }
  fs::path root_;
  nlohmann::ordered_json files_ = nlohmann::ordered_json::array();
};

std::string pose_json(const NamedPose& p) { return part_pose_to_json(p.pose); }

/// The posed ground truth of a body: one bone per part, or spread over the rig's chains.
Eigen::MatrixXd pose_body(const MakeHumanModel& model, const Body& body, const PartPose& pose,
                          const std::optional<AnatomicalDriving>& anatomy) {
  if (!anatomy) {
    const BoneTransforms T = pose_bone_transforms(model.rig, body.bone_heads, bone_pose_from_part_pose(model.rig, pose));
    return dual_quaternion_skinning(body.mesh.V, model.weights, T);
  }
  const BoneTransforms T = pose_bone_transforms(model.rig, body.bone_heads, anatomical_bone_pose(model.rig, body, pose, *anatomy));
  return anatomy->dual_quaternion ? dual_quaternion_skinning(body.mesh.V, model.weights, T)
                                  : linear_blend_skinning(body.mesh.V, model.weights, T);
}

std::string correspondence_csv(const SurfacePoints& s) {
  std::ostringstream o;
  o << "# subject vertex -> template triangle and barycentric coordinates (posekit dataset)\n"
    << "subject_vertex,template_triangle,b0,b1,b2\n"
    << std::setprecision(17);
  for (Eigen::Index i = 0; i < s.face.size(); ++i)
    o << i << ',' << s.face[i] << ',' << s.bary(i, 0) << ',' << s.bary(i, 1) << ',' << s.bary(i, 2) << '\n';
  return o.str();
}

std::string measurements_json(const Measurements& m, const BodyStats& st) {
  nlohmann::ordered_json j;
  j["units"] = "m (girths are convex-hull perimeters of the cross-section; definitions in README)";
  j["stature"] = m.stature;
  j["girths"] = {{"bust", m.bust},   {"underbust", m.underbust}, {"waist", m.waist}, {"hip", m.hip},
                 {"thigh", m.thigh}, {"upper_arm", m.upper_arm}, {"neck", m.neck}};
  j["levels_y"] = {{"arms_separate", m.arms_separate_height},
                   {"bust", m.bust_height},
                   {"waist", m.waist_height},
                   {"hip", m.hip_height},
                   {"crotch", m.crotch_height}};
  j["volume_litres"] = st.volume_litres;
  j["mass_kg"] = st.mass_kg;
  j["bmi"] = st.bmi;
  return j.dump(2) + "\n";
}

}  // namespace

namespace {

/// The template in rest pose with its 16-part labels, joint centres and spec.
void write_template(DatasetWriter& w, const Body& templ, const Eigen::VectorXi& vlabels, const Eigen::VectorXi& tlabels,
                    const Eigen::MatrixXd& joints) {
  TriangleMesh m = templ.mesh;
  m.vertex_scalars["part"] = vlabels.cast<double>();
  w.mesh("template/rest.ply", m, "template", "pose-dataset subject in rest pose, with vertex scalar 'part' (0..15)");
  nlohmann::ordered_json parts;
  for (int p = 0; p < kNumParts; ++p) parts["names"].push_back(part_name(p));
  parts["vertex_part"] = std::vector<int>(vlabels.data(), vlabels.data() + vlabels.size());
  parts["triangle_part"] = std::vector<int>(tlabels.data(), tlabels.data() + tlabels.size());
  w.text("template/parts.json", parts.dump() + "\n", "labels", "16-part labels of every template vertex and triangle");
  nlohmann::ordered_json jj;
  jj["units"] = "m";
  for (int j = 0; j < kNumJoints; ++j) jj["joints"][joint_name(j)] = vec(joints.row(j).transpose());
  w.text("template/joints.json", jj.dump(2) + "\n", "joints", "15 joint centres of the 16-part skeleton, rest pose");
  w.text("template/spec.json", body_spec_to_json(BodySpec{}), "spec", "MakeHuman body spec of the template");
}

/// A subject's simulated booth scans, one per pose in `scanned`; returns the manifest's entries.
nlohmann::ordered_json write_scans(DatasetWriter& w, const DatasetOptions& o, const std::string& id, size_t si,
                                   const std::vector<std::pair<std::string, TriangleMesh>>& scanned, DatasetSummary* summary) {
  nlohmann::ordered_json scans = nlohmann::ordered_json::array();
  for (size_t k = 0; k < scanned.size(); ++k) {
    ScannerOptions so;
    so.noise_sigma = o.scan_noise_sigma;
    so.outlier_fraction = o.scan_outlier_fraction;
    so.width = 320;
    so.height = 480;
    so.focal_px = 345;
    so.seed = o.seed * 7919u + static_cast<unsigned>(si * 31 + k);
    const SimulatedScan scan = simulate_scan(scanned[k].second, so);
    const std::string rel = "scans/" + id + "/" + scanned[k].first + ".pcd";
    w.cloud(rel, scan.cloud, "simulated scan of " + id + " in '" + scanned[k].first + "' (mm, 8 views, noise along rays)");
    scans.push_back({{"pose", scanned[k].first},
                     {"cloud", rel},
                     {"points", scan.cloud.size()},
                     {"outliers", scan.outliers},
                     {"noise_sigma_mm", o.scan_noise_sigma * 1000}});
    ++summary->scans;
  }
  return scans;
}

/// A subject's front and side photos (and their true masks, and the cameras' file).
void write_photos(DatasetWriter& w, const std::string& id, const TriangleMesh& rest_mesh, DatasetSummary* summary) {
  // Photos: front and (left) side at 3 m, perspective, plain background.
  const double mid = 0.5 * (rest_mesh.V.col(1).maxCoeff() + rest_mesh.V.col(1).minCoeff());
  const PinholeCamera front =
      PinholeCamera::look_at(Eigen::Vector3d(0, mid, 3.0), Eigen::Vector3d(0, mid, 0), Eigen::Vector3d::UnitY(), 800, 1200, 1400);
  const PinholeCamera side =
      PinholeCamera::look_at(Eigen::Vector3d(3.0, mid, 0), Eigen::Vector3d(0, mid, 0), Eigen::Vector3d::UnitY(), 800, 1200, 1400);
  std::string cameras = "{\n\"front\": " + camera_to_json(front) + ",\n\"side\": " + camera_to_json(side) + "}\n";
  for (const auto& [view, cam] : {std::pair<std::string, PinholeCamera>{"front", front}, {"side", side}}) {
    const RenderBuffers buf = render_mesh(rest_mesh, cam);
    std::vector<std::uint8_t> mask(buf.face.size());
    for (size_t k = 0; k < mask.size(); ++k) mask[k] = buf.face[k] >= 0 ? 255 : 0;
    w.png("photos/" + id + "/" + view + ".png", buf.width, buf.height, buf.gray, "photo", view + " photo of " + id + " (3 m, f = 1400 px)");
    w.png("photos/" + id + "/" + view + "_mask.png", buf.width, buf.height, mask, "mask",
          "ground-truth silhouette of the " + view + " photo");
    summary->photos += 1;
  }
  w.text("photos/" + id + "/camera.json", cameras, "camera", "intrinsics and extrinsics of the front and side photos");
}

}  // namespace

DatasetSummary make_dataset(const std::string& out_dir, const DatasetOptions& o) {
  const Stopwatch t0;
  DatasetSummary summary;
  write_folder_atomically(out_dir, o.force, [&](const std::string& tmp_folder) {
    const fs::path tmp(tmp_folder);
    const auto model = load_makehuman_model(o.data_root);
    const std::optional<AnatomicalDriving> anatomy = anatomical_driving_by_name(o.driving, "dataset");
    DatasetWriter w(tmp);
    nlohmann::ordered_json manifest;
    manifest["format"] = "posekit dataset 1";
    manifest["generator"] = {
        {"seed", o.seed},
        {"small", o.small},
        {"source", "MakeHuman CC0 assets (data root)"},
        {"posing", anatomy ? "163-bone rig driven anatomically (" + anatomy->name + "), MakeHuman skinning weights, " +
                                 (anatomy->dual_quaternion ? "dual quaternion" : "linear blend") + " skinning"
                           : std::string("163-bone rig, one bone per part, MakeHuman skinning weights, dual quaternion skinning")},
        {"driving", o.driving}};
    manifest["units"] = {{"meshes", "m"}, {"scans", "mm"}, {"angles", "radians"}};

    // Template: the pose-dataset subject in rest pose.
    const Body templ = build_body(*model, BodySpec{});
    const Eigen::VectorXi vlabels = vertex_part_labels(*model);
    const Eigen::VectorXi tlabels = triangle_part_labels(templ.mesh.F, vlabels);
    const Eigen::MatrixXd joints = joint_centres(model->rig, templ);
    write_template(w, templ, vlabels, tlabels, joints);
    // Pose dataset.
    std::vector<NamedPose> poses = standard_pose_set(joints, o.seed, o.small ? 4 : 10, o.small);
    std::vector<std::string> subject_poses(std::begin(kSubjectTestPoses), std::end(kSubjectTestPoses));
    if (anatomy && !o.small) subject_poses.insert(subject_poses.end(), std::begin(kSubjectExtraPoses), std::end(kSubjectExtraPoses));
    for (auto& p : poses)
      for (const auto& name : subject_poses)
        if (p.name == name) p.test = true;
    for (const char* name : kSubjectTestPoses)
      if (std::none_of(poses.begin(), poses.end(), [&](const NamedPose& p) { return p.name == name; }))
        throw InvalidInput(std::string("pose set lacks the subject test pose ") + name);
    NamedPose rest;
    rest.name = "rest";
    poses.insert(poses.begin(), rest);
    const int total_steps = static_cast<int>(poses.size()) + (o.small ? 2 : o.subjects);
    int step = 0;
    nlohmann::ordered_json pose_list = nlohmann::ordered_json::array();
    for (const NamedPose& p : poses) {
      TriangleMesh m;
      m.V = pose_body(*model, templ, p.pose, anatomy);
      m.F = templ.mesh.F;
      w.mesh("pose_dataset/" + p.name + ".ply", m, "pose example", "template registered in pose '" + p.name + "'");
      w.text("pose_dataset/" + p.name + ".json", pose_json(p), "pose", "16-part pose of '" + p.name + "'");
      pose_list.push_back({{"name", p.name},
                           {"mesh", "pose_dataset/" + p.name + ".ply"},
                           {"pose", "pose_dataset/" + p.name + ".json"},
                           {"split", p.test ? "test" : "train"}});
      ++summary.poses;
      summary.test_poses += p.test;
      if (o.progress) o.progress(++step, total_steps, "pose " + p.name);
    }
    manifest["template"] = {{"mesh", "template/rest.ply"},
                            {"parts", "template/parts.json"},
                            {"joints", "template/joints.json"},
                            {"spec", "template/spec.json"}};
    manifest["pose_dataset"] = {{"rest", "rest"}, {"poses", pose_list}};

    // Subjects.
    const auto specs = make_subject_specs(*model, o.seed, o.small ? 2 : o.subjects);
    nlohmann::ordered_json subjects = nlohmann::ordered_json::array();
    for (size_t si = 0; si < specs.size(); ++si) {
      const SubjectSpec& s = specs[si];
      const std::string dir = "subjects/" + s.id + "/";
      const Body body = build_body(*model, s.spec);
      const BodyStats st = body_stats(body.mesh);
      SurfacePoints corr;
      const TriangleMesh rest_mesh = remesh_body(body.mesh, o.subject_vertices, &corr);
      const Measurements meas = measure_makehuman_body(*model, body);
      w.text(dir + "spec.json", body_spec_to_json(s.spec), "spec", "MakeHuman body spec of subject " + s.id);
      w.mesh(dir + "rest.ply", rest_mesh, "subject", "subject " + s.id + " in rest pose, its own topology");
      w.text(dir + "measurements.json", measurements_json(meas, st), "measurements", "ground-truth stature and girths");
      w.text(dir + "correspondence.csv", correspondence_csv(corr), "correspondence",
             "ground truth: each subject vertex as a template triangle + barycentric coordinates");
      {
        const Eigen::MatrixXd sj = joint_centres(model->rig, body);
        nlohmann::ordered_json jj;
        jj["units"] = "m";
        for (int j = 0; j < kNumJoints; ++j) jj["joints"][joint_name(j)] = vec(sj.row(j).transpose());
        w.text(dir + "joints.json", jj.dump(2) + "\n", "joints", "ground truth: the rig's 15 joint centres of subject " + s.id);
      }
      nlohmann::ordered_json posed = nlohmann::ordered_json::array();
      std::vector<std::pair<std::string, TriangleMesh>> scanned = {{"rest", rest_mesh}};
      for (const auto& pose_name : subject_poses) {
        const char* pname = pose_name.c_str();
        const auto it = std::find_if(poses.begin(), poses.end(), [&](const NamedPose& p) { return p.name == pose_name; });
        if (it == poses.end()) throw InvalidInput("pose set lacks the subject test pose " + pose_name);
        TriangleMesh pm;
        const Eigen::MatrixXd posed_template = pose_body(*model, body, it->pose, anatomy);
        pm.V = evaluate_smooth_surface_points(posed_template, body.mesh.F, vertex_normals(posed_template, body.mesh.F), corr);
        pm.F = rest_mesh.F;
        w.mesh(dir + "posed/" + pname + ".ply", pm, "posed subject", "subject " + s.id + " posed by the rig in '" + pname + "'");
        w.text(dir + "posed/" + pname + ".json", pose_json(*it), "pose", "16-part pose of '" + std::string(pname) + "'");
        posed.push_back({{"pose", pname}, {"mesh", dir + "posed/" + pname + ".ply"}, {"pose_json", dir + "posed/" + pname + ".json"}});
        if (std::find(std::begin(kSubjectTestPoses), std::end(kSubjectTestPoses), pose_name) != std::end(kSubjectTestPoses))
          scanned.emplace_back(pname, pm);
      }
      const nlohmann::ordered_json scans = write_scans(w, o, s.id, si, scanned, &summary);
      write_photos(w, s.id, rest_mesh, &summary);
      subjects.push_back({{"id", s.id},
                          {"gender", s.female ? "female" : "male"},
                          {"bmi", st.bmi},
                          {"bmi_class", bmi_class_name(bmi_class_of(st.bmi))},
                          {"target_bmi", s.target_bmi},
                          {"stature_m", st.stature_m},
                          {"mass_kg", st.mass_kg},
                          {"spec", dir + "spec.json"},
                          {"rest", dir + "rest.ply"},
                          {"vertices", rest_mesh.num_vertices()},
                          {"triangles", rest_mesh.num_faces()},
                          {"measurements", dir + "measurements.json"},
                          {"correspondence", dir + "correspondence.csv"},
                          {"joints", dir + "joints.json"},
                          {"posed", posed},
                          {"scans", scans},
                          {"photos",
                           {{"front", "photos/" + s.id + "/front.png"},
                            {"side", "photos/" + s.id + "/side.png"},
                            {"front_mask", "photos/" + s.id + "/front_mask.png"},
                            {"side_mask", "photos/" + s.id + "/side_mask.png"},
                            {"camera", "photos/" + s.id + "/camera.json"}}}});
      ++summary.subjects;
      if (o.progress) o.progress(++step, total_steps, "subject " + s.id);
    }
    manifest["subjects"] = subjects;
    manifest["files"] = w.files();
    summary.files = static_cast<long>(w.files().size()) + 1;
    const std::string text = manifest.dump(2) + "\n";
    write_file_atomically((tmp / "manifest.json").string(), [&](std::ostream& os) { os << text; }, false);
  });
  summary.seconds = t0.seconds();
  return summary;
}

DatasetSummary make_people_set(const std::string& out_dir, const PeopleSetOptions& o) {
  if (o.people < 2) throw InvalidInput("people set: at least two people are needed (each is posed by a model of the others)");
  if (o.natural_rest < 0 || o.natural_rest > o.people)
    throw InvalidInput("people set: " + std::to_string(o.natural_rest) + " people in a natural rest, of " + std::to_string(o.people));
  const Stopwatch t0;
  DatasetSummary summary;
  write_folder_atomically(out_dir, o.force, [&](const std::string& tmp) {
    const auto model = load_makehuman_model(o.data_root);
    const std::optional<AnatomicalDriving> anatomy = anatomical_driving_by_name(o.driving, "people set");
    const auto specs = make_subject_specs(*model, o.seed, std::max(o.people, 2));
    DatasetWriter w(tmp);
    nlohmann::ordered_json people = nlohmann::ordered_json::array();
    int step = 0;
    for (int i = 0; i < o.people; ++i) {
      const SubjectSpec& s = specs[static_cast<size_t>(i)];
      const Body body = build_body(*model, s.spec);
      const Eigen::MatrixXd joints = joint_centres(model->rig, body);
      const bool natural = i >= o.people - o.natural_rest;
      const PartPose rest = natural ? natural_rest_pose(joints) : PartPose{};
      std::vector<NamedPose> poses = standard_pose_set(joints, o.seed, o.small ? 4 : 10, o.small);
      poses.insert(poses.begin(), NamedPose{"rest", PartPose{}, false});
      for (const NamedPose& p : poses) {
        TriangleMesh m;
        m.V = pose_body(*model, body, natural ? pose_from_rest(p.pose, rest) : p.pose, anatomy);
        m.F = body.mesh.F;
        w.mesh(s.id + "/" + p.name + ".ply", m, "pose example", s.id + " in pose '" + p.name + "'");
        if (p.name != "rest")
          w.text(s.id + "/" + p.name + ".json", pose_json(p), "pose", "16-part pose of '" + p.name + "' from " + s.id + "'s rest");
      }
      const BodyStats st = body_stats(body.mesh);
      people.push_back({{"id", s.id},
                        {"gender", s.female ? "female" : "male"},
                        {"bmi", st.bmi},
                        {"stature_m", st.stature_m},
                        {"rest", natural ? "natural: arms 25 degrees closer, elbows bent 25 degrees" : "the template's A-pose"},
                        {"rest_pose", nlohmann::ordered_json::parse(part_pose_to_json(rest))},
                        {"spec", nlohmann::ordered_json::parse(body_spec_to_json(s.spec))},
                        {"meshes", poses.size()}});
      summary.poses = static_cast<int>(poses.size());
      ++summary.subjects;
      if (o.progress) o.progress(++step, o.people, "person " + s.id);
    }
    nlohmann::ordered_json manifest;
    manifest["format"] = "posekit people set 1";
    manifest["generator"] = {{"seed", o.seed},
                             {"small", o.small},
                             {"source", "MakeHuman CC0 assets (data root)"},
                             {"driving", o.driving},
                             {"use", "posekit eval pose --dataset <this folder> --people"}};
    manifest["units"] = {{"meshes", "m"}, {"angles", "radians"}};
    manifest["people"] = people;
    summary.files = static_cast<long>(w.files().size()) + 1;
    write_file_atomically(
        tmp + "/manifest.json", [&](std::ostream& os) { os << manifest.dump(2) << "\n"; }, false);
  });
  summary.seconds = t0.seconds();
  return summary;
}

TriangleMesh load_subject_mesh(const std::string& path, Unit unit) {
  TriangleMesh m = read_mesh(path, {unit});
  m.vertex_scalars.clear();
  return m;
}

SurfacePoints load_correspondence(const std::string& path) {
  const std::string text = read_file_bytes(path);
  std::vector<int> face;
  std::vector<double> bary;
  std::istringstream in(text);
  std::string line;
  long line_no = 0;
  while (std::getline(in, line)) {
    ++line_no;
    if (line.empty() || line[0] == '#' || line.rfind("subject_vertex", 0) == 0) continue;
    std::istringstream cells(line);
    std::string cell;
    std::vector<double> values;
    while (std::getline(cells, cell, ',')) {
      try {
        values.push_back(std::stod(cell));
      } catch (const std::exception&) {
        throw IoError(path + ":" + std::to_string(line_no) + ": expected numbers 'vertex,triangle,b0,b1,b2'");
      }
    }
    if (values.size() != 5 || values[0] != static_cast<double>(face.size()))
      throw IoError(path + ":" + std::to_string(line_no) + ": expected 'vertex,triangle,b0,b1,b2' with vertices in order");
    face.push_back(static_cast<int>(values[1]));
    bary.insert(bary.end(), {values[2], values[3], values[4]});
  }
  if (face.empty()) throw IoError(path + ": no correspondence rows");
  SurfacePoints s;
  s.face = Eigen::Map<Eigen::VectorXi>(face.data(), static_cast<Eigen::Index>(face.size()));
  s.bary = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(bary.data(), static_cast<Eigen::Index>(face.size()), 3);
  s.distance = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(face.size()));
  return s;
}

PointCloud load_scan(const std::string& path, Unit unit) { return read_point_cloud(path, {unit}); }

}  // namespace posekit
