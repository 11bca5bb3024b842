#include "ply_format.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>
#include <limits>
#include <map>
#include <memory>
#include <sstream>
#include <vector>

#include "mapped_file.h"
#include "parse_util.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit::io_detail {
namespace {

enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

bool parse_type(std::string_view s, PlyType& t) {
  if (s == "char" || s == "int8") t = PlyType::kInt8;
  else if (s == "uchar" || s == "uint8") t = PlyType::kUint8;
  else if (s == "short" || s == "int16") t = PlyType::kInt16;
  else if (s == "ushort" || s == "uint16") t = PlyType::kUint16;
  else if (s == "int" || s == "int32") t = PlyType::kInt32;
  else if (s == "uint" || s == "uint32") t = PlyType::kUint32;
  else if (s == "float" || s == "float32") t = PlyType::kFloat32;
  else if (s == "double" || s == "float64") t = PlyType::kFloat64;
  else return false;
  return true;
}

struct PlyProperty {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;
};

struct PlyElement {
  std::string name;
  long long count = 0;
  std::vector<PlyProperty> properties;
};

enum class PlyEncoding { kAscii, kBinaryLittle, kBinaryBig };

template <typename T>
bool read_as_double(ByteReader& r, double& out) {
  T v;
  if (!r.read(v)) return false;
  out = static_cast<double>(v);
  return true;
}

bool read_binary_value(ByteReader& r, PlyType t, double& out) {
  switch (t) {
    case PlyType::kInt8:
      return read_as_double<std::int8_t>(r, out);
    case PlyType::kUint8:
      return read_as_double<std::uint8_t>(r, out);
    case PlyType::kInt16:
      return read_as_double<std::int16_t>(r, out);
    case PlyType::kUint16:
      return read_as_double<std::uint16_t>(r, out);
    case PlyType::kInt32:
      return read_as_double<std::int32_t>(r, out);
    case PlyType::kUint32:
      return read_as_double<std::uint32_t>(r, out);
    case PlyType::kFloat32:
      return read_as_double<float>(r, out);
    case PlyType::kFloat64:
      return read_as_double<double>(r, out);
  }
  return false;
}

/// Where each vertex property goes.
enum class VertexSlot { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kU, kV, kScalar, kIgnore };

/// Bytes one value of `t` takes in a binary file.
size_t type_size(PlyType t) {
  switch (t) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 1;
}

class PlyParser {
 public:
  PlyParser(const std::string& path, double scale, bool finite_only, std::vector<std::string>* warnings)
      : path_(path), scale_(scale), finite_only_(finite_only), warnings_(warnings) {}

  PlyContent parse() {
    file_ = std::make_unique<MappedFile>(path_);
    bytes_ = file_->bytes();
    if (bytes_.size() < 3 || bytes_.compare(0, 3, "ply") != 0) throw IoError(path_ + ": not a PLY file (expected the first line 'ply')");
    parse_header();
    check_counts_fit();
    const char* data_begin = bytes_.data() + header_end_;
    const char* data_end = bytes_.data() + bytes_.size();
    if (encoding_ == PlyEncoding::kAscii) {
      read_ascii(std::string_view(data_begin, data_end - data_begin));
    } else {
      const bool swap = (encoding_ == PlyEncoding::kBinaryLittle) != host_is_little_endian();
      ByteReader reader(data_begin, data_end, swap);
      read_binary(reader, swap);
    }
    finish();
    return std::move(out_);
  }

 private:
  [[noreturn]] void fail_element(const PlyElement& e, long long index, const std::string& what) const {
    throw IoError(path_ + ": element '" + e.name + "' #" + std::to_string(index) + " of " + std::to_string(e.count) + ": " + what);
  }

