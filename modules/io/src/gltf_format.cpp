#include "gltf_format.h"

#include <algorithm>
#include <array>
#include <cctype>
#include <cstdint>
#include <cstring>
#include <nlohmann/json.hpp>
#include <vector>

#include "posekit/io/atomic_file.h"
#include "posekit/version.h"

namespace posekit::io_detail {
namespace {

// glTF's numbers for component types, buffer targets and the triangle mode.
constexpr int kUnsignedByte = 5121, kUnsignedInt = 5125, kFloat = 5126;
constexpr int kArrayBuffer = 34962, kElementArrayBuffer = 34963;
constexpr std::uint32_t kGlbMagic = 0x46546C67, kJsonChunk = 0x4E4F534A, kBinChunk = 0x004E4942;

/// The binary buffer and the JSON that describes it, built one accessor at a time.
class GlbBuilder {
 public:
  /// Appends `bytes` as a new buffer view (4-byte aligned) and an accessor over it; its index.
  int add(const void* bytes, size_t size, int component_type, const char* type, size_t count, int target, bool normalized = false) {
    const size_t offset = buffer_.size();
    buffer_.resize(offset + size);
    std::memcpy(buffer_.data() + offset, bytes, size);
    buffer_.resize((buffer_.size() + 3) / 4 * 4, 0);
    views_.push_back({{"buffer", 0}, {"byteOffset", offset}, {"byteLength", size}, {"target", target}});
    nlohmann::ordered_json accessor = {
        {"bufferView", views_.size() - 1}, {"componentType", component_type}, {"count", count}, {"type", type}};
    if (normalized) accessor["normalized"] = true;
    accessors_.push_back(accessor);
    return static_cast<int>(accessors_.size() - 1);
  }
  nlohmann::ordered_json& accessor(int i) { return accessors_[static_cast<size_t>(i)]; }

  void write(const std::string& path, const nlohmann::ordered_json& primitive) {
    nlohmann::ordered_json gltf = {
        {"asset", {{"version", "2.0"}, {"generator", "posekit " + std::string(version())}}},
        {"scene", 0},
        {"scenes", {{{"nodes", {0}}}}},
        {"nodes", {{{"mesh", 0}}}},
        {"meshes", {{{"primitives", {primitive}}}}},
        {"accessors", accessors_},
        {"bufferViews", views_},
        {"buffers", {{{"byteLength", buffer_.size()}}}},
    };
    std::string json = gltf.dump();
    json.resize((json.size() + 3) / 4 * 4, ' ');
    const auto total = static_cast<std::uint32_t>(12 + 8 + json.size() + 8 + buffer_.size());
    write_file_atomically(path, [&](std::ostream& out) {
      auto u32 = [&](std::uint32_t v) {  // glTF is little-endian
        const unsigned char b[4] = {static_cast<unsigned char>(v), static_cast<unsigned char>(v >> 8), static_cast<unsigned char>(v >> 16),
                                    static_cast<unsigned char>(v >> 24)};
        out.write(reinterpret_cast<const char*>(b), 4);
      };
      u32(kGlbMagic), u32(2), u32(total);
      u32(static_cast<std::uint32_t>(json.size())), u32(kJsonChunk);
      out.write(json.data(), static_cast<std::streamsize>(json.size()));
      u32(static_cast<std::uint32_t>(buffer_.size())), u32(kBinChunk);
      out.write(reinterpret_cast<const char*>(buffer_.data()), static_cast<std::streamsize>(buffer_.size()));
    });
  }

