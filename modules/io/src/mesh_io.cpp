#include "posekit/io/mesh_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <map>
#include <unordered_map>

#include "gltf_format.h"
#include "parse_util.h"
#include "ply_format.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/io/atomic_file.h"
#include "text_mesh_formats.h"

namespace posekit {
namespace io_detail {
std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char ch) { return std::tolower(ch); });
  return ext;
}
}  // namespace io_detail

using namespace io_detail;

namespace {

// ---------------------------------------------------------------- OBJ
/// Resolves a 1-based (or negative, relative) OBJ index against `count` items defined so far.
long long obj_index(const LineScanner& lines, std::string_view token, long long count, const char* what) {
  long long idx = lines.to_int(token, what);
  if (idx < 0) idx = count + idx + 1;  // relative index
  if (idx < 1 || idx > count)
    lines.fail(std::string(what) + " " + std::string(token) + " out of range 1.." + std::to_string(count) + " (defined so far)");
  return idx - 1;
}

/// Normals of an OBJ file as posekit keeps them, one per vertex: the one the faces' `v//vn` indices
/// give it. A vertex whose corners name different normals (hard edges, flat shading) cannot keep one:
/// the normals are then dropped with a warning, as texture seams are. Files whose faces name no
/// normal but that have one `vn` per `v` pair them by order, with a warning.
void read_obj_normals(const std::string& path, const std::vector<double>& vn, const std::vector<long long>& vertex_vn,
                      long long corners_with_vn, long long corners_without_vn, long long splits, std::vector<std::string>* warnings,
                      TriangleMesh* mesh) {
  const Eigen::Index nv = static_cast<Eigen::Index>(vertex_vn.size());
  if (vn.empty()) return;
  if (corners_with_vn == 0) {
    if (static_cast<Eigen::Index>(vn.size() / 3) == nv) {
      mesh->N = Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(vn.data(), nv, 3);
      warn(warnings, path + ": the faces name no normal ('f v//vn'): the " + std::to_string(nv) +
                         " 'vn' lines were paired with the vertices by order");
    } else {
      warn(warnings, path + ": normals not kept: the faces name none and there are " + std::to_string(vn.size() / 3) + " 'vn' lines for " +
                         std::to_string(nv) + " vertices");
    }
    return;
  }
  if (splits > 0) {
    warn(warnings, path + ": normals not kept: " + std::to_string(splits) +
                       " face corners give a vertex another normal than its first (hard edges or flat shading; posekit "
                       "keeps one normal per vertex)");
    return;
  }
  if (corners_without_vn > 0 || std::any_of(vertex_vn.begin(), vertex_vn.end(), [](long long n) { return n < 0; })) {
    warn(warnings, path + ": normals not kept: some vertices or face corners have none");
    return;
  }
  mesh->N.resize(nv, 3);
  for (Eigen::Index i = 0; i < nv; ++i)
    for (int k = 0; k < 3; ++k) mesh->N(i, k) = vn[3 * static_cast<size_t>(vertex_vn[static_cast<size_t>(i)]) + k];
}

}  // namespace

