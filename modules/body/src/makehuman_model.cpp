#include "posekit/body/makehuman_model.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <functional>
#include <nlohmann/json.hpp>
#include <set>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"

namespace posekit {
namespace fs = std::filesystem;

namespace {

constexpr double kDecimetre = 0.1;

/// A .target file: '#' comments, then "index dx dy dz" lines (decimetres).
MorphTarget read_target(const std::string& path, int num_vertices) {
  const std::string text = read_file_bytes(path);
  MorphTarget t;
  std::vector<double> d;
  size_t pos = 0;
  long line_no = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    const char* p = text.data() + pos;
    const char* e = text.data() + end;
    pos = end + 1;
    ++line_no;
    while (p < e && (*p == ' ' || *p == '\t')) ++p;
    if (p == e || *p == '#' || *p == '\r') continue;
    int index = 0;
    auto r = std::from_chars(p, e, index);
    double xyz[3];
    bool ok = r.ec == std::errc();
    p = r.ptr;
    for (int k = 0; k < 3 && ok; ++k) {
      while (p < e && (*p == ' ' || *p == '\t')) ++p;
      auto rr = std::from_chars(p, e, xyz[k]);
      ok = rr.ec == std::errc() && std::isfinite(xyz[k]);
      p = rr.ptr;
    }
    if (!ok) throw IoError(path + ":" + std::to_string(line_no) + ": expected 'index dx dy dz'");
    if (index < 0 || index >= num_vertices)
      throw IoError(path + ":" + std::to_string(line_no) + ": vertex index " + std::to_string(index) + " outside 0.." +
                    std::to_string(num_vertices - 1));
    t.index.push_back(index);
    d.insert(d.end(), {xyz[0] * kDecimetre, xyz[1] * kDecimetre, xyz[2] * kDecimetre});
  }
  t.delta = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(d.data(), static_cast<Eigen::Index>(t.index.size()), 3);
  return t;
}

void add_target(Eigen::MatrixXd& V, const MorphTarget& t, double w) {
  if (w == 0.0) return;
  for (size_t i = 0; i < t.index.size(); ++i) V.row(t.index[i]) += w * t.delta.row(static_cast<Eigen::Index>(i));
}

Rig read_rig(const std::string& path, int num_vertices) {
  const nlohmann::json j = read_json_file(path);
  if (!j.contains("bones") || !j.contains("joints")) throw IoError(path + ": expected 'bones' and 'joints' (a MakeHuman .mhskel)");
  const auto& bones = j["bones"];
  const auto& joints = j["joints"];
  std::map<std::string, std::vector<std::string>> children;
  std::string root;
  for (auto it = bones.begin(); it != bones.end(); ++it) {
    const auto& parent = (*it)["parent"];
    if (parent.is_null()) {
      if (!root.empty()) throw IoError(path + ": two root bones ('" + root + "', '" + it.key() + "')");
      root = it.key();
    } else {
      children[parent.get<std::string>()].push_back(it.key());
    }
  }
  if (root.empty()) throw IoError(path + ": no root bone (a bone with parent null)");
  Rig rig;
  auto joint_vertices = [&](const std::string& bone, const char* end) {
    const std::string name = bones[bone][end].get<std::string>();
    if (!joints.contains(name)) throw IoError(path + ": bone '" + bone + "' names unknown joint '" + name + "'");
    std::vector<int> v = joints[name].get<std::vector<int>>();
    if (v.empty()) throw IoError(path + ": joint '" + name + "' has no vertices");
    for (int x : v)
      if (x < 0 || x >= num_vertices) throw IoError(path + ": joint '" + name + "' has vertex " + std::to_string(x) + " outside base.obj");
    return v;
  };
  std::function<void(const std::string&, int)> visit = [&](const std::string& name, int parent) {
    const int index = rig.num_bones();
    rig.bone_names.push_back(name);
    rig.parent.push_back(parent);
    rig.head_vertices.push_back(joint_vertices(name, "head"));
    rig.tail_vertices.push_back(joint_vertices(name, "tail"));
    std::vector<std::vector<int>> plane;
    const auto& bone = bones[name];
    if (bone.contains("rotation_plane") && bone["rotation_plane"].is_string() && j.contains("planes")) {
      const std::string plane_name = bone["rotation_plane"].get<std::string>();
      if (j["planes"].contains(plane_name)) {
        for (const auto& joint : j["planes"][plane_name]) {
          const std::string jn = joint.get<std::string>();
          if (!joints.contains(jn)) throw IoError(path + ": plane '" + plane_name + "' names unknown joint '" + jn + "'");
          plane.push_back(joints[jn].get<std::vector<int>>());
        }
        if (plane.size() != 3) throw IoError(path + ": plane '" + plane_name + "' must name 3 joints");
      }
    }
    rig.plane_vertices.push_back(std::move(plane));
    for (const auto& c : children[name]) visit(c, index);
  };
  visit(root, -1);
  if (rig.num_bones() != static_cast<int>(bones.size()))
    throw IoError(path + ": " + std::to_string(bones.size() - rig.num_bones()) + " bones are not connected to the root");
  return rig;
}

}  // namespace

