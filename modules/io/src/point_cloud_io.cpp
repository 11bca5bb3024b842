#include "posekit/io/point_cloud_io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <iomanip>

#include "mapped_file.h"
#include "parse_util.h"
#include "ply_format.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "text_mesh_formats.h"

namespace posekit {
using namespace io_detail;

namespace {

/// LZF decompression (PCD's binary_compressed): a control byte below 32 starts a run of ctrl + 1
/// literal bytes; otherwise its top 3 bits (7: plus the next byte) give length - 2 and its low 5 bits
/// with the next byte the distance - 1 back into the output. Returns the bytes written, or 0 when
/// the input is corrupt or does not fit into `out_size`.
size_t lzf_decompress(const char* in, size_t in_size, char* out, size_t out_size) {
  const auto* ip = reinterpret_cast<const unsigned char*>(in);
  const unsigned char* const in_end = ip + in_size;
  auto* op = reinterpret_cast<unsigned char*>(out);
  const unsigned char* const out_begin = op;
  const unsigned char* const out_end = op + out_size;
  while (ip < in_end) {
    const unsigned ctrl = *ip++;
    if (ctrl < 32) {
      const size_t run = ctrl + 1;
      if (static_cast<size_t>(in_end - ip) < run || static_cast<size_t>(out_end - op) < run) return 0;
      std::memcpy(op, ip, run);
      ip += run, op += run;
      continue;
    }
    size_t length = ctrl >> 5;
    if (length == 7) {
      if (ip >= in_end) return 0;
      length += *ip++;
    }
    length += 2;
    if (ip >= in_end) return 0;
    const size_t distance = ((static_cast<size_t>(ctrl & 0x1f) << 8) | *ip++) + 1;
    if (distance > static_cast<size_t>(op - out_begin) || static_cast<size_t>(out_end - op) < length) return 0;
    const unsigned char* ref = op - distance;
    for (size_t k = 0; k < length; ++k) *op++ = *ref++;  // the reference may overlap the output
  }
  return static_cast<size_t>(op - out_begin);
}

struct PcdField {
  std::string name;
  int size = 4;
  char type = 'F';
  int count = 1;
  size_t offset = 0;  // within a point record (binary), or first value index (ascii)
};

double pcd_value(const char* p, const PcdField& f) {
  switch (f.type) {
    case 'F':
      if (f.size == 4) {
        float x;
        std::memcpy(&x, p, 4);
        return x;
      }
      if (f.size == 8) {
        double x;
        std::memcpy(&x, p, 8);
        return x;
      }
      break;
    case 'I':
      if (f.size == 1) {
        std::int8_t x;
        std::memcpy(&x, p, 1);
        return x;
      }
      if (f.size == 2) {
        std::int16_t x;
        std::memcpy(&x, p, 2);
        return x;
      }
      if (f.size == 4) {
        std::int32_t x;
        std::memcpy(&x, p, 4);
        return x;
      }
      if (f.size == 8) {
        std::int64_t x;
        std::memcpy(&x, p, 8);
        return static_cast<double>(x);
      }
      break;
    case 'U':
      if (f.size == 1) {
        std::uint8_t x;
        std::memcpy(&x, p, 1);
        return x;
      }
      if (f.size == 2) {
        std::uint16_t x;
        std::memcpy(&x, p, 2);
        return x;
      }
      if (f.size == 4) {
        std::uint32_t x;
        std::memcpy(&x, p, 4);
        return x;
      }
      if (f.size == 8) {
        std::uint64_t x;
        std::memcpy(&x, p, 8);
        return static_cast<double>(x);
      }
      break;
  }
  return 0.0;
}

bool is_packed_color(const PcdField& f) { return (f.name == "rgb" || f.name == "rgba") && f.size == 4; }

/// The 32 bits of a packed PCD colour field, whatever TYPE the file gave it.
std::uint32_t packed_color_bits(const char* p) {
  std::uint32_t bits;
  std::memcpy(&bits, p, 4);
  return bits;
}

/// A PCD header: its fields (with their offsets in a binary record), point count and DATA kind.
struct PcdHeader {
  std::vector<PcdField> fields;
  long long points = -1;
  std::string data;  ///< ascii, binary or binary_compressed
  size_t record = 0, values_per_point = 0;
};

/// Reads the header up to its DATA line and checks it. Throws IoError naming `path`.
PcdHeader read_pcd_header(LineScanner& lines, const std::string& path) {
  std::string_view line;
  std::vector<std::string_view> tok;
  PcdHeader h;
  std::vector<PcdField>& fields = h.fields;
  long long& points = h.points;
  std::string& data = h.data;
  long long width = -1, height = -1;
  points = -1;
  bool have_size = false, have_type = false;
  while (lines.next(line)) {
    split(line, tok);
    if (tok.empty() || tok[0][0] == '#') continue;
    const std::string_view key = tok[0];
    const size_t nvals = tok.size() - 1;
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS" || key == "COLUMNS") {
      fields.clear();
      for (size_t i = 1; i < tok.size(); ++i) {
        for (const PcdField& other : fields)
          if (other.name == tok[i] && other.name != "_") lines.fail("field '" + printable(tok[i]) + "' is declared twice");
        fields.push_back({std::string(tok[i])});
      }
    } else if (key == "SIZE" || key == "TYPE" || key == "COUNT") {
      if (nvals != fields.size())
        lines.fail(std::string(key) + " has " + std::to_string(nvals) + " entries, expected one per field (" +
                   std::to_string(fields.size()) + ")");
      for (size_t i = 0; i < nvals; ++i) {
        if (key == "TYPE") {
          if (tok[i + 1].size() != 1 || std::string_view("FIU").find(tok[i + 1][0]) == std::string_view::npos)
            lines.fail("TYPE must be F, I or U, got '" + printable(tok[i + 1]) + "'");
          fields[i].type = tok[i + 1][0];
        } else {
          const long long v = lines.to_int(tok[i + 1], key == "SIZE" ? "SIZE" : "COUNT");
          if (key == "SIZE" && v != 1 && v != 2 && v != 4 && v != 8) lines.fail("SIZE must be 1, 2, 4 or 8");
          if (key == "COUNT" && (v < 1 || v > 1 << 20)) lines.fail("COUNT must be positive");
          (key == "SIZE" ? fields[i].size : fields[i].count) = static_cast<int>(v);
        }
      }
      (key == "SIZE" ? have_size : have_type) |= key != "COUNT";
    } else if (key == "WIDTH" && nvals == 1) {
      width = lines.to_int(tok[1], "WIDTH");
    } else if (key == "HEIGHT" && nvals == 1) {
      height = lines.to_int(tok[1], "HEIGHT");
    } else if (key == "POINTS" && nvals == 1) {
      points = lines.to_int(tok[1], "POINTS");
    } else if (key == "DATA" && nvals == 1) {
      data = std::string(tok[1]);
      break;
    } else {
      lines.fail("unexpected PCD header line '" + printable(line) + "'");
    }
  }
  if (data.empty()) throw IoError(path + ": PCD header has no DATA line (not a PCD file?)");
  std::string missing;
  if (fields.empty()) missing += " FIELDS";
  if (!have_size) missing += " SIZE";
  if (!have_type) missing += " TYPE";
  if (width < 0) missing += " WIDTH";
  if (height < 0) missing += " HEIGHT";
  if (!missing.empty()) throw IoError(path + ": PCD header lacks" + missing + " (or gives a negative value)");
  constexpr long long kMaxSide = 1LL << 31;  // keeps WIDTH x HEIGHT within 64 bits
  if (width > kMaxSide || height > kMaxSide || points > kMaxSide * kMaxSide)
    throw IoError(path + ": PCD header declares WIDTH " + std::to_string(width) + ", HEIGHT " + std::to_string(height) + ", POINTS " +
                  std::to_string(points) + ": more points than any file can hold");
  if (points < 0) points = width * height;
  if (points != width * height)
    throw IoError(path + ": PCD header declares POINTS " + std::to_string(points) + " but WIDTH x HEIGHT = " + std::to_string(width) +
                  " x " + std::to_string(height) + " = " + std::to_string(width * height));
  for (PcdField& field : fields) {
    field.offset = h.record;
    h.record += static_cast<size_t>(field.size) * field.count;
    h.values_per_point += static_cast<size_t>(field.count);
  }
  return h;
}

/// A PCD's values where they lie: ascii ones parsed into ascii[field][point], binary records and
/// binary_compressed columns decoded in place. Packed colours keep their 32 bits.
struct PcdValues {
  const PcdHeader* header = nullptr;
  std::vector<std::vector<double>> ascii;
  const char* records = nullptr;  ///< binary: point p's field f at records + p * record + offset
  std::vector<char> raw;          ///< binary_compressed: field f's column at raw + column[f]
  std::vector<size_t> column;