  void parse_header() {
    const size_t end = find_end_header();
    LineScanner lines(std::string_view(bytes_.data(), end), path_);
    std::string_view line;
    std::vector<std::string_view> tok;
    lines.next(line);  // "ply"
    bool have_format = false;
    while (lines.next(line)) {
      split(line, tok);
      if (tok.empty() || tok[0] == "comment" || tok[0] == "obj_info") continue;
      if (tok[0] == "format") {
        if (tok.size() < 2) lines.fail("expected 'format ascii|binary_little_endian|binary_big_endian 1.0'");
        if (tok[1] == "ascii") encoding_ = PlyEncoding::kAscii;
        else if (tok[1] == "binary_little_endian") encoding_ = PlyEncoding::kBinaryLittle;
        else if (tok[1] == "binary_big_endian") encoding_ = PlyEncoding::kBinaryBig;
        else lines.fail("unknown PLY format '" + printable(tok[1]) + "'");
        have_format = true;
      } else if (tok[0] == "element") {
        if (tok.size() != 3) lines.fail("expected 'element <name> <count>'");
        for (const auto& other : elements_)
          if (other.name == tok[1]) lines.fail("element '" + printable(tok[1]) + "' is declared twice");
        PlyElement e;
        e.name = std::string(tok[1]);
        e.count = lines.to_int(tok[2], "the element count");
        if (e.count < 0) lines.fail("negative element count");
        elements_.push_back(std::move(e));
      } else if (tok[0] == "property") {
        if (elements_.empty()) lines.fail("property before any element");
        PlyProperty p;
        if (tok.size() == 5 && tok[1] == "list") {
          p.is_list = true;
          if (!parse_type(tok[2], p.count_type) || !parse_type(tok[3], p.type))
            lines.fail("unknown list property types '" + printable(tok[2]) + " " + printable(tok[3]) + "'");
          p.name = std::string(tok[4]);
        } else if (tok.size() == 3) {
          if (!parse_type(tok[1], p.type)) lines.fail("unknown property type '" + printable(tok[1]) + "'");
          p.name = std::string(tok[2]);
        } else {
          lines.fail("expected 'property <type> <name>' or 'property list <ctype> <type> <name>'");
        }
        for (const auto& other : elements_.back().properties)
          if (other.name == p.name) lines.fail("property '" + p.name + "' of element '" + elements_.back().name + "' is declared twice");
        elements_.back().properties.push_back(std::move(p));
      } else if (tok[0] == "end_header") {
        break;
      } else if (elements_.empty()) {
        // Some exporters write notes such as "Created by ..." without 'comment'.
        warn(warnings_,
             path_ + ":" + std::to_string(lines.line_number()) + ": skipped the header line '" + printable(line) + "' (not a PLY keyword)");
      } else {
        // After an element a misspelt 'property' would shift every value: refuse it.
        lines.fail("unexpected header keyword '" + printable(tok[0]) + "'");
      }
    }
    if (!have_format) throw IoError(path_ + ": PLY header has no 'format' line");
    header_end_ = end;
  }

  /// Refuses element counts the data cannot hold before anything is allocated for them: a binary
  /// record takes at least its fixed-size properties and list counts, an ascii one a value and a
  /// separator per property.
  void check_counts_fit() const {
    const double available = static_cast<double>(bytes_.size() - std::min(header_end_, bytes_.size())) + 1;
    double needed = 0;
    for (const auto& e : elements_) {
      double record = 0;
      for (const auto& p : e.properties)
        record += encoding_ == PlyEncoding::kAscii ? 2.0 : static_cast<double>(type_size(p.is_list ? p.count_type : p.type));
      needed += record * static_cast<double>(e.count);
      if (needed > available)
        throw IoError(path_ + ": element '" + e.name + "' claims " + std::to_string(e.count) + " entries, more than the " +
                      std::to_string(bytes_.size() - header_end_) + " bytes of data can hold (truncated or corrupt file)");
    }
  }

  size_t find_end_header() {
    size_t pos = 0;
    while (true) {
      const size_t hit = bytes_.find("end_header", pos);
      if (hit == std::string_view::npos || hit > (1u << 20)) throw IoError(path_ + ": PLY header has no 'end_header' line");
      size_t eol = bytes_.find('\n', hit);
      if (eol == std::string_view::npos) {
        if (bytes_.size() - hit <= 11) return bytes_.size();  // header only
        throw IoError(path_ + ": PLY header has no line break after 'end_header'");
      }
      if (hit == 0 || bytes_[hit - 1] == '\n') return eol + 1;
      pos = hit + 1;
    }
  }

