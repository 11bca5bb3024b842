#pragma once
// Internal to posekit_core: one key per undirected edge, shared by the topology and the slicer.

#include <algorithm>
#include <cstdint>

namespace posekit {
namespace core_detail {

/// (min << 32) | max of an edge's two vertex indices: the same key for (a, b) and (b, a).
inline std::uint64_t undirected_edge_key(int a, int b) {
  const auto lo = static_cast<std::uint32_t>(std::min(a, b)), hi = static_cast<std::uint32_t>(std::max(a, b));
  return (static_cast<std::uint64_t>(lo) << 32) | hi;
}

}  // namespace core_detail
}  // namespace posekit
