#include "posekit/io/checksum.h"

#include <array>

#include "posekit/io/atomic_file.h"

namespace posekit {
namespace {

std::array<std::uint32_t, 256> make_table() {
  std::array<std::uint32_t, 256> table{};
  for (std::uint32_t i = 0; i < 256; ++i) {
    std::uint32_t c = i;
    for (int k = 0; k < 8; ++k) c = (c & 1u) ? 0xEDB88320u ^ (c >> 1) : c >> 1;
    table[i] = c;
  }
  return table;
}

}  // namespace

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  static const std::array<std::uint32_t, 256> table = make_table();
  const auto* p = static_cast<const unsigned char*>(data);
  crc = ~crc;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ p[i]) & 0xFFu] ^ (crc >> 8);
  return ~crc;
}

std::uint32_t file_crc32(const std::string& path) {
  const std::string bytes = read_file_bytes(path);
  return crc32(bytes.data(), bytes.size());
}

void write_file_with_crc32(const std::string& path, const std::string& bytes) {
  const std::uint32_t crc = crc32(bytes.data(), bytes.size());
  write_file_atomically(path, [&](std::ostream& out) {
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    out.write(reinterpret_cast<const char*>(&crc), sizeof crc);
  });
}

}  // namespace posekit
