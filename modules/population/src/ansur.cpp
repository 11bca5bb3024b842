#include "posekit/population/ansur.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "posekit/core/error.h"

namespace posekit {
namespace {

struct MeasureRow {
  const char* column;
  const char* name;
  bool girth;
};
constexpr MeasureRow kMeasures[kSurveyMeasureCount] = {
    {"stature", "stature", false},
    {"chestcircumference", "chest", true},
    {"waistcircumference", "waist", true},
    {"buttockcircumference", "buttock", true},
    {"thighcircumference", "thigh", true},
    {"calfcircumference", "calf", true},
    {"neckcircumference", "neck", true},
    {"bicepscircumferenceflexed", "biceps", true},
    {"crotchheight", "crotch_height", false},
    {"acromialheight", "acromial_height", false},
    {"biacromialbreadth", "biacromial_breadth", false},
    {"sleeveoutseam", "sleeve_outseam", false},
};

/// ANSUR II's columns for a limb segment: its length, or the difference of two heights.
struct SegmentColumns {
  const char* name;
  const char* upper;
  const char* lower;  ///< nullptr: `upper` is the length itself
};
constexpr SegmentColumns kSegments[kLimbSegmentCount] = {
    {"upper_arm", "acromionradialelength", nullptr},
    {"forearm", "radialestylionlength", nullptr},
    {"thigh", "trochanterionheight", "lateralfemoralepicondyleheight"},
    {"shank", "lateralfemoralepicondyleheight", "lateralmalleolusheight"},
};

std::vector<std::string> split_csv_line(std::string line) {
  if (!line.empty() && line.back() == '\r') line.pop_back();
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(field);
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

std::string lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

}  // namespace

const char* survey_column(SurveyMeasure m) { return kMeasures[static_cast<int>(m)].column; }
const char* survey_measure_name(SurveyMeasure m) { return kMeasures[static_cast<int>(m)].name; }
bool survey_measure_is_girth(SurveyMeasure m) { return kMeasures[static_cast<int>(m)].girth; }
const char* limb_segment_name(LimbSegment s) { return kSegments[static_cast<int>(s)].name; }

std::vector<SurveySubject> read_survey_csv(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path + ": cannot open the survey file");
  std::string line;
  if (!std::getline(in, line)) throw InvalidInput(path + ": empty file, expected a header row of column names");
  if (line.rfind("\xEF\xBB\xBF", 0) == 0) line.erase(0, 3);  // a UTF-8 byte order mark
  const std::vector<std::string> header = split_csv_line(line);
  std::map<std::string, int> column;
  for (size_t i = 0; i < header.size(); ++i) column[lower(header[i])] = static_cast<int>(i);
  auto find = [&](const char* name) {
    const auto it = column.find(name);
    return it == column.end() ? -1 : it->second;
  };
  int measure_column[kSurveyMeasureCount];
  for (int m = 0; m < kSurveyMeasureCount; ++m) {
    measure_column[m] = find(kMeasures[m].column);
    if (measure_column[m] < 0)
      throw InvalidInput(path + ": no column '" + kMeasures[m].column + "' (an ANSUR II-style survey names its columns in line 1)");
  }
  const int sex_column = find("gender") >= 0 ? find("gender") : find("sex");
  if (sex_column < 0) throw InvalidInput(path + ": no column 'Gender' (Male/Female) or 'sex' (M/F)");
  const int id_column = find("subjectid"), race_column = find("dodrace"), weight_column = find("weightkg");
  std::array<std::array<int, 2>, kLimbSegmentCount> segment_column{};
  bool has_segments = true;
  for (int k = 0; k < kLimbSegmentCount; ++k) {
    segment_column[k] = {find(kSegments[k].upper), kSegments[k].lower ? find(kSegments[k].lower) : -2};
    has_segments = has_segments && segment_column[k][0] >= 0 && segment_column[k][1] != -1;
  }

