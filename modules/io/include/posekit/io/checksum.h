#pragma once
// Integrity checks of posekit's own binary files.
#include <cstddef>
#include <cstdint>
#include <string>

namespace posekit {

/// CRC-32 (IEEE 802.3, the polynomial of zlib and PNG) of `size` bytes, continuing from `crc`
/// (0 to start). crc32("123456789") == 0xCBF43926.
std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

/// CRC-32 of a whole file (e.g. to redo results made from another version of it). Throws IoError.
std::uint32_t file_crc32(const std::string& path);

/// Writes `bytes` followed by their CRC-32 (4 bytes, little-endian) through a temporary file: the
/// trailer of posekit's binary formats (.pkm, .pks). Throws IoError.
void write_file_with_crc32(const std::string& path, const std::string& bytes);

}  // namespace posekit