  double decode(const char* p, size_t f) const {
    const PcdField& field = header->fields[f];
    return is_packed_color(field) ? static_cast<double>(packed_color_bits(p)) : pcd_value(p, field);
  }
  double operator()(size_t f, Eigen::Index p) const {
    const PcdField& field = header->fields[f];
    if (records) return decode(records + static_cast<size_t>(p) * header->record + field.offset, f);
    if (!ascii.empty()) return ascii[f][static_cast<size_t>(p)];
    return decode(raw.data() + column[f] + static_cast<size_t>(p) * static_cast<size_t>(field.size) * field.count, f);
  }
};

/// Reads the data after the header, first checking that the header's count fits it.
PcdValues read_pcd_values(LineScanner& lines, std::string_view bytes, const PcdHeader& h, const std::string& path) {
  const std::vector<PcdField>& fields = h.fields;
  const long long points = h.points;
  const std::string& data = h.data;
  const size_t record = h.record, values_per_point = h.values_per_point;
  std::string_view line;
  std::vector<std::string_view> tok;
  // The header's count must fit the data before anything is allocated for it: a binary point takes
  // `record` bytes, an ascii one at least a character and a separator per value.
  const size_t data_start = lines.offset();
  const double available = static_cast<double>(bytes.size() - data_start);
  const double needed = data == "binary"  ? static_cast<double>(record) * static_cast<double>(points)
                        : data == "ascii" ? 2.0 * static_cast<double>(values_per_point) * static_cast<double>(points) - 1
                                          : 0.0;
  if (needed > available)
    throw IoError(path + ": the header declares " + std::to_string(points) + " points of " + std::to_string(record) +
                  " bytes, more than the " + std::to_string(bytes.size() - data_start) + " bytes of data can hold (truncated file)");
  // Each value read where it lies: the ascii values parsed into values[field][point], binary records
  // and binary_compressed columns decoded in place. Packed colours keep their 32 bits.
  PcdValues out;
  out.header = &h;
  std::vector<std::vector<double>>& values = out.ascii;
  std::vector<char>& raw = out.raw;
  std::vector<size_t>& column = out.column;
  column.assign(fields.size(), 0);
  if (data == "ascii") {
    values.assign(fields.size(), std::vector<double>(static_cast<size_t>(points)));
    for (long long p = 0; p < points; ++p) {
      do {
        if (!lines.next(line))
          throw IoError(path + ": point #" + std::to_string(p) + " of " + std::to_string(points) +
                        ": file ends early (the header declares more points than the file has)");
        split(line, tok);
      } while (tok.empty());
      if (tok.size() != values_per_point)
        lines.fail("point #" + std::to_string(p) + ": " + std::to_string(tok.size()) + " values, expected " +
                   std::to_string(values_per_point) + " (one per field and count)");
      size_t t = 0;
      for (size_t f = 0; f < fields.size(); ++f)
        for (int c = 0; c < fields[f].count; ++c, ++t) {
          if (c != 0) continue;
          double v = lines.to_double(tok[t], "a field value");
          if (is_packed_color(fields[f]) && fields[f].type == 'F' && tok[t].find_first_of(".eE") != std::string_view::npos) {
            // Older PCL wrote the packed colour as the float with the same bits.
            const float as_float = static_cast<float>(v);
            v = static_cast<double>(packed_color_bits(reinterpret_cast<const char*>(&as_float)));
          }
          values[f][p] = v;
        }
    }
  } else if (data == "binary") {
    out.records = bytes.data() + data_start;
  } else if (data == "binary_compressed") {
    if (bytes.size() - data_start < 8) throw IoError(path + ": binary_compressed data is truncated");
    std::uint32_t compressed = 0, uncompressed = 0;
    std::memcpy(&compressed, bytes.data() + data_start, 4);
    std::memcpy(&uncompressed, bytes.data() + data_start + 4, 4);
    // LZF turns at most 3 bytes into 264: a larger ratio is a corrupt header.
    constexpr double kLzfMaxRatio = 264.0 / 3.0;
    if (compressed > bytes.size() - data_start - 8 || uncompressed != record * static_cast<size_t>(points) ||
        static_cast<double>(uncompressed) > kLzfMaxRatio * compressed + 8)
      throw IoError(path + ": binary_compressed sizes (" + std::to_string(compressed) + " -> " + std::to_string(uncompressed) +
                    " bytes) do not match the header's " + std::to_string(points) + " points of " + std::to_string(record) +
                    " bytes (truncated or corrupt)");
    raw.resize(uncompressed);
    if (uncompressed > 0 && lzf_decompress(bytes.data() + data_start + 8, compressed, raw.data(), uncompressed) != uncompressed)
      throw IoError(path + ": binary_compressed data does not decompress (corrupt)");
    size_t off = 0;
    for (size_t f = 0; f < fields.size(); ++f) {
      column[f] = off;
      off += static_cast<size_t>(fields[f].size) * fields[f].count * static_cast<size_t>(points);
    }
  } else {
    throw IoError(path + ": unknown DATA '" + data + "': expected ascii, binary or binary_compressed");
  }
  return out;
}

PointCloud read_pcd(const std::string& path, double scale) {
  const io_detail::MappedFile file(path);  // binary data is decoded straight from the map into the columns
  const std::string_view bytes = file.bytes();
  LineScanner lines(bytes, path);
  const PcdHeader header = read_pcd_header(lines, path);
  const std::vector<PcdField>& fields = header.fields;
  int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1, icolor = -1;
  for (size_t i = 0; i < fields.size(); ++i) {
    const std::string& n = fields[i].name;
    if (n == "x") ix = static_cast<int>(i);
    else if (n == "y") iy = static_cast<int>(i);
    else if (n == "z") iz = static_cast<int>(i);
    else if (n == "normal_x") inx = static_cast<int>(i);
    else if (n == "normal_y") iny = static_cast<int>(i);
    else if (n == "normal_z") inz = static_cast<int>(i);
    else if (is_packed_color(fields[i]) && icolor < 0) icolor = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) throw IoError(path + ": PCD has no x, y, z fields");
  const bool normals = inx >= 0 && iny >= 0 && inz >= 0;
  const PcdValues value = read_pcd_values(lines, bytes, header, path);
  const long long points = header.points;
  PointCloud cloud;
  const auto n = static_cast<Eigen::Index>(points);
  cloud.P.resize(n, 3);
  if (normals) cloud.N.resize(n, 3);
  if (icolor >= 0) cloud.C.resize(n, 3);
  for (size_t f = 0; f < fields.size(); ++f) {
    const int fi = static_cast<int>(f);
    if (fi == ix || fi == iy || fi == iz || fi == inx || fi == iny || fi == inz || fi == icolor || fields[f].count != 1 ||
        fields[f].name == "_")
      continue;
    cloud.point_scalars[fields[f].name].resize(n);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    cloud.P.row(i) << value(ix, i) * scale, value(iy, i) * scale, value(iz, i) * scale;
    if (normals) cloud.N.row(i) << value(inx, i), value(iny, i), value(inz, i);
    if (icolor >= 0) {
      const double packed = value(icolor, i);
      if (!(packed >= 0 && packed < 4294967296.0))  // not a packed 0x00RRGGBB: casting it would be undefined
        throw IoError(path + ": point " + std::to_string(i) + ": colour field '" + fields[static_cast<size_t>(icolor)].name + "' is " +
                      std::to_string(packed) + ", not a packed 24-bit RGB value");
      const auto bits = static_cast<std::uint32_t>(packed);
      cloud.C.row(i) << static_cast<std::uint8_t>(bits >> 16), static_cast<std::uint8_t>(bits >> 8), static_cast<std::uint8_t>(bits);
    }
  }
  for (size_t f = 0; f < fields.size(); ++f) {
    auto it = cloud.point_scalars.find(fields[f].name);
    if (it != cloud.point_scalars.end())
      for (Eigen::Index i = 0; i < n; ++i) it->second[i] = value(f, i);
  }
  return cloud;
}

void write_pcd(const std::string& path, const PointCloud& cloud, double scale, bool binary, bool all_double) {
  const Eigen::Index n = cloud.size();
  const bool normals = cloud.has_normals();
  const bool colors = cloud.has_colors();
  // Coordinates as float32 only where that moves no point by more than 1 micrometre.
  const bool p64 = all_double || !float_keeps_coordinates(cloud.P.reshaped(), scale, 1e-6 * scale);
  std::vector<bool> s64;
  for (const auto& kv : cloud.point_scalars) s64.push_back(all_double || !float_keeps_field(kv.second));
  write_file_atomically(path, [&](std::ostream& out) {
    const char* ps = p64 ? " 8" : " 4";
    std::string names = "x y z", sizes = std::string(ps) + ps + ps, types = "F F F", counts = "1 1 1";
    if (normals) {
      names += " normal_x normal_y normal_z";
      sizes += all_double ? " 8 8 8" : " 4 4 4";
      types += " F F F";
      counts += " 1 1 1";
    }
    if (colors) {
      names += " rgb";
      sizes += " 4";
      types += " U";
      counts += " 1";
    }  // packed as PCL 1.13 writes it
    size_t k = 0;
    for (const auto& kv : cloud.point_scalars) {
      names += " " + kv.first;
      sizes += s64[k++] ? " 8" : " 4";
      types += " F";
      counts += " 1";
    }
    out << "# .PCD v0.7 - written by posekit\nVERSION 0.7\nFIELDS " << names << "\nSIZE " << sizes.substr(1) << "\nTYPE " << types
        << "\nCOUNT " << counts << "\nWIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA "
        << (binary ? "binary" : "ascii") << "\n";
    std::string rec;
    auto put_value = [&](double v, bool wide) {
      if (binary) {
        if (wide) rec.append(reinterpret_cast<const char*>(&v), 8);
        else {
          const float f = static_cast<float>(v);
          rec.append(reinterpret_cast<const char*>(&f), 4);
        }
      }
    };
    for (Eigen::Index i = 0; i < n; ++i) {
      std::uint32_t bits = 0;
      if (colors) bits = (std::uint32_t(cloud.C(i, 0)) << 16) | (std::uint32_t(cloud.C(i, 1)) << 8) | cloud.C(i, 2);
      if (binary) {
        rec.clear();
        for (int c = 0; c < 3; ++c) put_value(cloud.P(i, c) * scale, p64);
        if (normals)
          for (int c = 0; c < 3; ++c) put_value(cloud.N(i, c), all_double);
        if (colors) rec.append(reinterpret_cast<const char*>(&bits), 4);
        k = 0;
        for (const auto& kv : cloud.point_scalars) put_value(kv.second[i], s64[k++]);
        out.write(rec.data(), static_cast<std::streamsize>(rec.size()));
        continue;
      }
      // ascii: the text of each value as the binary file would hold it
      for (int c = 0; c < 3; ++c) {
        if (c) out << ' ';
        if (p64) put_number(out, cloud.P(i, c), scale);
        else put_number(out, static_cast<float>(cloud.P(i, c) * scale));
      }
      if (normals)
        for (int c = 0; c < 3; ++c) {
          out << ' ';
          if (all_double) put_number(out, cloud.N(i, c));
          else put_number(out, static_cast<float>(cloud.N(i, c)));
        }
      if (colors) out << ' ' << bits;
      k = 0;
      for (const auto& kv : cloud.point_scalars) {
        out << ' ';
        if (s64[k++]) put_number(out, kv.second[i]);
        else put_number(out, static_cast<float>(kv.second[i]));
      }
      out << '\n';
    }
  });
}

// ---------------------------------------------------------------- XYZ / PTS / TXT columns
enum class Column { kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kScalar };

/// A column name of a `//X Y Z R G B ...` header (CloudCompare, Agisoft) or of a bare name line.
Column column_of_name(std::string name) {
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return std::tolower(c); });
  if (name == "x") return Column::kX;
  if (name == "y") return Column::kY;
  if (name == "z") return Column::kZ;
  if (name == "nx" || name == "normal_x" || name == "normalx") return Column::kNx;
  if (name == "ny" || name == "normal_y" || name == "normaly") return Column::kNy;
  if (name == "nz" || name == "normal_z" || name == "normalz") return Column::kNz;
  if (name == "r" || name == "red") return Column::kRed;
  if (name == "g" || name == "green") return Column::kGreen;
  if (name == "b" || name == "blue") return Column::kBlue;
  return Column::kScalar;
}

