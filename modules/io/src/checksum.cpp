#include "posekit/io/checksum.h"

#include <zlib.h>

#include "posekit/io/atomic_file.h"

namespace posekit {

std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc) {
  // zlib's CRC-32: the same polynomial and conventions, several bytes a step.
  if (size == 0) return crc;
  return static_cast<std::uint32_t>(::crc32_z(crc, static_cast<const Bytef*>(data), size));
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