  std::vector<VertexSlot> vertex_slots(const PlyElement& e) {
    std::vector<VertexSlot> slots;
    for (const auto& p : e.properties) {
      VertexSlot s = VertexSlot::kScalar;
      if (p.is_list) s = VertexSlot::kIgnore;
      else if (p.name == "x") s = VertexSlot::kX;
      else if (p.name == "y") s = VertexSlot::kY;
      else if (p.name == "z") s = VertexSlot::kZ;
      else if (p.name == "nx") s = VertexSlot::kNx;
      else if (p.name == "ny") s = VertexSlot::kNy;
      else if (p.name == "nz") s = VertexSlot::kNz;
      else if (p.name == "red" || p.name == "r" || p.name == "diffuse_red") s = VertexSlot::kRed;
      else if (p.name == "green" || p.name == "g" || p.name == "diffuse_green") s = VertexSlot::kGreen;
      else if (p.name == "blue" || p.name == "b" || p.name == "diffuse_blue") s = VertexSlot::kBlue;
      else if (p.name == "u" || p.name == "s" || p.name == "texture_u" || p.name == "texture_s") s = VertexSlot::kU;
      else if (p.name == "v" || p.name == "t" || p.name == "texture_v" || p.name == "texture_t") s = VertexSlot::kV;
      slots.push_back(s);
    }
    for (const auto& p : e.properties)
      if (p.is_list) warn(warnings_, path_ + ": the vertex list property '" + p.name + "' is not kept (posekit keeps scalar properties)");
    auto has = [&](VertexSlot s) { return std::find(slots.begin(), slots.end(), s) != slots.end(); };
    if (!has(VertexSlot::kX) || !has(VertexSlot::kY) || !has(VertexSlot::kZ))
      throw IoError(path_ + ": element 'vertex' has no x, y, z properties");
    has_normals_ = has(VertexSlot::kNx) && has(VertexSlot::kNy) && has(VertexSlot::kNz);
    has_colors_ = has(VertexSlot::kRed) && has(VertexSlot::kGreen) && has(VertexSlot::kBlue);
    has_uv_ = has(VertexSlot::kU) && has(VertexSlot::kV);
    const auto n = e.count;
    out_.V.resize(n, 3);
    if (has_normals_) out_.N.resize(n, 3);
    if (has_colors_) out_.C.resize(n, 3);
    if (has_uv_) out_.UV.resize(n, 2);
    for (size_t i = 0; i < slots.size(); ++i) {
      // A lone colour channel or texture coordinate is kept as a scalar field, not lost.
      VertexSlot& slot = slots[i];
      if ((!has_normals_ && (slot == VertexSlot::kNx || slot == VertexSlot::kNy || slot == VertexSlot::kNz)) ||
          (!has_colors_ && (slot == VertexSlot::kRed || slot == VertexSlot::kGreen || slot == VertexSlot::kBlue)) ||
          (!has_uv_ && (slot == VertexSlot::kU || slot == VertexSlot::kV)))
        slot = VertexSlot::kScalar;
      if (slot == VertexSlot::kScalar) out_.scalars[e.properties[i].name].resize(n);
    }
    return slots;
  }

  void store_vertex(const PlyElement& e, const std::vector<VertexSlot>& slots, long long v, size_t prop, double value) {
    switch (slots[prop]) {
      case VertexSlot::kX:
        out_.V(v, 0) = value * scale_;
        break;
      case VertexSlot::kY:
        out_.V(v, 1) = value * scale_;
        break;
      case VertexSlot::kZ:
        out_.V(v, 2) = value * scale_;
        break;
      case VertexSlot::kNx:
        out_.N(v, 0) = value;
        break;
      case VertexSlot::kNy:
        out_.N(v, 1) = value;
        break;
      case VertexSlot::kNz:
        out_.N(v, 2) = value;
        break;
      case VertexSlot::kRed:
        out_.C(v, 0) = to_color(value, e.properties[prop].type);
        break;
      case VertexSlot::kGreen:
        out_.C(v, 1) = to_color(value, e.properties[prop].type);
        break;
      case VertexSlot::kBlue:
        out_.C(v, 2) = to_color(value, e.properties[prop].type);
        break;
      case VertexSlot::kU:
        out_.UV(v, 0) = value;
        break;
      case VertexSlot::kV:
        out_.UV(v, 1) = value;
        break;
      case VertexSlot::kScalar:
        out_.scalars[e.properties[prop].name][v] = value;
        break;
      case VertexSlot::kIgnore:
        break;
    }
  }