int Rig::find_bone(const std::string& name) const {
  for (int b = 0; b < num_bones(); ++b)
    if (bone_names[b] == name) return b;
  return -1;
}

const MakeHumanModel::Modifier* MakeHumanModel::find_modifier(const std::string& name) const {
  for (const auto& m : modifiers)
    if (m.name == name) return &m;
  return nullptr;
}

namespace {

/// The macro and modifier targets of a data root into `model`.
void load_targets(const fs::path& root, int nv, MakeHumanModel* model) {
  // Macro targets: the variant names in the file name multiply to the target's weight.
  const fs::path macro_dir = root / "targets" / "macrodetails";
  if (!fs::is_directory(macro_dir)) throw IoError(macro_dir.string() + ": missing (MakeHuman macro targets expected)");
  std::vector<fs::path> macro_files;
  for (const auto& e : fs::recursive_directory_iterator(macro_dir))
    if (e.path().extension() == ".target") macro_files.push_back(e.path());
  std::sort(macro_files.begin(), macro_files.end());
  // Every slider combination needs its target: a missing one would silently give a wrong body.
  for (const char* gender : {"female", "male"}) {
    std::vector<fs::path> required = {macro_dir / (std::string("african-") + gender + "-young.target"),
                                      macro_dir / (std::string("asian-") + gender + "-young.target"),
                                      macro_dir / (std::string("caucasian-") + gender + "-young.target")};
    for (const char* muscle : {"minmuscle", "averagemuscle", "maxmuscle"})
      for (const char* weight : {"minweight", "averageweight", "maxweight"}) {
        const std::string stem = std::string(gender) + "-young-" + muscle + "-" + weight;
        required.push_back(macro_dir / ("universal-" + stem + ".target"));
        for (const char* h : {"minheight", "maxheight"}) required.push_back(macro_dir / "height" / (stem + "-" + h + ".target"));
        for (const char* p : {"uncommonproportions", "idealproportions"})
          required.push_back(macro_dir / "proportions" / (stem + "-" + p + ".target"));
      }
    for (const auto& r : required)
      if (!fs::is_regular_file(r))
        throw IoError(r.string() +
                      ": missing macro target (every gender/muscle/weight/height/proportions combination "
                      "of the MakeHuman macro model is needed)");
  }
  for (const auto& p : macro_files) {
    MakeHumanModel::MacroTarget mt;
    mt.name = fs::relative(p, root / "targets").string();
    std::string stem = p.stem().string();
    size_t start = 0;
    while (start <= stem.size()) {
      const size_t dash = stem.find('-', start);
      const std::string token = stem.substr(start, dash == std::string::npos ? std::string::npos : dash - start);
      if (token != "universal") mt.variants.push_back(token);
      if (dash == std::string::npos) break;
      start = dash + 1;
    }
    mt.target = read_target(p.string(), nv);
    model->macro_targets.push_back(std::move(mt));
  }

  // Local modifiers from the modifier definitions, for the groups whose targets are present.
  std::set<std::string> used_files;
  auto target_index = [&](const fs::path& p) {
    used_files.insert(p.string());
    model->modifier_targets.push_back(read_target(p.string(), nv));
    return static_cast<int>(model->modifier_targets.size()) - 1;
  };
  for (const char* file : {"modeling_modifiers.json", "measurement_modifiers.json"}) {
    const std::string path = (root / "modifiers" / file).string();
    const nlohmann::json groups = read_json_file(path);
    for (const auto& g : groups) {
      const std::string group = g.value("group", "");
      for (const auto& m : g.value("modifiers", nlohmann::json::array())) {
        if (!m.contains("target")) continue;  // macro variables, handled by the sliders
        const std::string target = m["target"].get<std::string>();
        const fs::path dir = root / "targets" / group;
        MakeHumanModel::Modifier mod;
        if (m.contains("min") && m.contains("max")) {
          const fs::path lo = dir / (target + "-" + m["min"].get<std::string>() + ".target");
          const fs::path hi = dir / (target + "-" + m["max"].get<std::string>() + ".target");
          if (!fs::exists(lo) || !fs::exists(hi)) continue;
          mod.name = group + "/" + target + "-" + m["min"].get<std::string>() + "|" + m["max"].get<std::string>();
          mod.two_sided = true;
          mod.negative = target_index(lo);
          mod.positive = target_index(hi);
        } else {
          const fs::path one = dir / (target + ".target");
          if (!fs::exists(one)) continue;
          mod.name = group + "/" + target;
          mod.positive = target_index(one);
        }
        model->modifiers.push_back(std::move(mod));
      }
    }
  }
  // Target files of the local groups that no definition names become one-sided modifiers.
  for (const char* group : {"measure", "torso", "hip", "stomach", "buttocks", "bodyshapes"}) {
    const fs::path dir = root / "targets" / group;
    if (!fs::is_directory(dir)) continue;
    std::vector<fs::path> files;
    for (const auto& e : fs::directory_iterator(dir))
      if (e.path().extension() == ".target" && !used_files.count(e.path().string())) files.push_back(e.path());
    std::sort(files.begin(), files.end());
    for (const auto& p : files) {
      MakeHumanModel::Modifier mod;
      mod.name = std::string(group) + "/" + p.stem().string();
      mod.positive = target_index(p);
      model->modifiers.push_back(std::move(mod));
    }
  }
}

}  // namespace