namespace io_detail {

TriangleMesh read_obj(const std::string& path, double scale, std::vector<std::string>* warnings) {
  const std::string bytes = read_file_bytes(path);
  if (bytes.find('\0') != std::string::npos) throw IoError(path + ": contains NUL bytes: expected a text OBJ file");
  LineScanner lines(bytes, path);
  std::vector<double> v, vc, vn, vt;
  std::vector<int> tris, groups;
  std::vector<long long> vertex_vt;  // the vt each vertex uses, -1 none yet
  long long vt_seams = 0, corners_without_vt = 0;
  std::vector<long long> vertex_vn;  // the vn each vertex's corners name, -1 none yet
  long long vn_splits = 0, corners_with_vn = 0, corners_without_vn = 0, vertices_with_colour = 0, vn_without_lines = 0;
  std::vector<std::string> group_names;
  std::map<std::string, int> group_index;
  int current_group = -1;
  std::string_view line;
  std::string joined;
  std::vector<std::string_view> tok;
  std::vector<int> poly;
  while (lines.next(line)) {
    // A backslash at the end of a line continues the statement on the next line.
    if (!line.empty() && line.back() == '\\') {
      joined.assign(line.substr(0, line.size() - 1));
      std::string_view more;
      while (lines.next(more)) {
        const bool again = !more.empty() && more.back() == '\\';
        joined += ' ';
        joined.append(more.substr(0, more.size() - (again ? 1 : 0)));
        if (!again) break;
      }
      line = joined;
    }
    if (line.empty() || line[0] == '#') continue;
    split(line, tok);
    if (tok.empty()) continue;
    const std::string_view key = tok[0];
    if (key == "v") {
      if (tok.size() != 4 && tok.size() != 5 && tok.size() != 7) lines.fail("expected 'v x y z [w]' or 'v x y z r g b'");
      for (int k = 1; k <= 3; ++k) {
        const double x = lines.to_double(tok[k], "a vertex coordinate");
        if (!std::isfinite(x)) lines.fail("non-finite vertex coordinate '" + printable(tok[k]) + "'");
        v.push_back(x * scale);
      }
      if (tok.size() == 7) {
        // Colours stay in step with the vertices: one without gets a placeholder (dropped below).
        vc.resize(3 * (v.size() / 3 - 1), 0.0);
        for (int k = 4; k <= 6; ++k) vc.push_back(lines.to_double(tok[k], "a vertex colour"));
        ++vertices_with_colour;
      }
      vertex_vt.push_back(-1);
      vertex_vn.push_back(-1);
    } else if (key == "vn") {
      if (tok.size() != 4) lines.fail("expected 'vn x y z'");
      for (int k = 1; k <= 3; ++k) vn.push_back(lines.to_double(tok[k], "a normal component"));
    } else if (key == "vt") {
      if (tok.size() < 2 || tok.size() > 4) lines.fail("expected 'vt u [v [w]]'");
      vt.push_back(lines.to_double(tok[1], "a texture coordinate"));
      vt.push_back(tok.size() > 2 ? lines.to_double(tok[2], "a texture coordinate") : 0.0);
    } else if (key == "f") {
      if (tok.size() < 4) lines.fail("a face needs at least 3 vertices");
      const long long nv = static_cast<long long>(v.size() / 3);
      const long long nt = static_cast<long long>(vt.size() / 2);
      const long long nn = static_cast<long long>(vn.size() / 3);
      poly.clear();
      for (size_t k = 1; k < tok.size(); ++k) {
        const std::string_view t = tok[k];
        const size_t slash = t.find('/');
        const long long idx = obj_index(lines, t.substr(0, slash), nv, "face vertex index");
        poly.push_back(static_cast<int>(idx));
        const std::string_view rest = slash == std::string_view::npos ? std::string_view() : t.substr(slash + 1);
        const size_t second_slash = rest.find('/');
        const std::string_view vt_token = rest.substr(0, second_slash);
        const std::string_view vn_token = second_slash == std::string_view::npos ? std::string_view() : rest.substr(second_slash + 1);
        if (vn_token.empty() || nn == 0) {  // a file without 'vn' lines: its faces' normal indices name nothing
          ++corners_without_vn;
          vn_without_lines += !vn_token.empty();
        } else {
          // v//vn: the normal belongs to this corner's vertex, whatever the order of the vn lines.
          ++corners_with_vn;
          const long long ni = obj_index(lines, vn_token, nn, "normal index");
          long long& used = vertex_vn[idx];
          if (used < 0) used = ni;
          else if (used != ni && (vn[3 * used] != vn[3 * ni] || vn[3 * used + 1] != vn[3 * ni + 1] || vn[3 * used + 2] != vn[3 * ni + 2]))
            ++vn_splits;
        }
        if (vt_token.empty()) {
          ++corners_without_vt;
          continue;
        }
        const long long ti = obj_index(lines, vt_token, nt, "texture coordinate index");
        long long& used = vertex_vt[idx];
        if (used < 0) used = ti;
        else if (used != ti && (vt[2 * used] != vt[2 * ti] || vt[2 * used + 1] != vt[2 * ti + 1])) ++vt_seams;
      }
      for (size_t k = 1; k + 1 < poly.size(); ++k) {
        tris.insert(tris.end(), {poly[0], poly[k], poly[k + 1]});
        groups.push_back(current_group);
      }
    } else if (key == "g") {
      std::string name = tok.size() > 1 ? std::string(tok[1]) : std::string("default");
      for (size_t k = 2; k < tok.size(); ++k) name += " " + std::string(tok[k]);
      auto [it, inserted] = group_index.emplace(name, static_cast<int>(group_names.size()));
      if (inserted) group_names.push_back(name);
      current_group = it->second;
    }
    // o, s, usemtl, mtllib, l, p and other statements carry nothing posekit uses.
  }
  TriangleMesh mesh;
  const Eigen::Index nv = static_cast<Eigen::Index>(v.size() / 3);
  if (nv == 0) throw IoError(path + ": no vertices ('v' lines) found: expected an OBJ mesh");
  mesh.V = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(v.data(), nv, 3);
  mesh.F = Eigen::Map<Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
  if (vn_without_lines > 0)
    warn(warnings,
         path + ": " + std::to_string(vn_without_lines) + " face corners name a normal ('v//vn') but the file has no 'vn' lines: ignored");
  read_obj_normals(path, vn, vertex_vn, corners_with_vn, corners_without_vn, vn_splits, warnings, &mesh);
  if (vertices_with_colour > 0 && vertices_with_colour < nv)
    warn(warnings, path + ": vertex colours not kept: only " + std::to_string(vertices_with_colour) + " of " + std::to_string(nv) +
                       " vertices have one ('v x y z r g b')");
  if (vertices_with_colour == nv) {
    mesh.C.resize(nv, 3);
    for (Eigen::Index i = 0; i < nv; ++i)
      for (int k = 0; k < 3; ++k) mesh.C(i, k) = static_cast<std::uint8_t>(std::clamp(std::lround(vc[3 * i + k] * 255.0), 0L, 255L));
  }
  if (!vt.empty()) {
    const bool every_vertex = std::none_of(vertex_vt.begin(), vertex_vt.end(), [](long long t) { return t < 0; });
    if (vt_seams > 0)
      warn(warnings, path + ": texture coordinates not kept: " + std::to_string(vt_seams) +
                         " face corners give a vertex another texture coordinate than its first (UV seams; posekit "
                         "keeps one per vertex)");
    else if (!every_vertex || corners_without_vt > 0)
      warn(warnings, path + ": texture coordinates not kept: some vertices or face corners have none");
    else {
      mesh.UV.resize(nv, 2);
      for (Eigen::Index i = 0; i < nv; ++i) mesh.UV.row(i) << vt[2 * vertex_vt[i]], vt[2 * vertex_vt[i] + 1];
    }
  }
  if (!group_names.empty()) {
    // Faces before the first `g` belong to "default".
    if (std::find(groups.begin(), groups.end(), -1) != groups.end()) {
      auto [it, inserted] = group_index.emplace("default", static_cast<int>(group_names.size()));
      if (inserted) group_names.push_back("default");
      for (int& g : groups)
        if (g < 0) g = it->second;
    }
    mesh.face_group = Eigen::Map<Eigen::VectorXi>(groups.data(), static_cast<Eigen::Index>(groups.size()));
    mesh.group_names = group_names;
  }
  return mesh;
}

TriangleMesh read_off(const std::string& path, double scale) {
  const std::string bytes = read_file_bytes(path);
  LineScanner lines(bytes, path);
  std::string_view line;
  std::vector<std::string_view> tok;
  // Tokens of the next non-comment line, remembering line numbers through the scanner.
  auto next_tokens = [&](const char* what) {
    while (true) {
      if (!lines.next(line)) lines.fail(std::string("file ends early: expected ") + what);
      const size_t hash = line.find('#');
      split(hash == std::string_view::npos ? line : line.substr(0, hash), tok);
      if (!tok.empty()) return;
    }
  };
  next_tokens("the OFF header");
  // [ST][C][N][4][n]OFF (Geomview's OFF): texture, colour and normal columns on each vertex line.
  std::string_view head = tok[0];
  if (head.size() < 3 || head.substr(head.size() - 3) != "OFF" ||
      head.substr(0, head.size() - 3).find_first_not_of("STCN4n") != std::string_view::npos)
    lines.fail("expected the header 'OFF' (or COFF, NOFF, STOFF, ...), got '" + printable(head) + "'");
  const std::string_view prefix = head.substr(0, head.size() - 3);
  if (prefix.find('4') != std::string_view::npos || prefix.find('n') != std::string_view::npos)
    lines.fail("'" + printable(head) + "' is a 4-D or n-D OFF file: posekit reads 3-D meshes");
  const bool has_uv = prefix.find("ST") != std::string_view::npos;
  const bool has_color = prefix.find('C') != std::string_view::npos;
  const bool has_normal = prefix.find('N') != std::string_view::npos;
  std::vector<std::string_view> counts(tok.begin() + 1, tok.end());
  if (counts.empty()) {
    next_tokens("the counts line 'nv nf ne'");
    counts = tok;
  }
  if (counts.size() < 2) lines.fail("expected the counts 'nv nf [ne]'");
  const long long nv = lines.to_int(counts[0], "the vertex count");
  const long long nf = lines.to_int(counts[1], "the face count");
  if (nv <= 0 || nf < 0) lines.fail("implausible counts nv=" + std::to_string(nv) + " nf=" + std::to_string(nf));
  if (static_cast<size_t>(nv) > bytes.size() / 6 + 1 || static_cast<size_t>(nf) > bytes.size() / 8 + 1)
    lines.fail("the header claims " + std::to_string(nv) + " vertices and " + std::to_string(nf) + " faces, more than the file can hold");
  TriangleMesh mesh;
  mesh.V.resize(nv, 3);
  if (has_normal) mesh.N.resize(nv, 3);
  if (has_uv) mesh.UV.resize(nv, 2);
  Eigen::MatrixXd color(has_color ? nv : 0, 3);
  for (long long i = 0; i < nv; ++i) {
    next_tokens("a vertex line");
    // x y z [nx ny nz] [r g b [a]] [u v]
    const size_t need = 3 + (has_normal ? 3 : 0) + (has_color ? 3 : 0) + (has_uv ? 2 : 0);
    if (tok.size() < need)
      lines.fail("vertex " + std::to_string(i) + ": expected " + std::to_string(need) + " values for '" + printable(head) + "', got " +
                 std::to_string(tok.size()));
    size_t t = 0;
    for (int k = 0; k < 3; ++k) {
      const double x = lines.to_double(tok[t++], "a vertex coordinate");
      if (!std::isfinite(x)) lines.fail("vertex " + std::to_string(i) + " has a non-finite coordinate");
      mesh.V(i, k) = x * scale;
    }
    if (has_normal)
      for (int k = 0; k < 3; ++k) mesh.N(i, k) = lines.to_double(tok[t++], "a normal component");
    if (has_color) {
      for (int k = 0; k < 3; ++k) color(i, k) = lines.to_double(tok[t++], "a colour component");
      if (has_uv && tok.size() >= need + 1) ++t;  // alpha
    }
    if (has_uv)
      for (int k = 0; k < 2; ++k) mesh.UV(i, k) = lines.to_double(tok[t++], "a texture coordinate");
  }
  if (has_color) {
    // Geomview writes colours as 0..1 floats, most other tools as 0..255 integers.
    const double unit = color.size() > 0 && color.maxCoeff() > 1.0 ? 1.0 : 255.0;
    mesh.C.resize(nv, 3);
    for (Eigen::Index i = 0; i < nv; ++i)
      for (int k = 0; k < 3; ++k) mesh.C(i, k) = static_cast<std::uint8_t>(std::clamp(std::lround(color(i, k) * unit), 0L, 255L));
  }
  std::vector<int> tris;
  std::vector<int> poly;
  for (long long f = 0; f < nf; ++f) {
    next_tokens("a face line");
    const long long n = lines.to_int(tok[0], "the face vertex count");
    if (n < 3 || n > 1000000) lines.fail("face " + std::to_string(f) + ": expected 'n i1 .. in' with n >= 3");
    poly.clear();
    size_t t = 1;
    for (long long k = 0; k < n; ++k, ++t) {
      if (t >= tok.size()) {  // the indices go on on the next line
        next_tokens("the rest of a face's vertex indices");
        t = 0;
      }
      const long long idx = lines.to_int(tok[t], "a face vertex index");
      if (idx < 0 || idx >= nv)
        lines.fail("face " + std::to_string(f) + ": vertex index " + std::to_string(idx) + " out of range 0.." + std::to_string(nv - 1));
      poly.push_back(static_cast<int>(idx));
    }
    // Values after the indices are the face's colour, which posekit does not keep.
    for (size_t k = 1; k + 1 < poly.size(); ++k) tris.insert(tris.end(), {poly[0], poly[k], poly[k + 1]});
  }
  mesh.F = Eigen::Map<Eigen::Matrix<int, Eigen::Dynamic, 3, Eigen::RowMajor>>(tris.data(), static_cast<Eigen::Index>(tris.size() / 3), 3);
  return mesh;
}

void write_obj(const std::string& path, const TriangleMesh& mesh, double scale) {
  const bool uv = mesh.has_uv(), normals = mesh.has_normals();
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        out << "# written by posekit\n";
        for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
          out << 'v';
          for (int k = 0; k < 3; ++k) out << ' ', put_number(out, mesh.V(i, k), scale);
          if (mesh.has_colors())
            for (int k = 0; k < 3; ++k) out << ' ', put_number(out, mesh.C(i, k) / 255.0);
          out << '\n';
        }
        if (uv)
          for (Eigen::Index i = 0; i < mesh.UV.rows(); ++i) {
            out << "vt ";
            put_number(out, mesh.UV(i, 0));
            out << ' ';
            put_number(out, mesh.UV(i, 1));
            out << '\n';
          }
        if (normals)
          for (Eigen::Index i = 0; i < mesh.N.rows(); ++i) {
            out << "vn";
            for (int k = 0; k < 3; ++k) out << ' ', put_number(out, mesh.N(i, k));
            out << '\n';
          }
        const bool grouped = mesh.face_group.size() == mesh.F.rows() && !mesh.group_names.empty();
        int current = -1;
        for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
          if (grouped && mesh.face_group[f] != current) {
            current = mesh.face_group[f];
            out << "g " << mesh.group_names.at(current) << '\n';
          }
          out << 'f';
          for (int c = 0; c < 3; ++c) {
            const int i = mesh.F(f, c) + 1;
            out << ' ' << i;
            if (uv && normals) out << '/' << i << '/' << i;
            else if (uv) out << '/' << i;
            else if (normals) out << "//" << i;
          }
          out << '\n';
        }
      },
      false);
}

