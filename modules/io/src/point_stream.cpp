#include "posekit/io/point_stream.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string_view>

#include "posekit/core/error.h"

namespace posekit {
namespace {

/// A coordinate's type: its size and how its bytes become a double.
enum class Scalar { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kInt64, kUint64, kFloat32, kFloat64 };

int scalar_size(Scalar s) {
  switch (s) {
    case Scalar::kInt8:
    case Scalar::kUint8:
      return 1;
    case Scalar::kInt16:
    case Scalar::kUint16:
      return 2;
    case Scalar::kInt32:
    case Scalar::kUint32:
    case Scalar::kFloat32:
      return 4;
    case Scalar::kInt64:
    case Scalar::kUint64:
    case Scalar::kFloat64:
      return 8;
  }
  return 1;
}

template <class T>
double as_double(const char* p, bool swap) {
  unsigned char b[sizeof(T)];
  std::memcpy(b, p, sizeof(T));
  if (swap)
    for (size_t k = 0; k < sizeof(T) / 2; ++k) std::swap(b[k], b[sizeof(T) - 1 - k]);
  T x;
  std::memcpy(&x, b, sizeof(T));
  return static_cast<double>(x);
}

double decode(const char* p, Scalar s, bool swap) {
  switch (s) {
    case Scalar::kInt8:
      return as_double<std::int8_t>(p, swap);
    case Scalar::kUint8:
      return as_double<std::uint8_t>(p, swap);
    case Scalar::kInt16:
      return as_double<std::int16_t>(p, swap);
    case Scalar::kUint16:
      return as_double<std::uint16_t>(p, swap);
    case Scalar::kInt32:
      return as_double<std::int32_t>(p, swap);
    case Scalar::kUint32:
      return as_double<std::uint32_t>(p, swap);
    case Scalar::kInt64:
      return as_double<std::int64_t>(p, swap);
    case Scalar::kUint64:
      return as_double<std::uint64_t>(p, swap);
    case Scalar::kFloat32:
      return as_double<float>(p, swap);
    case Scalar::kFloat64:
      return as_double<double>(p, swap);
  }
  return 0;
}

bool ply_scalar(std::string_view t, Scalar* s) {
  if (t == "char" || t == "int8") *s = Scalar::kInt8;
  else if (t == "uchar" || t == "uint8") *s = Scalar::kUint8;
  else if (t == "short" || t == "int16") *s = Scalar::kInt16;
  else if (t == "ushort" || t == "uint16") *s = Scalar::kUint16;
  else if (t == "int" || t == "int32") *s = Scalar::kInt32;
  else if (t == "uint" || t == "uint32") *s = Scalar::kUint32;
  else if (t == "float" || t == "float32") *s = Scalar::kFloat32;
  else if (t == "double" || t == "float64") *s = Scalar::kFloat64;
  else return false;
  return true;
}

bool pcd_scalar(char type, int size, Scalar* s) {
  const Scalar float_types[] = {Scalar::kFloat32, Scalar::kFloat64};
  const Scalar signed_types[] = {Scalar::kInt8, Scalar::kInt16, Scalar::kInt32, Scalar::kInt64};
  const Scalar unsigned_types[] = {Scalar::kUint8, Scalar::kUint16, Scalar::kUint32, Scalar::kUint64};
  const int log2_size = size == 1 ? 0 : size == 2 ? 1 : size == 4 ? 2 : size == 8 ? 3 : -1;
  if (log2_size < 0) return false;
  if (type == 'F' && log2_size >= 2) *s = float_types[log2_size - 2];
  else if (type == 'I') *s = signed_types[log2_size];
  else if (type == 'U') *s = unsigned_types[log2_size];
  else return false;
  return true;
}

std::vector<std::string_view> words(std::string_view line) {
  std::vector<std::string_view> out;
  size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t' || line[i] == '\r')) ++i;
    const size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t' && line[i] != '\r') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

bool to_count(std::string_view s, long long* v) {
  if (s.empty() || s.size() > 18) return false;
  long long x = 0;
  for (char c : s) {
    if (c < '0' || c > '9') return false;
    x = 10 * x + (c - '0');
  }
  *v = x;
  return true;
}

constexpr Eigen::Index kBlock = 256;  // records per block of the finite-point index (a read walks at most one)

}  // namespace

struct PointStream::Impl {
  int fd = -1;
  const char* data = nullptr;  // the whole file, mapped (not populated)
  size_t size = 0;
  size_t data_start = 0, record = 0, offset[3] = {0, 0, 0};
  Scalar type[3] = {Scalar::kFloat32, Scalar::kFloat32, Scalar::kFloat32};
  bool swap = false;
  double scale = 1;
  long long records = 0;
  Eigen::Index finite = 0;
  bool all_finite = true;
  std::vector<Eigen::Index> block_start;  // finite points before each block of kBlock records

