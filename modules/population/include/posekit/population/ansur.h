#pragma once
// Reading an ANSUR II-style anthropometric survey: one subject per CSV row, the survey's column
// names (Gordon et al. 2014, Natick/TR-15/007), lengths and girths in millimetres.
#include <array>
#include <limits>
#include <string>
#include <vector>

namespace posekit {

/// The measurements posekit's population is fitted to: ANSUR II's names, definitions in
/// docs/population.md. A body in the MakeHuman topology is measured the same way by
/// TemplateAnthropometry.
enum class SurveyMeasure {
  kStature,
  kChestCircumference,
  kWaistCircumference,  ///< at the omphalion (navel)
  kButtockCircumference,
  kThighCircumference,
  kCalfCircumference,
  kNeckCircumference,
  kBicepsCircumference,  ///< ANSUR's is flexed; a relaxed model arm reads smaller
  kCrotchHeight,
  kAcromialHeight,
  kBiacromialBreadth,
  kSleeveOutseam,
};
constexpr int kSurveyMeasureCount = 12;
using SurveyValues = std::array<double, kSurveyMeasureCount>;  ///< m, in SurveyMeasure order

/// The ANSUR II column of a measure, e.g. "chestcircumference".
const char* survey_column(SurveyMeasure m);
/// A short name for tables, e.g. "chest".
const char* survey_measure_name(SurveyMeasure m);
/// True for circumferences, false for heights, breadths and lengths.
bool survey_measure_is_girth(SurveyMeasure m);

/// Limb segments a survey measures between landmarks besides the 12 fitted measurements (ANSUR II:
/// acromion-radiale and radiale-stylion lengths; the thigh and shank as differences of the
/// trochanterion, lateral femoral epicondyle and lateral malleolus heights). They say how a limb
/// divides into its segments, which the 12 leave open.
enum class LimbSegment { kUpperArm, kForearm, kThigh, kShank };
constexpr int kLimbSegmentCount = 4;
/// "upper_arm", "forearm", "thigh", "shank".
const char* limb_segment_name(LimbSegment s);

struct SurveySubject {
  std::string id;  ///< SubjectId (or "row N")
  bool male = false;
  /// DODRace as recorded (1 white, 2 black, 3 hispanic, 4 asian, 5 native american, 6 pacific
  /// islander, 8 other); 0 when the file has no such column.
  int race = 0;
  double weight_kg = 0;  ///< 0 when not recorded
  SurveyValues values{};
  /// m, in LimbSegment order; NaN where the survey lacks the columns.
  std::array<double, kLimbSegmentCount> segments{kNaN, kNaN, kNaN, kNaN};

 private:
  static constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
};

/// Reads one survey CSV: a header row naming the columns, then one subject per row. Needs the columns
/// of every SurveyMeasure and a sex column (`Gender`: Male/Female, or `sex`: M/F), reads `SubjectId`,
/// `DODRace` and `weightkg` (tenths of a kg) when present, and the limb segments' columns when all
/// are present. Millimetres become metres. Throws IoError
/// for an unreadable file, InvalidInput naming the file, line and column for a missing column, a
/// row of another length, a value that is not a positive number or a stature outside 500-2600 mm
/// (another unit).
std::vector<SurveySubject> read_survey_csv(const std::string& path);

/// Reads ANSUR II from its folder: ANSUR_II_MALE_Public.csv and ANSUR_II_FEMALE_Public.csv, men first.
/// Throws IoError naming a missing file.
std::vector<SurveySubject> read_ansur2(const std::string& folder);

/// `count` subjects drawn at random from `subjects` with `seed`, women and men alternately (women
/// first), none twice. Throws InvalidInput when a sex runs out.
std::vector<SurveySubject> sample_survey(const std::vector<SurveySubject>& subjects, int count, unsigned seed);

/// Reads a survey from a path: ANSUR II's folder (read_ansur2) or one CSV (read_survey_csv).
std::vector<SurveySubject> read_survey(const std::string& path);

/// Locates ANSUR II: `explicit_path` when not empty, else the POSEKIT_ANSUR environment variable, else
/// the folder `ansur2` beside the MakeHuman data root (../shared/datasets/ansur2). Throws IoError
/// saying where it looked.
std::string find_ansur_root(const std::string& explicit_path, const std::string& makehuman_root);

}  // namespace posekit
