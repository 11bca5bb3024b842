#pragma once
// Tables of an enumeration's values and their names (the evaluations' variations and conditions).
#include <string>
#include <utility>
#include <vector>

#include "posekit/core/error.h"

namespace posekit {

template <typename E, size_t N>
using NameTable = std::pair<E, const char*>[N];

/// Every value of the table, in its order.
template <typename E, size_t N>
std::vector<E> table_values(const NameTable<E, N>& table) {
  std::vector<E> out;
  for (const auto& entry : table) out.push_back(entry.first);
  return out;
}

/// The name of `value` ("?" when the table lacks it).
template <typename E, size_t N>
const char* table_name(const NameTable<E, N>& table, E value) {
  for (const auto& [k, name] : table)
    if (k == value) return name;
  return "?";
}

/// The value named `name`; throws InvalidInput "unknown <what> '<name>' (one of: ...)".
template <typename E, size_t N>
E parse_table_name(const NameTable<E, N>& table, const std::string& name, const std::string& what) {
  std::string list;
  for (const auto& [k, n] : table) {
    if (name == n) return k;
    list += std::string(list.empty() ? "" : ", ") + n;
  }
  throw InvalidInput("unknown " + what + " '" + name + "' (one of: " + list + ")");
}

}  // namespace posekit