/// Names from a header line: "//X,Y,Z,R,G,B", "# x y z nx ny nz", "X Y Z Intensity".
std::vector<std::string> header_names(std::string_view line) {
  while (!line.empty() && (line.front() == '/' || line.front() == '#' || is_space(line.front()))) line.remove_prefix(1);
  std::string text(line);
  std::replace(text.begin(), text.end(), ',', ' ');
  std::replace(text.begin(), text.end(), ';', ' ');
  std::vector<std::string_view> tok;
  split(text, tok);
  return std::vector<std::string>(tok.begin(), tok.end());
}

/// A line of names only ("X Y Z Intensity"): no token is a number.
bool is_name_line(const std::vector<std::string_view>& tok) {
  double v;
  return std::none_of(tok.begin(), tok.end(), [&](std::string_view t) { return parse_double(t, v); });
}

/// How to read unnamed columns 4.. of an XYZ file from their values (#rows x #cols, row-major):
/// three unit-length columns are normals, three integer 0..255 columns (not all 0/1) colours, a
/// fourth column of a 4- or 7-column file is intensity (PTS) unless a 7-column file reads as RGBA,
/// anything else a scalar field.
std::vector<Column> guess_columns(const std::vector<double>& v, size_t cols, bool pts_count, std::vector<std::string>& names,
                                  const std::string& path, std::vector<std::string>* warnings) {
  const size_t rows = v.size() / cols;
  std::vector<Column> out(cols, Column::kScalar);
  out[0] = Column::kX, out[1] = Column::kY, out[2] = Column::kZ;
  names.assign(cols, "");
  auto is_normals = [&](size_t c) {
    for (size_t r = 0; r < rows; ++r) {
      const double* p = &v[r * cols + c];
      const double len2 = p[0] * p[0] + p[1] * p[1] + p[2] * p[2];
      if (!(std::abs(len2 - 1.0) < 2e-3)) return false;
    }
    return true;
  };
  auto is_colors = [&](size_t c) {
    bool above_one = false;
    for (size_t r = 0; r < rows; ++r)
      for (size_t k = c; k < c + 3; ++k) {
        const double x = v[r * cols + k];
        if (!(x >= 0 && x <= 255 && x == std::floor(x))) return false;
        above_one |= x > 1;
      }
    return above_one;
  };
  auto column_is = [&](size_t c, auto&& test) {
    for (size_t r = 0; r < rows; ++r)
      if (!test(v[r * cols + c], v[c])) return false;
    return true;
  };
  const bool seventh_constant = cols == 7 && column_is(6, [](double x, double first) { return x == first; });
  const bool seventh_colour_like = cols == 7 && column_is(6, [](double x, double) { return x >= 0 && x <= 255 && x == std::floor(x); });
  size_t c = 3;
  std::string said;
  // X Y Z R G B A against PTS's X Y Z I R G B: colours in columns 4-6 and a constant (or, without a
  // PTS count line, a 0..255) seventh column are RGBA.
  if (cols == 7 && rows > 0 && is_colors(3) && seventh_colour_like && (seventh_constant || !pts_count)) {
    out[3] = Column::kRed, out[4] = Column::kGreen, out[5] = Column::kBlue;
    names[6] = "alpha";
    said += ", columns 4-6 as RGB colours (0..255) and column 7 as the scalar field alpha";
    c = 7;
  } else if ((cols == 4 || cols == 7) && rows > 0) {
    names[3] = "intensity";
    said += ", column 4 as intensity";
    c = 4;
  }
  while (c < cols) {
    if (c + 3 <= cols && is_normals(c)) {
      out[c] = Column::kNx, out[c + 1] = Column::kNy, out[c + 2] = Column::kNz;
      said += ", columns " + std::to_string(c + 1) + "-" + std::to_string(c + 3) + " as normals (unit length)";
      c += 3;
    } else if (c + 3 <= cols && is_colors(c)) {
      out[c] = Column::kRed, out[c + 1] = Column::kGreen, out[c + 2] = Column::kBlue;
      said += ", columns " + std::to_string(c + 1) + "-" + std::to_string(c + 3) + " as RGB colours (0..255)";
      c += 3;
    } else {
      names[c] = "column_" + std::to_string(c + 1);
      said += ", column " + std::to_string(c + 1) + " as the scalar field " + names[c];
      ++c;
    }
  }
  if (!said.empty())
    warn(warnings,
         path + ": no header names the columns: read" + said.substr(1) + " (name them with a first line such as '//X Y Z R G B')");
  return out;
}