void write_off(const std::string& path, const TriangleMesh& mesh, double scale) {
  const bool colors = mesh.has_colors(), normals = mesh.has_normals();
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        out << (colors ? "C" : "") << (normals ? "N" : "") << "OFF\n" << mesh.V.rows() << ' ' << mesh.F.rows() << " 0\n";
        for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
          for (int k = 0; k < 3; ++k) {
            if (k) out << ' ';
            put_number(out, mesh.V(i, k), scale);
          }
          if (normals)
            for (int k = 0; k < 3; ++k) out << ' ', put_number(out, mesh.N(i, k));
          if (colors) out << ' ' << int(mesh.C(i, 0)) << ' ' << int(mesh.C(i, 1)) << ' ' << int(mesh.C(i, 2)) << " 255";
          out << '\n';
        }
        for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) out << "3 " << mesh.F(f, 0) << ' ' << mesh.F(f, 1) << ' ' << mesh.F(f, 2) << '\n';
      },
      false);
}

}  // namespace io_detail

namespace {

// ---------------------------------------------------------------- STL
/// Welds corners with bit-identical coordinates into shared vertices.
TriangleMesh weld(const std::vector<float>& corners, double scale) {
  struct Key {
    float x, y, z;
    bool operator==(const Key& o) const { return x == o.x && y == o.y && z == o.z; }
  };
  struct Hash {
    size_t operator()(const Key& k) const {
      std::uint32_t a, b, c;
      std::memcpy(&a, &k.x, 4);
      std::memcpy(&b, &k.y, 4);
      std::memcpy(&c, &k.z, 4);
      return (static_cast<size_t>(a) * 73856093u) ^ (static_cast<size_t>(b) * 19349663u) ^ (static_cast<size_t>(c) * 83492791u);
    }
  };
  std::unordered_map<Key, int, Hash> index;
  index.reserve(corners.size() / 6);
  std::vector<double> v;
  const size_t nc = corners.size() / 3;
  TriangleMesh mesh;
  mesh.F.resize(static_cast<Eigen::Index>(nc / 3), 3);
  for (size_t c = 0; c < nc; ++c) {
    const Key k{corners[3 * c], corners[3 * c + 1], corners[3 * c + 2]};
    auto [it, inserted] = index.emplace(k, static_cast<int>(v.size() / 3));
    if (inserted) v.insert(v.end(), {k.x * scale, k.y * scale, k.z * scale});
    mesh.F(static_cast<Eigen::Index>(c / 3), static_cast<int>(c % 3)) = it->second;
  }
  mesh.V = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(v.data(), static_cast<Eigen::Index>(v.size() / 3), 3);
  return mesh;
}

TriangleMesh read_stl(const std::string& path, double scale) {
  const std::string bytes = read_file_bytes(path);
  std::vector<float> corners;
  if (bytes.size() >= 84) {
    std::uint32_t n = 0;
    std::memcpy(&n, bytes.data() + 80, 4);
    if (!host_is_little_endian()) n = __builtin_bswap32(n);
    if (84 + 50ull * n == bytes.size()) {
      ByteReader r(bytes.data() + 84, bytes.data() + bytes.size(), !host_is_little_endian());
      corners.reserve(9ull * n);
      for (std::uint32_t t = 0; t < n; ++t) {
        r.skip(12);
        for (int k = 0; k < 9; ++k) {
          float x = 0;
          r.read(x);
          if (!std::isfinite(x)) throw IoError(path + ": triangle #" + std::to_string(t) + " has a non-finite coordinate");
          corners.push_back(x);
        }
        r.skip(2);
      }
      if (n == 0) throw IoError(path + ": binary STL with no triangles");
      return weld(corners, scale);
    }
  }
  if (bytes.compare(0, 5, "solid") != 0) {
    std::uint32_t n = 0;
    if (bytes.size() >= 84) std::memcpy(&n, bytes.data() + 80, 4);
    if (bytes.size() >= 84 && !host_is_little_endian()) n = __builtin_bswap32(n);
    throw IoError(path + ": not an STL file: not ascii (no 'solid' header), and not binary: " +
                  (bytes.size() < 84 ? std::string("shorter than the 84-byte header")
                                     : "the header declares " + std::to_string(n) + " triangles, which take " +
                                           std::to_string(84 + 50ull * n) + " bytes, the file has " + std::to_string(bytes.size())));
  }
  LineScanner lines(bytes, path);
  std::string_view line;
  std::vector<std::string_view> tok;
  while (lines.next(line)) {
    split(line, tok);
    if (tok.empty() || tok[0] != "vertex") continue;
    if (tok.size() != 4) lines.fail("expected 'vertex x y z'");
    for (int k = 1; k <= 3; ++k) {
      const double x = lines.to_double(tok[k], "a vertex coordinate");
      if (!std::isfinite(x)) lines.fail("non-finite vertex coordinate");
      corners.push_back(static_cast<float>(x));
    }
  }
  if (corners.empty() || corners.size() % 9 != 0)
    throw IoError(path + ": ascii STL: expected facets of 3 'vertex' lines, found " + std::to_string(corners.size() / 3) + " vertices");
  return weld(corners, scale);
}

void write_stl(const std::string& path, const TriangleMesh& mesh, double scale, bool binary) {
  const Eigen::MatrixXd N = face_normals(mesh.V, mesh.F);
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        if (binary) {
          char header[80] = {};
          std::snprintf(header, sizeof(header), "posekit binary STL");
          out.write(header, 80);
          const auto n = static_cast<std::uint32_t>(mesh.F.rows());
          out.write(reinterpret_cast<const char*>(&n), 4);
          for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
            float rec[12];
            for (int k = 0; k < 3; ++k) rec[k] = static_cast<float>(N(f, k));
            for (int c = 0; c < 3; ++c)
              for (int k = 0; k < 3; ++k) rec[3 + 3 * c + k] = static_cast<float>(mesh.V(mesh.F(f, c), k) * scale);
            out.write(reinterpret_cast<const char*>(rec), sizeof(rec));
            const std::uint16_t attr = 0;
            out.write(reinterpret_cast<const char*>(&attr), 2);
          }
        } else {
          out << "solid posekit\n" << std::setprecision(9);
          for (Eigen::Index f = 0; f < mesh.F.rows(); ++f) {
            out << " facet normal " << N(f, 0) << ' ' << N(f, 1) << ' ' << N(f, 2) << "\n  outer loop\n";
            for (int c = 0; c < 3; ++c)
              out << "   vertex " << mesh.V(mesh.F(f, c), 0) * scale << ' ' << mesh.V(mesh.F(f, c), 1) * scale << ' '
                  << mesh.V(mesh.F(f, c), 2) * scale << '\n';
            out << "  endloop\n endfacet\n";
          }
          out << "endsolid posekit\n";
        }
      },
      true);
}

