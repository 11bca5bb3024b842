#include "posekit/io/point_cloud_io.h"

#include <pcl/io/lzf.h>

#include <cmath>
#include <cstring>
#include <iomanip>

#include "parse_util.h"
#include "ply_format.h"
#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit {
using namespace io_detail;

namespace {

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
      if (f.size == 4) { float x; std::memcpy(&x, p, 4); return x; }
      if (f.size == 8) { double x; std::memcpy(&x, p, 8); return x; }
      break;
    case 'I':
      if (f.size == 1) { std::int8_t x; std::memcpy(&x, p, 1); return x; }
      if (f.size == 2) { std::int16_t x; std::memcpy(&x, p, 2); return x; }
      if (f.size == 4) { std::int32_t x; std::memcpy(&x, p, 4); return x; }
      if (f.size == 8) { std::int64_t x; std::memcpy(&x, p, 8); return static_cast<double>(x); }
      break;
    case 'U':
      if (f.size == 1) { std::uint8_t x; std::memcpy(&x, p, 1); return x; }
      if (f.size == 2) { std::uint16_t x; std::memcpy(&x, p, 2); return x; }
      if (f.size == 4) { std::uint32_t x; std::memcpy(&x, p, 4); return x; }
      if (f.size == 8) { std::uint64_t x; std::memcpy(&x, p, 8); return static_cast<double>(x); }
      break;
  }
  return 0.0;
}