  static std::uint8_t to_color(double value, PlyType type) {
    if (type == PlyType::kFloat32 || type == PlyType::kFloat64) value *= 255.0;
    return static_cast<std::uint8_t>(std::clamp(std::lround(value), 0L, 255L));
  }

  static int face_list_index(const PlyElement& e) {
    for (size_t i = 0; i < e.properties.size(); ++i)
      if (e.properties[i].is_list && (e.properties[i].name == "vertex_indices" || e.properties[i].name == "vertex_index"))
        return static_cast<int>(i);
    return -1;
  }

  /// A list length: a whole number up to a million (a float type may hold NaN or 2.5).
  void check_list_length(const PlyElement& e, long long i, double count) const {
    if (!(count >= 0 && count <= 1e6) || count != std::floor(count)) fail_element(e, i, "implausible list length " + std::to_string(count));
  }

  /// A vertex index read as a number: a whole number (a float type may hold NaN or 2.5).
  long long to_index(const PlyElement& e, long long i, double value) const {
    if (!(std::abs(value) <= 2147483647.0) || value != std::floor(value))
      fail_element(e, i, "vertex index " + std::to_string(value) + " is not a whole number in range");
    return static_cast<long long>(value);
  }

  /// A polygon, fan-triangulated. Its indices are checked against the vertex count in finish(),
  /// since the face element may come before the vertex element.
  void add_polygon(const PlyElement& e, long long f, const std::vector<long long>& poly) {
    if (poly.size() < 3) fail_element(e, f, "a face needs at least 3 vertices, got " + std::to_string(poly.size()));
    for (long long idx : poly)
      if (idx < 0) fail_element(e, f, "vertex index " + std::to_string(idx) + " out of range (negative)");
    for (size_t k = 1; k + 1 < poly.size(); ++k) {
      tris_.insert(tris_.end(), {static_cast<int>(poly[0]), static_cast<int>(poly[k]), static_cast<int>(poly[k + 1])});
      tri_face_.push_back(f);
    }
  }

  /// A face's per-corner texture coordinates (MeshLab's `property list uchar float texcoord`).
  void add_corner_uv(const PlyElement& e, long long f, const std::vector<long long>& poly, const std::vector<double>& uv) {
    if (uv.size() != 2 * poly.size())
      fail_element(
          e, f, "texcoord has " + std::to_string(uv.size()) + " values, expected 2 per corner (" + std::to_string(2 * poly.size()) + ")");
    for (size_t k = 0; k < poly.size(); ++k) corner_uv_.push_back({poly[k], uv[2 * k], uv[2 * k + 1]});
  }

  /// What to do with each property of an element (shared by the ascii and binary readers).
  struct ElementPlan {
    bool is_vertex = false, is_face = false;
    std::vector<VertexSlot> slots;  ///< vertex elements only
    int list_index = -1;            ///< face elements: the vertex_indices property
    int texcoord_index = -1;        ///< face elements: per-corner texture coordinates
  };
  ElementPlan plan_element(const PlyElement& e) {
    ElementPlan plan;
    plan.is_vertex = e.name == "vertex";
    plan.is_face = e.name == "face";
    if (plan.is_vertex) plan.slots = vertex_slots(e);
    if (plan.is_face) {
      plan.list_index = face_list_index(e);
      // PCL's pcl_pcd2ply writes 'element face 0' with no properties.
      if (plan.list_index < 0 && e.count > 0) throw IoError(path_ + ": element 'face' has no vertex_indices list");
      tris_.reserve(tris_.size() + static_cast<size_t>(e.count) * 3);
      for (size_t i = 0; i < e.properties.size(); ++i) {
        const PlyProperty& p = e.properties[i];
        if (static_cast<int>(i) == plan.list_index) continue;
        if (!p.is_list) face_values_[p.name].reserve(static_cast<size_t>(e.count));
        else if (p.name == "texcoord" && plan.texcoord_index < 0) plan.texcoord_index = static_cast<int>(i);
        else if (e.count > 0)
          warn(warnings_, path_ + ": the face list property '" + p.name + "' is not kept (posekit keeps face scalars and texcoord)");
      }
    }
    if (!plan.is_vertex && !plan.is_face && e.count > 0)
      warn(warnings_,
           path_ + ": element '" + e.name + "' (" + std::to_string(e.count) + " entries) is not kept: posekit reads 'vertex' and 'face'");
    return plan;
  }