PointCloud read_xyz(const std::string& path, double scale, std::vector<std::string>* warnings) {
  const std::string bytes = read_file_bytes(path);
  if (bytes.find('\0') != std::string::npos) throw IoError(path + ": contains NUL bytes: expected a text XYZ file");
  LineScanner lines(bytes, path);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<double> values;
  std::vector<std::string> names;
  size_t columns = 0;
  long long declared = -1;  // sum of PTS count lines
  std::string buffer;
  while (lines.next(line)) {
    const std::string_view text = trim(line);
    if (text.empty()) continue;
    if (text[0] == '#' || text[0] == '/' || text[0] == '%') {
      if (columns == 0) names = header_names(text);  // the last comment before the data may name the columns
      continue;
    }
    if (text.find_first_of(",;") != std::string_view::npos) {
      buffer.assign(text);
      std::replace(buffer.begin(), buffer.end(), ',', ' ');
      std::replace(buffer.begin(), buffer.end(), ';', ' ');
      split(buffer, tok);
    } else {
      split(text, tok);
    }
    if (tok.size() == 1) {  // PTS (Leica, Open3D): a point count before the points
      const long long count = lines.to_int(tok[0], "the point count of a PTS file");
      if (count < 0 || count > static_cast<long long>(bytes.size())) lines.fail("implausible point count " + std::to_string(count));
      declared = std::max(declared, 0LL) + count;
      continue;
    }
    if (columns == 0 && is_name_line(tok)) {  // a bare header line such as "X Y Z Intensity"
      names = header_names(text);
      continue;
    }
    if (columns == 0) {
      columns = tok.size();
      if (columns < 3) lines.fail("expected 'x y z [more columns]'");
      if (names.size() != columns) names.clear();
    }
    if (tok.size() != columns)
      lines.fail("expected " + std::to_string(columns) + " values like the first point, got " + std::to_string(tok.size()));
    for (size_t k = 0; k < columns; ++k) values.push_back(lines.to_double(tok[k], k < 3 ? "a coordinate" : "a value"));
  }
  if (values.empty()) throw IoError(path + ": no points: expected lines 'x y z [more columns]'");
  const auto n = static_cast<Eigen::Index>(values.size() / columns);
  if (declared >= 0 && declared != n)
    throw IoError(path + ": the point count line(s) declare " + std::to_string(declared) + " points, the file has " + std::to_string(n));
  std::vector<Column> kind;
  if (!names.empty()) {
    for (const std::string& name : names) kind.push_back(column_of_name(name));
  } else {
    kind = guess_columns(values, columns, declared >= 0, names, path, warnings);
  }
  auto index_of = [&](Column c) {
    const auto it = std::find(kind.begin(), kind.end(), c);
    return it == kind.end() ? -1 : static_cast<int>(it - kind.begin());
  };
  const int ix = index_of(Column::kX), iy = index_of(Column::kY), iz = index_of(Column::kZ);
  if (ix < 0 || iy < 0 || iz < 0) throw IoError(path + ": the header names no X, Y and Z columns");
  const int inx = index_of(Column::kNx), iny = index_of(Column::kNy), inz = index_of(Column::kNz);
  const int ir = index_of(Column::kRed), ig = index_of(Column::kGreen), ib = index_of(Column::kBlue);
  const bool normals = inx >= 0 && iny >= 0 && inz >= 0, colors = ir >= 0 && ig >= 0 && ib >= 0;
  double color_unit = 1.0;  // named colours may be 0..1 floats
  if (colors) {
    double top = 0;
    for (Eigen::Index i = 0; i < n; ++i)
      for (int c : {ir, ig, ib}) top = std::max(top, values[i * columns + c]);
    if (top <= 1.0) color_unit = 255.0;
  }
  PointCloud cloud;
  cloud.P.resize(n, 3);
  if (normals) cloud.N.resize(n, 3);
  if (colors) cloud.C.resize(n, 3);
  for (size_t k = 0; k < columns; ++k) {
    const bool used =
        kind[k] != Column::kScalar && (kind[k] <= Column::kZ || (normals && kind[k] <= Column::kNz) || (colors && kind[k] >= Column::kRed));
    if (!used) cloud.point_scalars[names[k].empty() ? "column_" + std::to_string(k + 1) : names[k]].resize(n);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const double* row = &values[i * columns];
    cloud.P.row(i) << row[ix] * scale, row[iy] * scale, row[iz] * scale;
    if (normals) cloud.N.row(i) << row[inx], row[iny], row[inz];
    if (colors)
      for (int c = 0; c < 3; ++c)
        cloud.C(i, c) = static_cast<std::uint8_t>(std::clamp(std::lround(row[(c == 0 ? ir : c == 1 ? ig : ib)] * color_unit), 0L, 255L));
    for (size_t k = 0; k < columns; ++k) {
      auto it = cloud.point_scalars.find(names[k].empty() ? "column_" + std::to_string(k + 1) : names[k]);
      if (it != cloud.point_scalars.end()) it->second[i] = row[k];
    }
  }
  return cloud;
}