PointCloud read_pcd(const std::string& path, double scale) {
  const std::string bytes = read_file_bytes(path);
  LineScanner lines(bytes, path);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<PcdField> fields;
  long long width = -1, height = 1, points = -1;
  std::string data;
  while (lines.next(line)) {
    split(line, tok);
    if (tok.empty() || tok[0][0] == '#') continue;
    const std::string_view key = tok[0];
    const size_t nvals = tok.size() - 1;
    if (key == "VERSION" || key == "VIEWPOINT") continue;
    if (key == "FIELDS" || key == "COLUMNS") {
      fields.clear();
      for (size_t i = 1; i < tok.size(); ++i) fields.push_back({std::string(tok[i])});
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
  if (points < 0) points = width * height;
  if (points < 0 || width < 0 || height < 0) throw IoError(path + ": PCD header has negative WIDTH/HEIGHT/POINTS");
  int ix = -1, iy = -1, iz = -1, inx = -1, iny = -1, inz = -1;
  size_t record = 0;
  for (size_t i = 0; i < fields.size(); ++i) {
    fields[i].offset = record;
    record += static_cast<size_t>(fields[i].size) * fields[i].count;
    const std::string& n = fields[i].name;
    if (n == "x") ix = static_cast<int>(i);
    else if (n == "y") iy = static_cast<int>(i);
    else if (n == "z") iz = static_cast<int>(i);
    else if (n == "normal_x") inx = static_cast<int>(i);
    else if (n == "normal_y") iny = static_cast<int>(i);
    else if (n == "normal_z") inz = static_cast<int>(i);
  }
  if (ix < 0 || iy < 0 || iz < 0) throw IoError(path + ": PCD has no x, y, z fields");
  const bool normals = inx >= 0 && iny >= 0 && inz >= 0;
  // Raw values per point, field-major: values[field][point].
  std::vector<std::vector<double>> values(fields.size(), std::vector<double>(static_cast<size_t>(points)));
  const size_t data_start = lines.offset();
  if (data == "ascii") {
    for (long long p = 0; p < points; ++p) {
      do {
        if (!lines.next(line))
          throw IoError(path + ": point #" + std::to_string(p) + " of " + std::to_string(points) +
                        ": file ends early (the header declares more points than the file has)");
        split(line, tok);
      } while (tok.empty());
      size_t t = 0;
      for (size_t f = 0; f < fields.size(); ++f)
        for (int c = 0; c < fields[f].count; ++c, ++t) {
          if (t >= tok.size()) lines.fail("point #" + std::to_string(p) + ": too few values");
          const double v = (tok[t] == "nan" || tok[t] == "NaN") ? NAN : lines.to_double(tok[t], "a field value");
          if (c == 0) values[f][p] = v;
        }
    }
  } else if (data == "binary") {
    const size_t need = record * static_cast<size_t>(points);
    if (bytes.size() - data_start < need)
      throw IoError(path + ": binary data holds " + std::to_string((bytes.size() - data_start) / std::max<size_t>(record, 1)) +
                    " points, the header declares " + std::to_string(points) + " (truncated file)");
    const char* base = bytes.data() + data_start;
    for (long long p = 0; p < points; ++p)
      for (size_t f = 0; f < fields.size(); ++f) values[f][p] = pcd_value(base + p * record + fields[f].offset, fields[f]);
  } else if (data == "binary_compressed") {
    if (bytes.size() - data_start < 8) throw IoError(path + ": binary_compressed data is truncated");
    std::uint32_t compressed = 0, uncompressed = 0;
    std::memcpy(&compressed, bytes.data() + data_start, 4);
    std::memcpy(&uncompressed, bytes.data() + data_start + 4, 4);
    if (compressed > bytes.size() - data_start - 8 || uncompressed != record * static_cast<size_t>(points))
      throw IoError(path + ": binary_compressed sizes do not match the header (truncated or corrupt)");
    std::vector<char> raw(uncompressed);
    if (uncompressed > 0 &&
        pcl::lzfDecompress(bytes.data() + data_start + 8, compressed, raw.data(), uncompressed) != uncompressed)
      throw IoError(path + ": binary_compressed data does not decompress (corrupt)");
    size_t off = 0;
    for (size_t f = 0; f < fields.size(); ++f) {
      const size_t stride = static_cast<size_t>(fields[f].size) * fields[f].count;
      for (long long p = 0; p < points; ++p) values[f][p] = pcd_value(raw.data() + off + p * stride, fields[f]);
      off += stride * static_cast<size_t>(points);
    }
  } else {
    throw IoError(path + ": unknown DATA '" + data + "': expected ascii, binary or binary_compressed");
  }
  // Organised clouds mark missing returns with NaN: those points are dropped.
  std::vector<long long> keep;
  keep.reserve(static_cast<size_t>(points));
  for (long long p = 0; p < points; ++p)
    if (std::isfinite(values[ix][p]) && std::isfinite(values[iy][p]) && std::isfinite(values[iz][p])) keep.push_back(p);
  PointCloud cloud;
  const auto n = static_cast<Eigen::Index>(keep.size());
  cloud.P.resize(n, 3);
  if (normals) cloud.N.resize(n, 3);
  for (size_t f = 0; f < fields.size(); ++f) {
    const int fi = static_cast<int>(f);
    if (fi == ix || fi == iy || fi == iz || fi == inx || fi == iny || fi == inz || fields[f].count != 1 ||
        fields[f].name == "rgb" || fields[f].name == "rgba" || fields[f].name == "_")
      continue;
    cloud.point_scalars[fields[f].name].resize(n);
  }
  for (Eigen::Index i = 0; i < n; ++i) {
    const long long p = keep[i];
    cloud.P.row(i) << values[ix][p] * scale, values[iy][p] * scale, values[iz][p] * scale;
    if (normals) cloud.N.row(i) << values[inx][p], values[iny][p], values[inz][p];
    for (size_t f = 0; f < fields.size(); ++f) {
      auto it = cloud.point_scalars.find(fields[f].name);
      if (it != cloud.point_scalars.end()) it->second[i] = values[f][p];
    }
  }
  return cloud;
}

void write_pcd(const std::string& path, const PointCloud& cloud, double scale, bool binary) {
  const Eigen::Index n = cloud.size();
  const bool normals = cloud.has_normals();
  write_file_atomically(path, [&](std::ostream& out) {
    std::string names = "x y z", sizes = "4 4 4", types = "F F F", counts = "1 1 1";
    if (normals) { names += " normal_x normal_y normal_z"; sizes += " 4 4 4"; types += " F F F"; counts += " 1 1 1"; }
    for (const auto& kv : cloud.point_scalars) { names += " " + kv.first; sizes += " 4"; types += " F"; counts += " 1"; }
    out << "# .PCD v0.7 - written by posekit\nVERSION 0.7\nFIELDS " << names << "\nSIZE " << sizes << "\nTYPE "
        << types << "\nCOUNT " << counts << "\nWIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n
        << "\nDATA " << (binary ? "binary" : "ascii") << "\n";
    if (!binary) out << std::setprecision(9);
    std::vector<float> rec;
    for (Eigen::Index i = 0; i < n; ++i) {
      rec.clear();
      for (int k = 0; k < 3; ++k) rec.push_back(static_cast<float>(cloud.P(i, k) * scale));
      if (normals) for (int k = 0; k < 3; ++k) rec.push_back(static_cast<float>(cloud.N(i, k)));
      for (const auto& kv : cloud.point_scalars) rec.push_back(static_cast<float>(kv.second[i]));
      if (binary) {
        out.write(reinterpret_cast<const char*>(rec.data()), static_cast<std::streamsize>(rec.size() * 4));
      } else {
        for (size_t k = 0; k < rec.size(); ++k) out << (k ? " " : "") << rec[k];
        out << '\n';
      }
    }
  });
}

PointCloud read_xyz(const std::string& path, double scale) {
  const std::string bytes = read_file_bytes(path);
  if (bytes.find('\0') != std::string::npos) throw IoError(path + ": contains NUL bytes: expected a text XYZ file");
  LineScanner lines(bytes, path);
  std::string_view line;
  std::vector<std::string_view> tok;
  std::vector<double> p, nrm;
  size_t columns = 0;
  std::string buffer;
  while (lines.next(line)) {
    if (line.find(',') != std::string_view::npos) {
      buffer.assign(line);
      std::replace(buffer.begin(), buffer.end(), ',', ' ');
      line = buffer;
    }
    split(line, tok);
    if (tok.empty() || tok[0][0] == '#' || tok[0][0] == '/') continue;
    if (columns == 0) {
      columns = tok.size();
      if (columns < 3) lines.fail("expected 'x y z [nx ny nz]'");
    }
    if (tok.size() != columns)
      lines.fail("expected " + std::to_string(columns) + " values like the first point, got " + std::to_string(tok.size()));
    for (int k = 0; k < 3; ++k) {
      const double x = lines.to_double(tok[k], "a coordinate");
      if (!std::isfinite(x)) lines.fail("non-finite coordinate");
      p.push_back(x * scale);
    }
    if (columns >= 6)
      for (int k = 3; k < 6; ++k) nrm.push_back(lines.to_double(tok[k], "a normal component"));
  }
  if (p.empty()) throw IoError(path + ": no points: expected lines 'x y z [nx ny nz]'");
  PointCloud cloud;
  const auto n = static_cast<Eigen::Index>(p.size() / 3);
  cloud.P = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(p.data(), n, 3);
  if (nrm.size() == p.size()) cloud.N = Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor>>(nrm.data(), n, 3);
  return cloud;
}

void write_xyz(const std::string& path, const PointCloud& cloud, double scale) {
  write_file_atomically(path, [&](std::ostream& out) {
    out << std::setprecision(17);
    for (Eigen::Index i = 0; i < cloud.size(); ++i) {
      out << cloud.P(i, 0) * scale << ' ' << cloud.P(i, 1) * scale << ' ' << cloud.P(i, 2) * scale;
      if (cloud.has_normals()) out << ' ' << cloud.N(i, 0) << ' ' << cloud.N(i, 1) << ' ' << cloud.N(i, 2);
      out << '\n';
    }
  }, false);
}

CloudFormat resolve(const std::string& path, CloudFormat format) {
  if (format != CloudFormat::kAuto) return format;
  const CloudFormat f = cloud_format_from_path(path);
  if (f == CloudFormat::kAuto)
    throw IoError(path + ": unknown point cloud extension '" + lower_extension(path) +
                  "': expected .pcd, .ply, .xyz, .txt or .pts");
  return f;
}

}  // namespace

CloudFormat cloud_format_from_path(const std::string& path) {
  const std::string ext = lower_extension(path);
  if (ext == ".pcd") return CloudFormat::kPcd;
  if (ext == ".ply") return CloudFormat::kPly;
  if (ext == ".xyz" || ext == ".txt" || ext == ".pts") return CloudFormat::kXyz;
  return CloudFormat::kAuto;
}

PointCloud read_point_cloud(const std::string& path, const CloudReadOptions& options) {
  const double scale = metres_per_unit(options.unit);
  PointCloud cloud;
  switch (resolve(path, options.format)) {
    case CloudFormat::kPcd: cloud = read_pcd(path, scale); break;
    case CloudFormat::kXyz: cloud = read_xyz(path, scale); break;
    case CloudFormat::kPly: {
      PlyContent c = read_ply(path, scale);
      cloud.P = std::move(c.V);
      cloud.N = std::move(c.N);
      cloud.point_scalars = std::move(c.scalars);
      break;
    }
    case CloudFormat::kAuto: break;
  }
  return cloud;
}

void write_point_cloud(const std::string& path, const PointCloud& cloud, const CloudWriteOptions& options) {
  if (cloud.P.cols() != 3 && cloud.P.rows() > 0) throw InvalidInput(path + ": expected P #P x 3");
  for (Eigen::Index i = 0; i < cloud.size(); ++i)
    if (!cloud.P.row(i).allFinite())
      throw InvalidInput(path + ": point " + std::to_string(i) + " has a non-finite coordinate");
  for (const auto& kv : cloud.point_scalars)
    if (kv.second.size() != cloud.size())
      throw InvalidInput(path + ": scalar field '" + kv.first + "' has " + std::to_string(kv.second.size()) +
                         " values, expected one per point");
  const double scale = 1.0 / metres_per_unit(options.unit);
  switch (resolve(path, options.format)) {
    case CloudFormat::kPcd: write_pcd(path, cloud, scale, options.binary); break;
    case CloudFormat::kXyz: write_xyz(path, cloud, scale); break;
    case CloudFormat::kPly:
      write_ply(path, PlyContent{cloud.P, cloud.has_normals() ? cloud.N : Eigen::MatrixXd(), RowMatrixX3u8(),
                                 cloud.point_scalars, Eigen::MatrixXi()},
                options.binary, scale);
      break;
    case CloudFormat::kAuto: break;
  }
}

}  // namespace posekit