  /// A face's scalar property value, stored per polygon (repeated on its triangles in finish()).
  void store_face_value(const PlyElement& e, size_t prop, double value) { face_values_[e.properties[prop].name].push_back(value); }

  /// A vertex element whose properties are all float or all double in the host's byte order (how
  /// scanners and most tools write clouds), wholly present: read record by record without a check
  /// per value. False when the element is not such (the general reader takes it).
  template <typename T>
  bool read_uniform_vertices(ByteReader& r, const PlyElement& e, const std::vector<VertexSlot>& slots, PlyType type, bool swap) {
    const size_t k = e.properties.size(), record = k * sizeof(T);
    if (swap || k == 0 || k > 64) return false;
    for (const auto& p : e.properties)
      if (p.is_list || p.type != type) return false;
    const auto count = static_cast<size_t>(e.count);
    if (r.remaining() / record < count) return false;  // the general reader names the vertex where the file ends
    // Each property's column (colours, which need converting, go through store_vertex).
    double* column[64] = {};
    double factor[64];
    bool colours = false;
    for (size_t q = 0; q < k; ++q) {
      factor[q] = 1;
      switch (slots[q]) {
        case VertexSlot::kX:
        case VertexSlot::kY:
        case VertexSlot::kZ:
          column[q] = out_.V.col(static_cast<int>(slots[q]) - static_cast<int>(VertexSlot::kX)).data(), factor[q] = scale_;
          break;
        case VertexSlot::kNx:
        case VertexSlot::kNy:
        case VertexSlot::kNz:
          column[q] = out_.N.col(static_cast<int>(slots[q]) - static_cast<int>(VertexSlot::kNx)).data();
          break;
        case VertexSlot::kU:
          column[q] = out_.UV.col(0).data();
          break;
        case VertexSlot::kV:
          column[q] = out_.UV.col(1).data();
          break;
        case VertexSlot::kScalar:
          column[q] = out_.scalars[e.properties[q].name].data();
          break;
        case VertexSlot::kRed:
        case VertexSlot::kGreen:
        case VertexSlot::kBlue:
          colours = true;
          break;
        case VertexSlot::kIgnore:
          break;
      }
    }
    const char* at = r.position();
    T values[64];
    for (size_t i = 0; i < count; ++i, at += record) {
      std::memcpy(values, at, record);
      for (size_t q = 0; q < k; ++q)
        if (column[q]) column[q][i] = factor[q] * static_cast<double>(values[q]);
        else if (colours) store_vertex(e, slots, static_cast<long long>(i), q, static_cast<double>(values[q]));
    }
    r.skip(count * record);
    return true;
  }

  void read_binary(ByteReader& r, bool swap) {
    std::vector<long long> poly;
    std::vector<double> uv;
    for (const auto& e : elements_) {
      const ElementPlan plan = plan_element(e);
      const bool is_vertex = plan.is_vertex, is_face = plan.is_face;
      const std::vector<VertexSlot>& slots = plan.slots;
      const int list_index = plan.list_index;
      if (is_vertex && (read_uniform_vertices<float>(r, e, slots, PlyType::kFloat32, swap) ||
                        read_uniform_vertices<double>(r, e, slots, PlyType::kFloat64, swap)))
        continue;
      for (long long i = 0; i < e.count; ++i) {
        uv.clear();
        for (size_t p = 0; p < e.properties.size(); ++p) {
          const auto& prop = e.properties[p];
          double value = 0;
          if (!prop.is_list) {
            if (!read_binary_value(r, prop.type, value)) fail_element(e, i, "file ends early (truncated binary data)");
            if (is_vertex) store_vertex(e, slots, i, p, value);
            if (is_face) store_face_value(e, p, value);
            continue;
          }
          double count = 0;
          if (!read_binary_value(r, prop.count_type, count)) fail_element(e, i, "file ends early (truncated binary data)");
          check_list_length(e, i, count);
          const bool keep = is_face && static_cast<int>(p) == list_index;
          const bool keep_uv = is_face && static_cast<int>(p) == plan.texcoord_index;
          if (keep) poly.clear();
          for (long long k = 0; k < static_cast<long long>(count); ++k) {
            if (!read_binary_value(r, prop.type, value)) fail_element(e, i, "file ends early (truncated binary data)");
            if (keep) poly.push_back(to_index(e, i, value));
            if (keep_uv) uv.push_back(value);
          }
          if (keep) add_polygon(e, i, poly);
        }
        if (plan.texcoord_index >= 0) add_corner_uv(e, i, poly, uv);
      }
    }
  }

