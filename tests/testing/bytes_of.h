#pragma once
#include <string>

namespace posekit::test {

/// A value's bytes as they lie in memory (little-endian here): for writing binary files by hand.
template <typename T>
std::string bytes_of(T v) {
  return std::string(reinterpret_cast<const char*>(&v), sizeof(T));
}

}  // namespace posekit::test