void write_xyz(const std::string& path, const PointCloud& cloud, double scale) {
  write_file_atomically(
      path,
      [&](std::ostream& out) {
        const bool normals = cloud.has_normals(), colors = cloud.has_colors();
        if (normals || colors || !cloud.point_scalars.empty()) {  // name the columns beyond x y z
          out << "//X Y Z";
          if (colors) out << " R G B";
          if (normals) out << " Nx Ny Nz";
          for (const auto& kv : cloud.point_scalars) out << ' ' << kv.first;
          out << '\n';
        }
        for (Eigen::Index i = 0; i < cloud.size(); ++i) {
          for (int k = 0; k < 3; ++k) {
            if (k) out << ' ';
            put_number(out, cloud.P(i, k), scale);
          }
          if (colors) out << ' ' << int(cloud.C(i, 0)) << ' ' << int(cloud.C(i, 1)) << ' ' << int(cloud.C(i, 2));
          if (normals)
            for (int k = 0; k < 3; ++k) out << ' ', put_number(out, cloud.N(i, k));
          for (const auto& kv : cloud.point_scalars) out << ' ', put_number(out, kv.second[i]);
          out << '\n';
        }
      },
      false);
}

/// The one rule for every cloud format: points with a NaN or infinite coordinate are dropped
/// (organised clouds mark missing returns so), and the caller is told how many.
void drop_non_finite_points(PointCloud& cloud, const std::string& path, std::vector<std::string>* warnings) {
  if (cloud.P.allFinite()) return;  // the usual case: one pass down the columns, nothing copied
  std::vector<Eigen::Index> keep;
  for (Eigen::Index i = 0; i < cloud.size(); ++i)
    if (cloud.P.row(i).allFinite()) keep.push_back(i);
  const auto n = static_cast<Eigen::Index>(keep.size());
  warn(warnings, path + ": dropped " + std::to_string(cloud.size() - n) + " of " + std::to_string(cloud.size()) +
                     " points with a NaN or infinite coordinate");
  PointCloud kept;
  kept.P.resize(n, 3);
  if (cloud.has_normals()) kept.N.resize(n, 3);
  if (cloud.has_colors()) kept.C.resize(n, 3);
  for (const auto& kv : cloud.point_scalars) kept.point_scalars[kv.first].resize(n);
  for (Eigen::Index i = 0; i < n; ++i) {
    kept.P.row(i) = cloud.P.row(keep[i]);
    if (cloud.has_normals()) kept.N.row(i) = cloud.N.row(keep[i]);
    if (cloud.has_colors()) kept.C.row(i) = cloud.C.row(keep[i]);
    for (auto& kv : kept.point_scalars) kv.second[i] = cloud.point_scalars.at(kv.first)[keep[i]];
  }
  cloud = std::move(kept);
}