  void read_ascii(std::string_view text) {
    LineScanner lines(text, path_);
    std::string_view line;
    std::vector<std::string_view> tok;
    std::vector<long long> poly;
    std::vector<double> uv;
    for (const auto& e : elements_) {
      const ElementPlan plan = plan_element(e);
      const bool is_vertex = plan.is_vertex, is_face = plan.is_face;
      const std::vector<VertexSlot>& slots = plan.slots;
      const int list_index = plan.list_index;
      for (long long i = 0; i < e.count; ++i) {
        do {
          if (!lines.next(line)) fail_element(e, i, "file ends early (expected " + std::to_string(e.count) + " lines)");
          split(line, tok);
        } while (tok.empty());
        size_t t = 0;
        auto take = [&]() -> std::string_view {
          if (t >= tok.size()) fail_element(e, i, "too few values on the line");
          return tok[t++];
        };
        uv.clear();
        for (size_t p = 0; p < e.properties.size(); ++p) {
          const auto& prop = e.properties[p];
          if (!prop.is_list) {
            const double value = to_number(take(), e, i);
            if (is_vertex) store_vertex(e, slots, i, p, value);
            if (is_face) store_face_value(e, p, value);
            continue;
          }
          const double count = to_number(take(), e, i);
          check_list_length(e, i, count);
          const bool keep = is_face && static_cast<int>(p) == list_index;
          const bool keep_uv = is_face && static_cast<int>(p) == plan.texcoord_index;
          if (keep) poly.clear();
          for (long long k = 0; k < static_cast<long long>(count); ++k) {
            const double value = to_number(take(), e, i);
            if (keep) poly.push_back(to_index(e, i, value));
            if (keep_uv) uv.push_back(value);
          }
          if (keep) add_polygon(e, i, poly);
        }
        if (plan.texcoord_index >= 0) add_corner_uv(e, i, poly, uv);
        if (t < tok.size())
          fail_element(e, i,
                       std::to_string(tok.size() - t) + " more value(s) on the line than the " + std::to_string(e.properties.size()) +
                           " properties declared");
      }
    }
  }

  double to_number(std::string_view token, const PlyElement& e, long long i) const {
    double value = 0;
    if (!parse_double(token, value)) fail_element(e, i, "expected a number, got '" + printable(token) + "'");
    return value;
  }

  void finish() {
    bool have_vertex = false;
    for (const auto& e : elements_) have_vertex |= e.name == "vertex";
    if (!have_vertex) throw IoError(path_ + ": PLY has no 'vertex' element");
    const PlyElement* face_element = nullptr;
    for (const auto& e : elements_)
      if (e.name == "face") face_element = &e;
    for (size_t t = 0; t < tris_.size(); ++t)
      if (tris_[t] >= out_.V.rows())
        fail_element(*face_element, tri_face_[t / 3],
                     "vertex index " + std::to_string(tris_[t]) + " out of range 0.." + std::to_string(out_.V.rows() - 1));
    for (const auto& [name, per_face] : face_values_) {
      Eigen::VectorXd& values = out_.face_scalars[name];
      values.resize(static_cast<Eigen::Index>(tri_face_.size()));
      for (size_t t = 0; t < tri_face_.size(); ++t) values[static_cast<Eigen::Index>(t)] = per_face[static_cast<size_t>(tri_face_[t])];
    }
    finish_corner_uv();
    // A PLY without faces is a point cloud, whose reader drops such points instead.
    for (Eigen::Index v = 0; finite_only_ && !tris_.empty() && v < out_.V.rows(); ++v)
      if (!out_.V.row(v).allFinite()) throw IoError(path_ + ": element 'vertex' #" + std::to_string(v) + " has a non-finite coordinate");
    out_.F.resize(static_cast<Eigen::Index>(tris_.size() / 3), 3);
    for (Eigen::Index f = 0; f < out_.F.rows(); ++f)
      for (int c = 0; c < 3; ++c) out_.F(f, c) = tris_[3 * f + c];
  }

