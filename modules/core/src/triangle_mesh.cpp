#include "posekit/core/triangle_mesh.h"

#include "posekit/core/error.h"

namespace posekit {

TriangleMesh extract_faces(const TriangleMesh& mesh, const std::vector<bool>& keep_face, std::vector<int>* vertex_map) {
  if (static_cast<Eigen::Index>(keep_face.size()) != mesh.num_faces())
    throw InvalidInput("extract_faces: keep_face has " + std::to_string(keep_face.size()) + " entries, expected one per face (" +
                       std::to_string(mesh.num_faces()) + ")");
  std::vector<int> new_index(mesh.num_vertices(), -1);
  std::vector<int> old_index;
  Eigen::Index kept = 0;
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    if (!keep_face[f]) continue;
    ++kept;
    for (int c = 0; c < 3; ++c) {
      const int v = mesh.F(f, c);
      if (v < 0 || v >= mesh.num_vertices())
        throw InvalidInput("extract_faces: face " + std::to_string(f) + " has vertex index " + std::to_string(v) + " outside [0, " +
                           std::to_string(mesh.num_vertices()) + ")");
      if (new_index[v] < 0) {
        new_index[v] = static_cast<int>(old_index.size());
        old_index.push_back(v);
      }
    }
  }
  TriangleMesh out;
  const Eigen::Index nv = static_cast<Eigen::Index>(old_index.size());
  out.V.resize(nv, 3);
  if (mesh.has_normals()) out.N.resize(nv, 3);
  if (mesh.has_colors()) out.C.resize(nv, 3);
  if (mesh.has_uv()) out.UV.resize(nv, 2);
  for (const auto& [name, values] : mesh.vertex_scalars) out.vertex_scalars[name].resize(nv);
  for (Eigen::Index i = 0; i < nv; ++i) {
    const int v = old_index[i];
    out.V.row(i) = mesh.V.row(v);
    if (mesh.has_normals()) out.N.row(i) = mesh.N.row(v);
    if (mesh.has_colors()) out.C.row(i) = mesh.C.row(v);
    if (mesh.has_uv()) out.UV.row(i) = mesh.UV.row(v);
    for (const auto& [name, values] : mesh.vertex_scalars) out.vertex_scalars[name][i] = values[v];
  }
  out.F.resize(kept, 3);
  const bool grouped = mesh.face_group.size() == mesh.num_faces() && mesh.num_faces() > 0;
  if (grouped) {
    out.face_group.resize(kept);
    out.group_names = mesh.group_names;
  }
  for (const auto& [name, values] : mesh.face_scalars)
    if (values.size() == mesh.num_faces()) out.face_scalars[name].resize(kept);
  Eigen::Index row = 0;
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) {
    if (!keep_face[f]) continue;
    for (int c = 0; c < 3; ++c) out.F(row, c) = new_index[mesh.F(f, c)];
    if (grouped) out.face_group[row] = mesh.face_group[f];
    for (auto& [name, values] : out.face_scalars) values[row] = mesh.face_scalars.at(name)[f];
    ++row;
  }
  if (vertex_map) *vertex_map = std::move(old_index);
  return out;
}

TriangleMesh extract_group(const TriangleMesh& mesh, const std::string& group, std::vector<int>* vertex_map) {
  int group_index = -1;
  for (size_t g = 0; g < mesh.group_names.size(); ++g)
    if (mesh.group_names[g] == group) group_index = static_cast<int>(g);
  if (group_index < 0 || mesh.face_group.size() != mesh.num_faces())
    throw InvalidInput("extract_group: the mesh has no face group named '" + group + "'");
  std::vector<bool> keep(mesh.num_faces());
  for (Eigen::Index f = 0; f < mesh.num_faces(); ++f) keep[f] = mesh.face_group[f] == group_index;
  TriangleMesh out = extract_faces(mesh, keep, vertex_map);
  out.face_group.resize(0);
  out.group_names.clear();
  return out;
}

}  // namespace posekit