  ~Impl() {
    if (data) ::munmap(const_cast<char*>(data), size);
    if (fd >= 0) ::close(fd);
  }

  double coordinate(long long r, int k) const {
    return decode(data + data_start + static_cast<size_t>(r) * record + offset[k], type[k], swap) * scale;
  }
  bool finite_record(long long r) const {
    return std::isfinite(coordinate(r, 0)) && std::isfinite(coordinate(r, 1)) && std::isfinite(coordinate(r, 2));
  }

  /// Parses a binary PLY header whose first element is 'vertex' with fixed-size x, y, z.
  bool parse_ply(std::string_view header) {
    bool vertex = false, format = false, file_big_endian = false;
    size_t at = 0;
    int found = 0;
    std::istringstream lines{std::string(header)};
    std::string line;
    std::getline(lines, line);  // "ply"
    while (std::getline(lines, line)) {
      const auto w = words(line);
      if (w.empty() || w[0] == "comment" || w[0] == "obj_info") continue;
      if (w[0] == "format") {
        if (w.size() < 2) return false;
        if (w[1] == "binary_little_endian") file_big_endian = false;
        else if (w[1] == "binary_big_endian") file_big_endian = true;
        else return false;
        format = true;
      } else if (w[0] == "element") {
        if (vertex) break;  // vertex first; what follows it does not matter
        if (w.size() != 3 || w[1] != "vertex" || !to_count(w[2], &records)) return false;
        vertex = true;
      } else if (w[0] == "property") {
        if (!vertex || w.size() != 3) return false;  // a list, or a property before the vertex element
        Scalar s;
        if (!ply_scalar(w[1], &s)) return false;
        const int k = w[2] == "x" ? 0 : w[2] == "y" ? 1 : w[2] == "z" ? 2 : -1;
        if (k >= 0) offset[k] = at, type[k] = s, found |= 1 << k;
        at += static_cast<size_t>(scalar_size(s));
      } else if (w[0] == "end_header") {
        break;
      } else {
        return false;
      }
    }
    if (!format || !vertex || found != 7) return false;
    const std::uint16_t one = 1;
    unsigned char first_byte;
    std::memcpy(&first_byte, &one, 1);
    swap = file_big_endian == (first_byte == 1);  // the file's byte order is not the host's
    record = at;
    return true;
  }

