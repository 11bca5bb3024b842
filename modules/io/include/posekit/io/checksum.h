#pragma once
// Integrity checks of posekit's own binary files.
#include <cstddef>
#include <cstdint>

namespace posekit {

/// CRC-32 (IEEE 802.3, the polynomial of zlib and PNG) of `size` bytes, continuing from `crc`
/// (0 to start). crc32("123456789") == 0xCBF43926.
std::uint32_t crc32(const void* data, std::size_t size, std::uint32_t crc = 0);

}  // namespace posekit