CloudFormat resolve(const std::string& path, CloudFormat format) {
  if (format != CloudFormat::kAuto) return format;
  const CloudFormat f = cloud_format_from_path(path);
  if (f == CloudFormat::kAuto)
    throw IoError(path + ": unknown point cloud extension '" + lower_extension(path) +
                  "': expected .pcd, .ply, .xyz, .txt, .pts, .obj or .off");
  return f;
}

}  // namespace

CloudFormat cloud_format_from_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".pcd") return CloudFormat::kPcd;
  if (ext == ".ply") return CloudFormat::kPly;
  if (ext == ".xyz" || ext == ".txt" || ext == ".pts") return CloudFormat::kXyz;
  if (ext == ".obj") return CloudFormat::kObj;
  if (ext == ".off") return CloudFormat::kOff;
  return CloudFormat::kAuto;
}

PointCloud read_point_cloud(const std::string& path, const CloudReadOptions& options) {
  const double scale = metres_per_unit(options.unit);
  PointCloud cloud;
  auto take_mesh_vertices = [&](TriangleMesh mesh) {
    cloud.P = std::move(mesh.V);
    cloud.N = std::move(mesh.N);
    cloud.C = std::move(mesh.C);
    cloud.point_scalars = std::move(mesh.vertex_scalars);
  };
  switch (resolve(path, options.format)) {
    case CloudFormat::kPcd:
      cloud = read_pcd(path, scale);
      break;
    case CloudFormat::kXyz:
      cloud = read_xyz(path, scale, options.warnings);
      break;
    case CloudFormat::kObj:
      take_mesh_vertices(read_obj(path, scale, nullptr));
      break;
    case CloudFormat::kOff:
      take_mesh_vertices(read_off(path, scale));
      break;
    case CloudFormat::kPly: {
      PlyContent c = read_ply(path, scale, false, options.warnings);
      cloud.P = std::move(c.V);
      cloud.N = std::move(c.N);
      cloud.C = std::move(c.C);
      cloud.point_scalars = std::move(c.scalars);
      if (c.UV.rows() > 0) cloud.point_scalars["texture_u"] = c.UV.col(0), cloud.point_scalars["texture_v"] = c.UV.col(1);
      break;
    }
    case CloudFormat::kAuto:
      break;
  }
  const Eigen::Index read = cloud.size();
  drop_non_finite_points(cloud, path, options.warnings);
  if (cloud.size() == 0)
    throw IoError(path + ": no points" +
                  (read > 0 ? " with finite coordinates (all " + std::to_string(read) + " are NaN or infinite)"
                            : std::string(": the file holds an empty cloud")));
  return cloud;
}