  /// Parses a PCD header with DATA binary and x, y, z fields of one value each.
  bool parse_pcd(std::string_view header) {
    std::vector<std::string> names;
    std::vector<int> sizes, counts;
    std::vector<char> types;
    long long width = -1, height = -1, points = -1;
    bool binary = false;
    std::istringstream lines{std::string(header)};
    std::string line;
    while (std::getline(lines, line)) {
      const auto w = words(line);
      if (w.empty() || w[0][0] == '#') continue;
      if (w[0] == "FIELDS" || w[0] == "COLUMNS") {
        for (size_t i = 1; i < w.size(); ++i) names.emplace_back(w[i]);
      } else if (w[0] == "SIZE" || w[0] == "COUNT") {
        for (size_t i = 1; i < w.size(); ++i) {
          long long v;
          if (!to_count(w[i], &v) || v < 1 || v > (1 << 20)) return false;
          (w[0] == "SIZE" ? sizes : counts).push_back(static_cast<int>(v));
        }
      } else if (w[0] == "TYPE") {
        for (size_t i = 1; i < w.size(); ++i) {
          if (w[i].size() != 1) return false;
          types.push_back(w[i][0]);
        }
      } else if (w[0] == "WIDTH" || w[0] == "HEIGHT" || w[0] == "POINTS") {
        long long v;
        if (w.size() != 2 || !to_count(w[1], &v)) return false;
        (w[0] == "WIDTH" ? width : w[0] == "HEIGHT" ? height : points) = v;
      } else if (w[0] == "DATA") {
        binary = w.size() == 2 && w[1] == "binary";
      }
    }
    if (!binary || names.empty() || sizes.size() != names.size() || types.size() != names.size() || width < 0 || height < 0) return false;
    if (counts.empty()) counts.assign(names.size(), 1);
    if (counts.size() != names.size() || width > (1LL << 31) || height > (1LL << 31)) return false;
    if (points < 0) points = width * height;
    if (points != width * height) return false;
    int found = 0;
    size_t at = 0;
    for (size_t i = 0; i < names.size(); ++i) {
      const int k = names[i] == "x" ? 0 : names[i] == "y" ? 1 : names[i] == "z" ? 2 : -1;
      if (k >= 0) {
        if (counts[i] != 1 || !pcd_scalar(types[i], sizes[i], &type[k])) return false;
        offset[k] = at, found |= 1 << k;
      }
      at += static_cast<size_t>(sizes[i]) * static_cast<size_t>(counts[i]);
    }
    if (found != 7) return false;
    record = at;
    records = points;
    return true;
  }
};

PointStream::PointStream(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
PointStream::~PointStream() = default;

std::unique_ptr<PointStream> PointStream::open(const std::string& path, double scale, std::vector<std::string>* warnings) {
  auto s = std::make_unique<Impl>();
  s->scale = scale;
  s->fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  struct stat st {};
  if (s->fd < 0 || ::fstat(s->fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size < 16) return nullptr;
  s->size = static_cast<size_t>(st.st_size);
  void* m = ::mmap(nullptr, s->size, PROT_READ, MAP_PRIVATE, s->fd, 0);
  if (m == MAP_FAILED) return nullptr;
  s->data = static_cast<const char*>(m);
  const std::string_view bytes(s->data, s->size);
  const bool ply = bytes.compare(0, 4, "ply\n") == 0 || bytes.compare(0, 5, "ply\r\n") == 0;
  size_t end;
  if (ply) {
    end = bytes.find("end_header");
    if (end == std::string_view::npos || end > (1u << 20)) return nullptr;
    end = bytes.find('\n', end);
    if (end == std::string_view::npos || !s->parse_ply(bytes.substr(0, end))) return nullptr;
  } else {
    end = bytes.find("\nDATA ");
    if (end == std::string_view::npos || end > (1u << 20)) return nullptr;
    end = bytes.find('\n', end + 1);
    if (end == std::string_view::npos || !s->parse_pcd(bytes.substr(0, end))) return nullptr;
  }
  s->data_start = end + 1;
  if (s->record == 0 || (s->size - s->data_start) / s->record < static_cast<size_t>(s->records)) return nullptr;
  // The finite points, block by block, releasing the pages as it goes.
  ::madvise(m, s->size, MADV_SEQUENTIAL);
  const long long blocks = (s->records + kBlock - 1) / kBlock;
  s->block_start.resize(static_cast<size_t>(blocks) + 1);
  for (long long b = 0; b < blocks; ++b) {
    s->block_start[static_cast<size_t>(b)] = s->finite;
    const long long last = std::min<long long>(s->records, (b + 1) * kBlock);
    for (long long r = b * kBlock; r < last; ++r) s->finite += s->finite_record(r);
  }
  s->block_start.back() = s->finite;
  s->all_finite = s->finite == s->records;
  if (!s->all_finite && warnings)
    warnings->push_back(path + ": dropped " + std::to_string(s->records - s->finite) + " of " + std::to_string(s->records) +
                        " points with a NaN or infinite coordinate");
  if (s->finite == 0) return nullptr;  // read_point_cloud says why
  std::unique_ptr<PointStream> stream(new PointStream(std::move(s)));
  stream->release(stream->size());
  return stream;
}

Eigen::Index PointStream::size() const { return impl_->finite; }

void PointStream::read(Eigen::Index first, Eigen::Index count, Eigen::MatrixXd* P) const {
  const Impl& s = *impl_;
  if (first < 0 || count < 0 || first + count > s.finite)
    throw InvalidInput("PointStream::read: points " + std::to_string(first) + " to " + std::to_string(first + count) + " of " +
                       std::to_string(s.finite));
  P->resize(count, 3);
  if (count == 0) return;
  // The record of finite point `first`: its block, then a walk within it.
  long long r = first;
  if (!s.all_finite) {
    const auto b =
        static_cast<long long>(std::upper_bound(s.block_start.begin(), s.block_start.end() - 1, first) - s.block_start.begin()) - 1;
    Eigen::Index at = s.block_start[static_cast<size_t>(b)];
    r = b * kBlock;
    while (true) {
      if (s.finite_record(r)) {
        if (at == first) break;
        ++at;
      }
      ++r;
    }
  }
  for (Eigen::Index i = 0; i < count; ++r) {
    if (!s.all_finite && !s.finite_record(r)) continue;
    for (int k = 0; k < 3; ++k) (*P)(i, k) = s.coordinate(r, k);
    ++i;
  }
}

void PointStream::release(Eigen::Index end) const {
  const Impl& s = *impl_;
  long long r = std::min<long long>(end, s.finite);
  if (!s.all_finite) r = s.records;  // the mapping is shared by every range: drop it all
  const size_t page = static_cast<size_t>(::sysconf(_SC_PAGESIZE));
  const size_t bytes = (s.data_start + static_cast<size_t>(r) * s.record) / page * page;
  if (bytes > 0) ::madvise(const_cast<char*>(s.data), bytes, MADV_DONTNEED);
}

}  // namespace posekit