  /// Per-corner texture coordinates become per-vertex ones when every vertex gets one and only one;
  /// otherwise (UV seams) they are dropped with a warning, as the OBJ reader does.
  void finish_corner_uv() {
    if (corner_uv_.empty()) return;
    if (has_uv_) {
      warn(warnings_, path_ + ": the faces' texcoord not kept: the vertices have their own texture coordinates");
      return;
    }
    const Eigen::Index nv = out_.V.rows();
    Eigen::MatrixXd uv = Eigen::MatrixXd::Constant(nv, 2, std::numeric_limits<double>::quiet_NaN());
    long long seams = 0;
    for (const CornerUv& c : corner_uv_) {
      if (c.vertex >= nv) continue;  // refused above
      if (std::isnan(uv(c.vertex, 0))) uv.row(c.vertex) << c.u, c.v;
      else if (uv(c.vertex, 0) != c.u || uv(c.vertex, 1) != c.v) ++seams;
    }
    if (seams > 0) {
      warn(warnings_, path_ + ": texture coordinates not kept: " + std::to_string(seams) +
                          " face corners give a vertex another texture coordinate than its first (UV seams; posekit keeps one per vertex)");
      return;
    }
    if (uv.hasNaN()) {
      warn(warnings_, path_ + ": texture coordinates not kept: some vertices are on no face with a texcoord");
      return;
    }
    out_.UV = std::move(uv);
  }

  struct CornerUv {
    long long vertex;
    double u, v;
  };