MeshFormat resolve(const std::string& path, MeshFormat format) {
  if (format != MeshFormat::kAuto) return format;
  const MeshFormat f = mesh_format_from_path(path);
  if (f == MeshFormat::kAuto)
    throw IoError(path + ": unknown mesh extension '" + lower_extension(path) +
                  "': expected .obj, .ply, .off, .stl or (written only) .glb");
  return f;
}

}  // namespace

std::vector<std::string> mesh_attributes_lost(const TriangleMesh& mesh, MeshFormat format) {
  const char* name = format == MeshFormat::kObj   ? "OBJ"
                     : format == MeshFormat::kOff ? "OFF"
                     : format == MeshFormat::kStl ? "STL"
                     : format == MeshFormat::kGlb ? "glTF"
                                                  : "PLY";
  std::vector<std::string> lost;
  auto lose = [&](bool has, bool holds, const std::string& what) {
    if (has && !holds) lost.push_back(std::string(name) + " cannot hold " + what + ": not written");
  };
  std::string scalars;
  for (const auto& kv : mesh.vertex_scalars) scalars += (scalars.empty() ? "" : ", ") + kv.first;
  const bool grouped = mesh.face_group.size() == mesh.F.rows() && !mesh.group_names.empty();
  lose(!scalars.empty(), format == MeshFormat::kPly || format == MeshFormat::kGlb, "the vertex scalar field(s) " + scalars + " (PLY can)");
  std::string face_fields;
  for (const auto& kv : mesh.face_scalars) face_fields += (face_fields.empty() ? "" : ", ") + kv.first;
  lose(!face_fields.empty(), format == MeshFormat::kPly, "the face field(s) " + face_fields + " (PLY can)");
  lose(grouped, format == MeshFormat::kObj, "face groups (OBJ can)");
  lose(mesh.has_uv(), format == MeshFormat::kObj || format == MeshFormat::kPly || format == MeshFormat::kGlb,
       "texture coordinates (OBJ and PLY can)");
  lose(mesh.has_colors(), format != MeshFormat::kStl, "vertex colours (PLY, OBJ and OFF can)");
  lose(mesh.has_normals(), format != MeshFormat::kStl, "vertex normals (PLY, OBJ and OFF can)");
  return lost;
}