std::shared_ptr<const MakeHumanModel> load_makehuman_model(const std::string& data_root, MakeHumanParts parts) {
  auto model = std::make_shared<MakeHumanModel>();
  model->data_root = data_root;
  const fs::path root(data_root);
  const std::string base_path = (root / "3dobjs" / "base.obj").string();
  const TriangleMesh base = read_mesh(base_path, {Unit::kDecimetre});
  model->base_V = base.V;
  const TriangleMesh body = [&] {
    std::vector<bool> keep(base.num_faces());
    int group = -1;
    for (size_t g = 0; g < base.group_names.size(); ++g)
      if (base.group_names[g] == "body") group = static_cast<int>(g);
    if (group < 0) throw IoError(base_path + ": no group 'body' (the MakeHuman skin)");
    TriangleMesh m;
    std::vector<int> rows;
    for (Eigen::Index f = 0; f < base.num_faces(); ++f)
      if (base.face_group[f] == group) rows.push_back(static_cast<int>(f));
    m.F.resize(static_cast<Eigen::Index>(rows.size()), 3);
    for (size_t i = 0; i < rows.size(); ++i) m.F.row(i) = base.F.row(rows[i]);
    return m;
  }();
  model->body_F = body.F;
  model->num_body_vertices = body.F.maxCoeff() + 1;
  {
    std::vector<bool> used(model->num_body_vertices, false);
    for (Eigen::Index i = 0; i < body.F.size(); ++i) used[body.F.data()[i]] = true;
    if (std::find(used.begin(), used.end(), false) != used.end())
      throw IoError(base_path + ": the 'body' group does not use vertices 1.." + std::to_string(model->num_body_vertices) +
                    " contiguously, as the MakeHuman skin does");
  }
  const int nv = static_cast<int>(model->base_V.rows());
  if (parts == MakeHumanParts::kAll) load_targets(root, nv, model.get());

  model->rig = read_rig((root / "rigs" / "default.mhskel").string(), nv);
  const std::string weights_path = (root / "rigs" / "default_weights.mhw").string();
  const nlohmann::json wj = read_json_file(weights_path);
  if (!wj.contains("weights")) throw IoError(weights_path + ": expected 'weights' (a MakeHuman .mhw)");
  std::vector<Eigen::Triplet<double>> triplets;
  for (auto it = wj["weights"].begin(); it != wj["weights"].end(); ++it) {
    const int bone = model->rig.find_bone(it.key());
    if (bone < 0) throw IoError(weights_path + ": weights for bone '" + it.key() + "', which the rig does not have");
    for (const auto& pair : *it) {
      const int v = pair.at(0).get<int>();
      const double w = pair.at(1).get<double>();
      if (v < 0 || v >= nv || !std::isfinite(w))
        throw IoError(weights_path + ": bad entry for bone '" + it.key() + "' (vertex " + std::to_string(v) + ")");
      if (v < model->num_body_vertices && w > 0) triplets.emplace_back(v, bone, w);
    }
  }
  model->weights.resize(model->num_body_vertices, model->rig.num_bones());
  model->weights.setFromTriplets(triplets.begin(), triplets.end());
  for (int v = 0; v < model->num_body_vertices; ++v) {
    const double sum = model->weights.row(v).sum();
    if (sum <= 0) throw IoError(weights_path + ": skin vertex " + std::to_string(v) + " has no skinning weight");
    model->weights.row(v) /= sum;
  }
  return model;
}