 private:
  std::vector<unsigned char> buffer_;
  nlohmann::ordered_json views_ = nlohmann::ordered_json::array(), accessors_ = nlohmann::ordered_json::array();
};

/// Little-endian float32 values of the rows of M (each row a vertex).
std::vector<float> float_rows(const Eigen::MatrixXd& M, double scale) {
  std::vector<float> out(static_cast<size_t>(M.size()));
  for (Eigen::Index i = 0; i < M.rows(); ++i)
    for (Eigen::Index k = 0; k < M.cols(); ++k) out[static_cast<size_t>(i * M.cols() + k)] = static_cast<float>(M(i, k) * scale);
  return out;
}

/// A vertex scalar's attribute name: "_" and the name in capitals, other characters as underscores.
std::string attribute_name(const std::string& field) {
  std::string name = "_";
  for (unsigned char c : field) name += std::isalnum(c) ? static_cast<char>(std::toupper(c)) : '_';
  return name;
}

}  // namespace

void write_glb(const std::string& path, const TriangleMesh& mesh, double scale) {
  static_assert(sizeof(float) == 4, "glTF stores float32");
  const auto n = static_cast<size_t>(mesh.V.rows());
  GlbBuilder glb;
  nlohmann::ordered_json attributes;
  const std::vector<float> positions = float_rows(mesh.V, scale);
  const int position = glb.add(positions.data(), positions.size() * 4, kFloat, "VEC3", n, kArrayBuffer);
  std::array<float, 3> lo{}, hi{};  // glTF requires POSITION's bounds
  for (int k = 0; k < 3; ++k) {
    lo[static_cast<size_t>(k)] = hi[static_cast<size_t>(k)] = positions[static_cast<size_t>(k)];
    for (size_t v = 0; v < n; ++v) {
      lo[static_cast<size_t>(k)] = std::min(lo[static_cast<size_t>(k)], positions[3 * v + static_cast<size_t>(k)]);
      hi[static_cast<size_t>(k)] = std::max(hi[static_cast<size_t>(k)], positions[3 * v + static_cast<size_t>(k)]);
    }
  }
  glb.accessor(position)["min"] = lo;
  glb.accessor(position)["max"] = hi;
  attributes["POSITION"] = position;
  if (mesh.has_normals()) {
    const Eigen::MatrixXd unit = mesh.N.rowwise().normalized();
    const std::vector<float> normals = float_rows(unit, 1.0);
    attributes["NORMAL"] = glb.add(normals.data(), normals.size() * 4, kFloat, "VEC3", n, kArrayBuffer);
  }
  if (mesh.has_colors()) {
    std::vector<std::uint8_t> rgba(4 * n, 255);
    for (size_t v = 0; v < n; ++v)
      for (int k = 0; k < 3; ++k) rgba[4 * v + static_cast<size_t>(k)] = mesh.C(static_cast<Eigen::Index>(v), k);
    attributes["COLOR_0"] = glb.add(rgba.data(), rgba.size(), kUnsignedByte, "VEC4", n, kArrayBuffer, true);
  }
  if (mesh.has_uv()) {
    Eigen::MatrixXd uv = mesh.UV;
    uv.col(1) = (1.0 - uv.col(1).array()).matrix();
    const std::vector<float> texcoords = float_rows(uv, 1.0);
    attributes["TEXCOORD_0"] = glb.add(texcoords.data(), texcoords.size() * 4, kFloat, "VEC2", n, kArrayBuffer);
  }
  for (const auto& [name, values] : mesh.vertex_scalars) {
    const std::vector<float> field = float_rows(values, 1.0);
    attributes[attribute_name(name)] = glb.add(field.data(), field.size() * 4, kFloat, "SCALAR", n, kArrayBuffer);
  }
  std::vector<std::uint32_t> indices(static_cast<size_t>(mesh.F.size()));
  for (Eigen::Index f = 0; f < mesh.F.rows(); ++f)
    for (int k = 0; k < 3; ++k) indices[static_cast<size_t>(3 * f + k)] = static_cast<std::uint32_t>(mesh.F(f, k));
  const int triangles = glb.add(indices.data(), indices.size() * 4, kUnsignedInt, "SCALAR", indices.size(), kElementArrayBuffer);
  glb.write(path, {{"attributes", attributes}, {"indices", triangles}, {"mode", 4}});
}

}  // namespace posekit::io_detail