MeshFormat mesh_format_from_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".obj") return MeshFormat::kObj;
  if (ext == ".ply") return MeshFormat::kPly;
  if (ext == ".off") return MeshFormat::kOff;
  if (ext == ".stl") return MeshFormat::kStl;
  if (ext == ".glb") return MeshFormat::kGlb;
  return MeshFormat::kAuto;
}

TriangleMesh read_mesh(const std::string& path, const MeshReadOptions& options) {
  const double scale = metres_per_unit(options.unit);
  TriangleMesh mesh;
  switch (resolve(path, options.format)) {
    case MeshFormat::kObj:
      mesh = read_obj(path, scale, options.warnings);
      break;
    case MeshFormat::kOff:
      mesh = read_off(path, scale);
      break;
    case MeshFormat::kStl:
      mesh = read_stl(path, scale);
      break;
    case MeshFormat::kPly: {
      io_detail::PlyContent c = io_detail::read_ply(path, scale, true, options.warnings);
      mesh.V = std::move(c.V);
      mesh.F = std::move(c.F);
      mesh.N = std::move(c.N);
      mesh.C = std::move(c.C);
      mesh.UV = std::move(c.UV);
      mesh.vertex_scalars = std::move(c.scalars);
      mesh.face_scalars = std::move(c.face_scalars);
      break;
    }
    case MeshFormat::kGlb:
      throw IoError(path + ": posekit writes glTF (.glb) but does not read it: convert it to PLY or OBJ with another tool");
    case MeshFormat::kAuto:
      break;
  }
  if (mesh.F.rows() == 0) throw IoError(path + ": no faces: expected a triangle mesh (read it as a point cloud?)");
  return mesh;
}

