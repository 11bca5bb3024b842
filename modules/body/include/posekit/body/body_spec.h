#pragma once
// A body described by MakeHuman slider values: small, stored as JSON, regenerates the body exactly.
#include <map>
#include <string>

namespace posekit {

struct BodySpec {
  double gender = 0.5;                                             ///< 0 female .. 1 male
  double muscle = 0.5;                                             ///< 0 .. 1
  double weight = 0.5;                                             ///< 0 .. 1
  double height = 0.5;                                             ///< 0 .. 1 (0.2 .. 0.8 is a plausible adult range)
  double proportions = 0.5;                                        ///< 0 uncommon .. 1 ideal
  double african = 1.0 / 3, asian = 1.0 / 3, caucasian = 1.0 / 3;  ///< normalised to sum 1 when used
  /// Local modifiers by name, e.g. "measure/measure-waist-circ-decr|incr": -1..1 (two-sided) or 0..1.
  std::map<std::string, double> modifiers;
};

/// Parses a body spec from JSON text; `context` (a file name) is used in error messages.
/// Unknown keys, non-numbers and out-of-range slider values throw InvalidInput naming the key.
BodySpec body_spec_from_json(const std::string& json_text, const std::string& context);

/// JSON text of a spec (all sliders and modifiers, stable key order).
std::string body_spec_to_json(const BodySpec& spec);

/// Reads / writes (atomically) a spec file. Throws IoError or InvalidInput naming the file.
BodySpec read_body_spec(const std::string& path);
void write_body_spec(const std::string& path, const BodySpec& spec);

}  // namespace posekit