double macro_target_weight(const std::vector<std::string>& variants, const BodySpec& s) {
  auto three_way = [](double x, const std::string& lo, const std::string& mid, const std::string& hi, const std::string& v, double* out) {
    const double wlo = std::max(0.0, 1 - 2 * x), whi = std::max(0.0, 2 * x - 1);
    if (v == lo) return *out = wlo, true;
    if (v == hi) return *out = whi, true;
    if (v == mid) return *out = 1 - wlo - whi, true;
    return false;
  };
  const double ethnic_sum = s.african + s.asian + s.caucasian;
  double w = 1.0;
  for (const std::string& v : variants) {
    double f = 0;
    if (v == "female") f = 1 - s.gender;
    else if (v == "male") f = s.gender;
    else if (v == "young") f = 1.0;  // only young adults are in the assets (age 0.5)
    else if (v == "african") f = s.african / ethnic_sum;
    else if (v == "asian") f = s.asian / ethnic_sum;
    else if (v == "caucasian") f = s.caucasian / ethnic_sum;
    else if (three_way(s.muscle, "minmuscle", "averagemuscle", "maxmuscle", v, &f)) {
    } else if (three_way(s.weight, "minweight", "averageweight", "maxweight", v, &f)) {
    } else if (v == "minheight") f = std::max(0.0, 1 - 2 * s.height);
    else if (v == "maxheight") f = std::max(0.0, 2 * s.height - 1);
    else if (v == "uncommonproportions") f = std::max(0.0, 1 - 2 * s.proportions);
    else if (v == "idealproportions") f = std::max(0.0, 2 * s.proportions - 1);
    else f = 0.0;  // a variant this model does not know (e.g. another age) contributes nothing
    w *= f;
    if (w == 0) break;
  }
  return w;
}

Eigen::MatrixXd shaped_base_vertices(const MakeHumanModel& model, const BodySpec& spec) {
  Eigen::MatrixXd V = model.base_V;
  for (const auto& mt : model.macro_targets) add_target(V, mt.target, macro_target_weight(mt.variants, spec));
  for (const auto& [name, value] : spec.modifiers) {
    const auto* mod = model.find_modifier(name);
    if (!mod) throw InvalidInput("body spec: unknown modifier '" + name + "' (see 'posekit body --list-modifiers')");
    if (!std::isfinite(value) || value > 1 || value < (mod->two_sided ? -1 : 0))
      throw InvalidInput("body spec: modifier '" + name + "' = " + std::to_string(value) + " outside " +
                         (mod->two_sided ? "[-1, 1]" : "[0, 1]"));
    if (value < 0) add_target(V, model.modifier_targets[mod->negative], -value);
    if (value > 0) add_target(V, model.modifier_targets[mod->positive], value);
  }
  return V;
}

Body build_body(const MakeHumanModel& model, const BodySpec& spec) {
  const Eigen::MatrixXd V = shaped_base_vertices(model, spec);
  Body body;
  const Rig& rig = model.rig;
  body.bone_heads.resize(rig.num_bones(), 3);
  body.bone_tails.resize(rig.num_bones(), 3);
  auto mean = [&](const std::vector<int>& idx) {
    Eigen::RowVector3d m = Eigen::RowVector3d::Zero();
    for (int i : idx) m += V.row(i);
    return Eigen::RowVector3d(m / static_cast<double>(idx.size()));
  };
  for (int b = 0; b < rig.num_bones(); ++b) {
    body.bone_heads.row(b) = mean(rig.head_vertices[b]);
    body.bone_tails.row(b) = mean(rig.tail_vertices[b]);
  }
  body.bone_frames.resize(rig.num_bones());
  for (int b = 0; b < rig.num_bones(); ++b) {
    const Eigen::Vector3d y = (body.bone_tails.row(b) - body.bone_heads.row(b)).transpose().normalized();
    Eigen::Vector3d z = Eigen::Vector3d::Zero();
    if (!rig.plane_vertices[b].empty()) {
      const Eigen::Vector3d p0 = mean(rig.plane_vertices[b][0]).transpose(), p1 = mean(rig.plane_vertices[b][1]).transpose(),
                            p2 = mean(rig.plane_vertices[b][2]).transpose();
      z = (p2 - p1).cross(p1 - p0);
    }
    z -= z.dot(y) * y;
    if (z.norm() < 1e-9) z = y.unitOrthogonal();  // no plane, or a degenerate one
    z.normalize();
    body.bone_frames[b].col(0) = y.cross(z);
    body.bone_frames[b].col(1) = y;
    body.bone_frames[b].col(2) = z;
  }
  body.mesh.V = V.topRows(model.num_body_vertices);
  body.mesh.F = model.body_F;
  return body;
}

}  // namespace posekit