void write_mesh(const std::string& path, const TriangleMesh& mesh, const MeshWriteOptions& options) {
  require_usable_mesh(mesh, path);
  for (const auto& kv : mesh.vertex_scalars)
    if (kv.first.empty() || std::any_of(kv.first.begin(), kv.first.end(), [](unsigned char ch) { return std::isspace(ch); }))
      throw InvalidInput(path + ": scalar field name '" + kv.first + "' must be non-empty without blanks");
  const double scale = 1.0 / metres_per_unit(options.unit);
  const MeshFormat format = resolve(path, options.format);
  for (std::string& lost : mesh_attributes_lost(mesh, format)) warn(options.warnings, path + ": " + lost);
  switch (format) {
    case MeshFormat::kObj:
      write_obj(path, mesh, scale);
      break;
    case MeshFormat::kOff:
      write_off(path, mesh, scale);
      break;
    case MeshFormat::kStl:
      write_stl(path, mesh, scale, options.binary);
      break;
    case MeshFormat::kPly: {
      io_detail::PlyContent c{mesh.V,
                              mesh.has_normals() ? mesh.N : Eigen::MatrixXd(),
                              mesh.has_colors() ? mesh.C : RowMatrixX3u8(),
                              mesh.has_uv() ? mesh.UV : Eigen::MatrixXd(),
                              mesh.vertex_scalars,
                              mesh.F,
                              mesh.face_scalars};
      io_detail::write_ply(path, c, options.binary, scale, options.double_precision);
      break;
    }
    case MeshFormat::kGlb:
      if (options.unit != Unit::kMetre)
        warn(options.warnings, path + ": glTF is in metres (the format says so): written in metres, not " + unit_name(options.unit));
      io_detail::write_glb(path, mesh, 1.0);
      break;
    case MeshFormat::kAuto:
      break;
  }
}

}  // namespace posekit
