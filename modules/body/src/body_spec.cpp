#include "posekit/body/body_spec.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"

namespace posekit {
namespace {

double slider(const nlohmann::json& j, const std::string& key, const std::string& context, double lo, double hi) {
  if (!j.is_number()) throw InvalidInput(context + ": '" + key + "' must be a number");
  const double v = j.get<double>();
  if (!std::isfinite(v) || v < lo || v > hi)
    throw InvalidInput(context + ": '" + key + "' = " + std::to_string(v) + " is outside [" + std::to_string(lo) + ", " +
                       std::to_string(hi) + "]");
  return v;
}

}  // namespace

BodySpec body_spec_from_json(const std::string& text, const std::string& context) {
  const nlohmann::json j = parse_json(text, context);
  if (!j.is_object()) throw InvalidInput(context + ": expected a JSON object of sliders");
  BodySpec spec;
  for (auto it = j.begin(); it != j.end(); ++it) {
    const std::string& key = it.key();
    if (key == "gender") spec.gender = slider(*it, key, context, 0, 1);
    else if (key == "muscle") spec.muscle = slider(*it, key, context, 0, 1);
    else if (key == "weight") spec.weight = slider(*it, key, context, 0, 1);
    else if (key == "height") spec.height = slider(*it, key, context, 0, 1);
    else if (key == "proportions") spec.proportions = slider(*it, key, context, 0, 1);
    else if (key == "african") spec.african = slider(*it, key, context, 0, 1);
    else if (key == "asian") spec.asian = slider(*it, key, context, 0, 1);
    else if (key == "caucasian") spec.caucasian = slider(*it, key, context, 0, 1);
    else if (key == "modifiers") {
      if (!it->is_object()) throw InvalidInput(context + ": 'modifiers' must be an object of name: value");
      for (auto m = it->begin(); m != it->end(); ++m) spec.modifiers[m.key()] = slider(*m, "modifiers/" + m.key(), context, -1, 1);
    } else if (key == "comment" || key == "format") {
      continue;
    } else {
      throw InvalidInput(context + ": unknown slider '" + key +
                         "' (expected gender, muscle, weight, height, proportions, african, asian, caucasian, modifiers)");
    }
  }
  if (spec.african + spec.asian + spec.caucasian <= 0) throw InvalidInput(context + ": the ethnic mix sums to zero");
  return spec;
}

std::string body_spec_to_json(const BodySpec& s) {
  nlohmann::ordered_json j;
  j["format"] = "posekit body spec 1";
  j["gender"] = s.gender;
  j["muscle"] = s.muscle;
  j["weight"] = s.weight;
  j["height"] = s.height;
  j["proportions"] = s.proportions;
  j["african"] = s.african;
  j["asian"] = s.asian;
  j["caucasian"] = s.caucasian;
  j["modifiers"] = nlohmann::ordered_json::object();
  for (const auto& [name, value] : s.modifiers) j["modifiers"][name] = value;
  return j.dump(2) + "\n";
}

BodySpec read_body_spec(const std::string& path) { return body_spec_from_json(read_file_bytes(path), path); }

void write_body_spec(const std::string& path, const BodySpec& spec) {
  const std::string text = body_spec_to_json(spec);
  write_file_atomically(
      path, [&](std::ostream& out) { out << text; }, false);
}

}  // namespace posekit