void write_point_cloud(const std::string& path, const PointCloud& cloud, const CloudWriteOptions& options) {
  if (cloud.P.cols() != 3 && cloud.P.rows() > 0) throw InvalidInput(path + ": expected P #P x 3");
  for (Eigen::Index i = 0; i < cloud.size(); ++i)
    if (!cloud.P.row(i).allFinite()) throw InvalidInput(path + ": point " + std::to_string(i) + " has a non-finite coordinate");
  for (const auto& kv : cloud.point_scalars)
    if (kv.second.size() != cloud.size())
      throw InvalidInput(path + ": scalar field '" + kv.first + "' has " + std::to_string(kv.second.size()) +
                         " values, expected one per point");
  const double scale = 1.0 / metres_per_unit(options.unit);
  switch (resolve(path, options.format)) {
    case CloudFormat::kPcd:
      write_pcd(path, cloud, scale, options.binary, options.double_precision);
      break;
    case CloudFormat::kXyz:
      write_xyz(path, cloud, scale);
      break;
    case CloudFormat::kPly:
      write_ply(path,
                PlyContent{cloud.P,
                           cloud.has_normals() ? cloud.N : Eigen::MatrixXd(),
                           cloud.has_colors() ? cloud.C : RowMatrixX3u8(),
                           Eigen::MatrixXd(),
                           cloud.point_scalars,
                           Eigen::MatrixXi(),
                           {}},
                options.binary, scale, options.double_precision);
      break;
    case CloudFormat::kObj:
    case CloudFormat::kOff: {
      // A point cloud as a mesh file without faces: the vertices, their normals and colours.
      TriangleMesh points;
      points.V = cloud.P;
      if (cloud.has_normals()) points.N = cloud.N;
      if (cloud.has_colors()) points.C = cloud.C;
      for (const auto& kv : cloud.point_scalars)
        warn(options.warnings, path + ": " + (resolve(path, options.format) == CloudFormat::kObj ? "OBJ" : "OFF") +
                                   " cannot hold the scalar field " + kv.first + ": not written");
      if (resolve(path, options.format) == CloudFormat::kObj) write_obj(path, points, scale);
      else write_off(path, points, scale);
      break;
    }
    case CloudFormat::kAuto:
      break;
  }
}

}  // namespace posekit