  std::string path_;
  double scale_;
  bool finite_only_;
  std::vector<std::string>* warnings_;
  std::unique_ptr<MappedFile> file_;
  std::string_view bytes_;
  size_t header_end_ = 0;
  PlyEncoding encoding_ = PlyEncoding::kAscii;
  std::vector<PlyElement> elements_;
  bool has_normals_ = false;
  bool has_colors_ = false;
  bool has_uv_ = false;
  std::vector<int> tris_;
  std::vector<long long> tri_face_;                         ///< the face (polygon) number of each triangle
  std::map<std::string, std::vector<double>> face_values_;  ///< per polygon
  std::vector<CornerUv> corner_uv_;
  PlyContent out_;
};

template <typename T>
void put(std::ostream& out, T value) {
  out.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

}  // namespace

std::string ply_scalar_property(const std::string& field) { return field == "alpha" ? field : "scalar_" + field; }

std::string ply_scalar_field(const std::string& property) {
  const std::string prefix = "scalar_";
  return property.size() > prefix.size() && property.compare(0, prefix.size(), prefix) == 0 ? property.substr(prefix.size()) : property;
}

PlyContent read_ply(const std::string& path, double scale, bool finite_only, std::vector<std::string>* warnings) {
  PlyContent c = PlyParser(path, scale, finite_only, warnings).parse();
  std::map<std::string, Eigen::VectorXd> fields;
  for (auto& [property, values] : c.scalars) {
    const std::string field = ply_scalar_field(property);
    fields[field != property && c.scalars.count(field) ? property : field] = std::move(values);
  }
  c.scalars = std::move(fields);
  return c;
}

namespace {

/// One column of the vertex or face records (a column of a column-major matrix, or a field), stored
/// as float32 or float64.
struct PlyColumn {
  std::string name;
  const double* values;
  double scale;
  bool wide;
};

void put_column_value(std::ostream& out, const PlyColumn& c, Eigen::Index i, bool binary, bool first) {
  const double v = c.values[i] * c.scale;
  if (binary) {
    if (c.wide) put(out, v);
    else put(out, static_cast<float>(v));
    return;
  }
  if (!first) out << ' ';
  if (c.wide) put_number(out, c.values[i], c.scale);
  else put_number(out, static_cast<float>(v));
}

void check_ply_fields(const std::string& path, const PlyContent& c) {
  for (const auto& [name, values] : c.scalars)
    if (values.size() != c.V.rows())
      throw InvalidInput(path + ": scalar field '" + name + "' has " + std::to_string(values.size()) +
                         " values, expected one per vertex (" + std::to_string(c.V.rows()) + ")");
  for (const auto& [name, values] : c.face_scalars) {
    if (values.size() != c.F.rows())
      throw InvalidInput(path + ": face field '" + name + "' has " + std::to_string(values.size()) +
                         " values, expected one per triangle (" + std::to_string(c.F.rows()) + ")");
    if (name.empty() || name == "vertex_indices" || name.find_first_of(" \t\n") != std::string::npos)
      throw InvalidInput(path + ": face field name '" + name + "' must be non-empty without blanks");
  }
}

}  // namespace

void write_ply(const std::string& path, const PlyContent& c, bool binary, double scale, bool all_double) {
  check_ply_fields(path, c);
  const Eigen::Index n = c.V.rows();
  const bool colors = c.C.rows() == n && n > 0;
  std::vector<PlyColumn> vertex_columns;
  const bool p64 = all_double || !float_keeps_coordinates(c.V.reshaped(), scale, 1e-6 * scale);
  for (int k = 0; k < 3; ++k) vertex_columns.push_back({std::string(1, "xyz"[k]), c.V.data() + k * n, scale, p64});
  if (c.N.rows() == n && n > 0) {
    const bool wide = all_double || !float_keeps_field(c.N.reshaped());
    for (int k = 0; k < 3; ++k) vertex_columns.push_back({std::string("n") + "xyz"[k], c.N.data() + k * n, 1.0, wide});
  }
  if (c.UV.rows() == n && c.UV.cols() == 2 && n > 0) {
    const bool wide = all_double || !float_keeps_field(c.UV.reshaped());
    vertex_columns.push_back({"texture_u", c.UV.data(), 1.0, wide});
    vertex_columns.push_back({"texture_v", c.UV.data() + n, 1.0, wide});
  }
  for (const auto& [name, values] : c.scalars)
    vertex_columns.push_back({ply_scalar_property(name), values.data(), 1.0, all_double || !float_keeps_field(values)});
  std::vector<PlyColumn> face_columns;
  for (const auto& [name, values] : c.face_scalars)
    face_columns.push_back({name, values.data(), 1.0, all_double || !float_keeps_field(values)});

  const bool little = host_is_little_endian();
  write_file_atomically(path, [&](std::ostream& out) {
    out << "ply\nformat " << (binary ? (little ? "binary_little_endian" : "binary_big_endian") : "ascii")
        << " 1.0\ncomment written by posekit\nelement vertex " << n << "\n";
    for (const PlyColumn& column : vertex_columns) out << "property " << (column.wide ? "double " : "float ") << column.name << "\n";
    if (colors) out << "property uchar red\nproperty uchar green\nproperty uchar blue\n";
    if (c.F.rows() > 0) {
      out << "element face " << c.F.rows() << "\nproperty list uchar int vertex_indices\n";
      for (const PlyColumn& column : face_columns) out << "property " << (column.wide ? "double " : "float ") << column.name << "\n";
    }
    out << "end_header\n";
    for (Eigen::Index v = 0; v < n; ++v) {
      for (size_t k = 0; k < vertex_columns.size(); ++k) put_column_value(out, vertex_columns[k], v, binary, k == 0);
      if (colors && binary)
        for (int j = 0; j < 3; ++j) put(out, c.C(v, j));
      if (colors && !binary) out << ' ' << int(c.C(v, 0)) << ' ' << int(c.C(v, 1)) << ' ' << int(c.C(v, 2));
      if (!binary) out << '\n';
    }
    for (Eigen::Index f = 0; f < c.F.rows(); ++f) {
      if (binary) {
        put<std::uint8_t>(out, 3);
        for (int k = 0; k < 3; ++k) put<std::int32_t>(out, c.F(f, k));
      } else {
        out << "3 " << c.F(f, 0) << ' ' << c.F(f, 1) << ' ' << c.F(f, 2);
      }
      for (const PlyColumn& column : face_columns) put_column_value(out, column, f, binary, false);
      if (!binary) out << '\n';
    }
  });
}

}  // namespace posekit::io_detail