  std::vector<SurveySubject> subjects;
  for (int line_number = 2; std::getline(in, line); ++line_number) {
    if (line.empty() || line == "\r") continue;
    const std::vector<std::string> f = split_csv_line(line);
    const std::string where = path + ":" + std::to_string(line_number);
    if (f.size() != header.size())
      throw InvalidInput(where + ": " + std::to_string(f.size()) + " fields, the header has " + std::to_string(header.size()));
    auto number = [&](int c) {
      const std::string& s = f[c];
      char* end = nullptr;
      const double v = std::strtod(s.c_str(), &end);
      if (s.empty() || end != s.c_str() + s.size() || !std::isfinite(v) || v <= 0)
        throw InvalidInput(where + ": column '" + header[c] + "' is '" + s + "', expected a positive number");
      return v;
    };
    SurveySubject s;
    s.id = id_column >= 0 ? f[id_column] : "row " + std::to_string(line_number);
    const std::string sex = lower(f[sex_column]);
    if (sex == "male" || sex == "m") s.male = true;
    else if (sex == "female" || sex == "f") s.male = false;
    else throw InvalidInput(where + ": column '" + header[sex_column] + "' is '" + f[sex_column] + "', expected Male or Female");
    for (int m = 0; m < kSurveyMeasureCount; ++m) s.values[m] = number(measure_column[m]) / 1000.0;
    const double stature = s.values[static_cast<int>(SurveyMeasure::kStature)];
    if (stature < 0.5 || stature > 2.6)
      throw InvalidInput(where + ": stature " + f[measure_column[0]] + " is not an adult's in millimetres (expected 500-2600)");
    if (race_column >= 0) s.race = static_cast<int>(number(race_column));
    if (weight_column >= 0) s.weight_kg = number(weight_column) / 10.0;
    for (int k = 0; has_segments && k < kLimbSegmentCount; ++k) {
      const double upper = number(segment_column[k][0]), lower = segment_column[k][1] >= 0 ? number(segment_column[k][1]) : 0;
      if (segment_column[k][1] >= 0 && upper <= lower)  // a difference of two heights
        throw InvalidInput(where + ": column '" + header[segment_column[k][0]] + "' is not above '" + header[segment_column[k][1]] + "'");
      s.segments[k] = (upper - lower) / 1000.0;
    }
    subjects.push_back(std::move(s));
  }
  if (subjects.empty()) throw InvalidInput(path + ": a header but no subjects");
  return subjects;
}

std::vector<SurveySubject> read_ansur2(const std::string& folder) {
  std::vector<SurveySubject> all;
  for (const char* name : {"ANSUR_II_MALE_Public.csv", "ANSUR_II_FEMALE_Public.csv"}) {
    const std::string path = (std::filesystem::path(folder) / name).string();
    if (!std::filesystem::is_regular_file(path))
      throw IoError(path + ": not found (ANSUR II is read from ../shared/datasets/ansur2 or --ansur DIR)");
    std::vector<SurveySubject> part = read_survey_csv(path);
    all.insert(all.end(), std::make_move_iterator(part.begin()), std::make_move_iterator(part.end()));
  }
  return all;
}

std::vector<SurveySubject> sample_survey(const std::vector<SurveySubject>& subjects, int count, unsigned seed) {
  std::vector<size_t> by_sex[2];
  for (size_t i = 0; i < subjects.size(); ++i) by_sex[subjects[i].male].push_back(i);
  std::mt19937 rng(seed);
  for (auto& v : by_sex) std::shuffle(v.begin(), v.end(), rng);
  std::vector<SurveySubject> out;
  for (int k = 0; k < count; ++k) {
    const int sex = k % 2;
    const size_t taken = static_cast<size_t>(k / 2);
    if (taken >= by_sex[sex].size())
      throw InvalidInput("survey sample: " + std::to_string(count) + " subjects need " + std::to_string(taken + 1) +
                         (sex ? " men" : " women") + ", the survey has " + std::to_string(by_sex[sex].size()));
    out.push_back(subjects[by_sex[sex][taken]]);
  }
  return out;
}

std::vector<SurveySubject> read_survey(const std::string& path) {
  return std::filesystem::is_directory(path) ? read_ansur2(path) : read_survey_csv(path);
}

std::string find_ansur_root(const std::string& explicit_path, const std::string& makehuman_root) {
  namespace fs = std::filesystem;
  if (!explicit_path.empty()) {
    if (fs::exists(explicit_path)) return explicit_path;
    throw IoError(explicit_path + ": not found (expected the ANSUR II folder or a survey CSV)");
  }
  if (const char* env = std::getenv("POSEKIT_ANSUR"); env && *env) {
    if (fs::exists(env)) return env;
    throw IoError(std::string(env) + " (from POSEKIT_ANSUR): not found");
  }
  const fs::path beside = (fs::path(makehuman_root) / ".." / "ansur2").lexically_normal();
  if (fs::is_directory(beside)) return beside.string();
  throw IoError("no ANSUR II folder found (looked in " + beside.string() +
                "): pass --survey DIR or set POSEKIT_ANSUR to the folder of ANSUR_II_MALE_Public.csv and "
                "ANSUR_II_FEMALE_Public.csv (public domain, as in ../shared/datasets/ansur2)");
}

}  // namespace posekit
