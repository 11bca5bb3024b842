#pragma once
// The population sampler: MakeHuman bodies of random proportions in the four BMI classes, with
// local shape variation (the evaluation subjects, calibration and shape-space populations), and
// their ground-truth measurements.
#include <functional>
#include <string>
#include <vector>

#include "posekit/body/makehuman_model.h"

namespace posekit {

enum class BmiClass { kUnderweight, kNormal, kOverweight, kObese };
const char* bmi_class_name(BmiClass c);  ///< "underweight", "normal", "overweight", "obese"
BmiClass bmi_class_of(double bmi);       ///< < 18.5, 18.5-25, 25-30, >= 30

constexpr double kBodyDensityKgPerLitre = 1.01;

struct BodyStats {
  double stature_m = 0, volume_litres = 0, mass_kg = 0, bmi = 0;
};
/// Stature (vertical extent), enclosed volume, mass at 1.01 kg/L and BMI of a standing body.
BodyStats body_stats(const TriangleMesh& body);

struct SubjectSpec {
  std::string id;  ///< "f01".."f08", "m01".."m08"
  bool female = true;
  BmiClass target_class = BmiClass::kNormal;
  double target_bmi = 22;
  BodySpec spec;
};

/// `count` subjects (half female), two per BMI class per gender for 16, each with random sliders
/// and measure modifiers from `seed` and a fatness chosen by bisection to hit its target BMI.
std::vector<SubjectSpec> make_subject_specs(const MakeHumanModel& model, unsigned seed, int count = 16);
/// Subject `index` (0-based) of make_subject_specs(model, seed, count), the same to the bit, without
/// the bisections of the others (a sixteenth of the work for one subject of 16).
SubjectSpec make_subject_spec(const MakeHumanModel& model, unsigned seed, int index, int count = 16);

/// `count` bodies for calibrating the segmentation (segmentation_prior.h): a third women, a third
/// men, a third of mixed gender, fatness uniform over the subjects' range (BMI about 15 to 40) and
/// the subjects' random sliders, from `seed` (use one the subjects do not).
std::vector<BodySpec> make_calibration_specs(unsigned seed, int count);

/// A population for a shape space (shape_space.h): `count` bodies of make_calibration_specs(seed,
/// count) built in the MakeHuman base topology at rest. Without `local_variation` the random
/// measure modifiers are left out (macro sliders and fatness only: a population that does not hold
/// every way the subjects vary). `keep` (optional) leaves a body out when it returns false; `note`
/// receives what the population was. Built on `threads` threads (0: all cores).
struct PopulationOptions {
  unsigned seed = 20261125;  ///< neither the subjects' nor the other populations' seed
  int count = 300;
  bool local_variation = true;
  std::function<bool(const BodySpec&, const TriangleMesh&)> keep;
  std::string keep_note;  ///< what `keep` leaves out, for the note
  int threads = 0;
  std::function<void(int, int)> progress;  ///< (bodies built, total), serialised
};
std::vector<Eigen::MatrixXd> make_population_bodies(const MakeHumanModel& model, const PopulationOptions& options,
                                                    std::string* note = nullptr);

/// Girths and stature in metres. Girths are convex-hull perimeters (a tape over concavities).
struct Measurements {
  double stature = 0, bust = 0, underbust = 0, waist = 0, hip = 0, thigh = 0, upper_arm = 0, neck = 0;
  double bust_height = 0, waist_height = 0, hip_height = 0, crotch_height = 0;  ///< y of the levels (m)
  double arms_separate_height = 0;  ///< highest level (m) below which both arms are separate from the torso
};
/// Ground-truth measurements of a MakeHuman body in rest pose, with its rig's joints as landmarks
/// (levels defined in the README after ISO 8559-1). Throws InvalidInput if a level cannot be found.
Measurements measure_makehuman_body(const MakeHumanModel& model, const Body& body);

}  // namespace posekit
