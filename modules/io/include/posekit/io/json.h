#pragma once
// JSON input with the checks posekit's own files need.
#include <string>

#include <nlohmann/json_fwd.hpp>

namespace posekit {

/// Parses JSON text, refusing a key repeated in one object (nlohmann would keep the last one, so a
/// pose with a joint given twice would silently lose the first). `context` (a file name) starts
/// every message. Throws IoError (not JSON) or InvalidInput (a duplicate key, named with its object).
nlohmann::json parse_json(const std::string& text, const std::string& context);

/// Reads and parses a JSON file (nlohmann's rules). Throws IoError naming `path` when it cannot be
/// read or is not JSON.
nlohmann::json read_json_file(const std::string& path);

}  // namespace posekit
