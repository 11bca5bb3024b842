#include "posekit/io/json.h"

#include <nlohmann/json.hpp>
#include <set>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit {

nlohmann::json parse_json(const std::string& text, const std::string& context) {
  using Event = nlohmann::json::parse_event_t;
  struct Open {
    std::string key;  // the key this object is the value of ("" at the top)
    std::set<std::string> keys;
  };
  std::vector<Open> objects;
  std::string last_key, duplicate;
  const auto check = [&](int, Event event, nlohmann::json& parsed) {
    if (event == Event::object_start) {
      objects.push_back({last_key, {}});
    } else if (event == Event::object_end) {
      if (!objects.empty()) objects.pop_back();
    } else if (event == Event::key && !objects.empty()) {
      last_key = parsed.get<std::string>();
      if (!objects.back().keys.insert(last_key).second && duplicate.empty())
        duplicate = "'" + last_key + "' appears twice in " +
                    (objects.back().key.empty() ? std::string("the top-level object") : "'" + objects.back().key + "'");
    } else if (event == Event::array_start) {
      last_key.clear();
    }
    return true;
  };
  nlohmann::json value;
  try {
    value = nlohmann::json::parse(text, check);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(context + ": not valid JSON (" + e.what() + ")");
  }
  if (!duplicate.empty()) throw InvalidInput(context + ": the key " + duplicate + " (the second would silently replace the first)");
  return value;
}

nlohmann::json read_json_file(const std::string& path) {
  const std::string text = read_file_bytes(path);
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw IoError(path + ": not valid JSON (" + e.what() + ")");
  }
}

}  // namespace posekit
