#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <algorithm>
#include <filesystem>
#include <random>
#include <set>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/population/ansur.h"
#include "posekit/population/survey_fit.h"
#include "posekit/population/survey_plausibility.h"
#include "posekit/registration/shape_space.h"
#include "posekit/shape/measurements.h"
#include "testing/makehuman_fixture.h"

using namespace posekit;

namespace {

std::string ansur_folder() {
  const std::string root = test::test_data_root();
  return root.empty() ? "" : (std::filesystem::path(root) / ".." / "ansur2").lexically_normal().string();
}

/// A survey CSV with ANSUR II's columns in another order, plus one the reader does not use.
std::string survey_csv(const std::string& row2) {
  std::string header = "SubjectId,Gender,unused", row1 = "7,Male,1";
  for (int m = kSurveyMeasureCount - 1; m >= 0; --m) {
    header += std::string(",") + survey_column(static_cast<SurveyMeasure>(m));
    row1 += "," + std::to_string(1000 + 100 * m);
  }
  return header + "\r\n" + row1 + "\r\n" + row2 + "\n";
}

BodySpec random_spec(std::mt19937& rng, const std::vector<std::string>& modifiers) {
  std::uniform_real_distribution<double> unit(0, 1), local(-0.6, 0.6);
  BodySpec s;
  s.gender = unit(rng) < 0.5 ? 0 : 1;
  s.muscle = unit(rng), s.weight = unit(rng), s.height = 0.2 + 0.6 * unit(rng), s.proportions = 0.3 + 0.4 * unit(rng);
  s.african = unit(rng), s.asian = unit(rng), s.caucasian = unit(rng);
  for (const std::string& m : modifiers) s.modifiers[m] = local(rng);
  return s;
}

const SurveyBodyFitter& fitter() {
  static const SurveyBodyFitter f(test::makehuman());
  return f;
}

}  // namespace

TEST(Survey, ReadsColumnsByNameInMetresAndNamesTheBadCell) {
  test::TempDir dir;
  std::string row2 = "8,Female,1";
  for (int m = 0; m < kSurveyMeasureCount; ++m) row2 += ",600";
  const auto subjects = read_survey_csv(dir.write("s.csv", survey_csv(row2)));
  ASSERT_EQ(subjects.size(), 2u);
  EXPECT_EQ(subjects[0].id, "7");
  EXPECT_TRUE(subjects[0].male);
  EXPECT_FALSE(subjects[1].male);
  for (int m = 0; m < kSurveyMeasureCount; ++m) EXPECT_NEAR(subjects[0].values[m], 1.0 + 0.1 * m, 1e-12) << m;

  std::string bad = "9,Female,1";
  for (int m = 0; m < kSurveyMeasureCount; ++m) bad += m == 3 ? ",n/a" : ",500";
  try {
    read_survey_csv(dir.write("bad.csv", survey_csv(bad)));
    FAIL() << "a cell that is not a number was read";
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:3: column '"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("'n/a', expected a positive number"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_survey_csv(dir.write("short.csv", survey_csv("9,Female,1,500"))), InvalidInput);
  std::string centimetres = "9,Female,1";  // stature 50.0: another unit
  for (int m = 0; m < kSurveyMeasureCount; ++m) centimetres += ",50";
  EXPECT_THROW(read_survey_csv(dir.write("cm.csv", survey_csv(centimetres))), InvalidInput);
  std::string unknown_sex = "9,X,1";
  for (int m = 0; m < kSurveyMeasureCount; ++m) unknown_sex += ",500";
  EXPECT_THROW(read_survey_csv(dir.write("sex.csv", survey_csv(unknown_sex))), InvalidInput);
  try {
    read_survey_csv(dir.write("nocol.csv", "SubjectId,Gender,stature\n1,Male,1700\n"));
    FAIL();
  } catch (const InvalidInput& e) {
    EXPECT_NE(std::string(e.what()).find("no column 'chestcircumference'"), std::string::npos) << e.what();
  }
  EXPECT_THROW(read_survey_csv(dir.file("missing.csv")), IoError);
}

TEST(Survey, ReadsAnsurIIsSixThousandAdults) {
  const std::string folder = ansur_folder();
  ASSERT_TRUE(std::filesystem::is_directory(folder)) << folder;
  const auto subjects = read_ansur2(folder);
  ASSERT_EQ(subjects.size(), 6068u);
  std::vector<double> men, women;
  for (const auto& s : subjects) (s.male ? men : women).push_back(s.values[0]);
  EXPECT_EQ(men.size(), 4082u);
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  EXPECT_NEAR(median(men), 1.755, 0.002);  // the README's medians
  EXPECT_NEAR(median(women), 1.626, 0.002);
}

TEST(TemplateAnthropometry, TheFewMeasuredVerticesGiveTheFullBodysMeasurements) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  std::mt19937 rng(3);
  for (int i = 0; i < 6; ++i) {
    const BodySpec s = random_spec(rng, default_fitted_modifiers());
    const TemplateAnthropometry& a = fitter().anthropometry(s.gender > 0.5);
    const SurveyValues full = measure_template_body(a, gather_measured_vertices(a, shaped_base_vertices(model, s)));
    const SurveyValues fast = fitter().measure(s);
    for (int m = 0; m < kSurveyMeasureCount; ++m) EXPECT_NEAR(fast[m], full[m], 1e-12) << i << " " << m;
  }
}

TEST(TemplateAnthropometry, AgreesWithMeasureOnTheTemplateAndScalesWithTheBody) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  for (int male = 0; male < 2; ++male) {
    BodySpec s;
    s.gender = male;
    const Body body = build_body(model, s);
    const BodyMeasurements m = measure_body(body.mesh.V, body.mesh.F);
    const TemplateAnthropometry& a = fitter().anthropometry(male);
    const Eigen::MatrixXd P = gather_measured_vertices(a, shaped_base_vertices(model, s));
    const SurveyValues v = measure_template_body(a, P);
    EXPECT_NEAR(v[0], m.stature, 0.002) << male;
    // The loops lie on the polygons, measure's sections on the smooth surface: a little shorter.
    EXPECT_NEAR(v[1], m.find("bust")->value, 0.006) << male;
    EXPECT_NEAR(v[3], m.find("hip")->value, 0.006) << male;
    EXPECT_NEAR(v[4], m.find("thigh")->value, 0.006) << male;
    EXPECT_NEAR(v[7], m.find("upper_arm")->value, 0.006) << male;
    EXPECT_LT(v[2], v[1]);  // a young adult template's navel girth is under the chest and buttocks
    EXPECT_LT(v[2], v[3]);
    EXPECT_LT(v[8], v[9]);  // crotch below acromion
    // Every measure is a length: a body 1.07 times as large measures 1.07 times as much, anywhere.
    const Eigen::MatrixXd moved = (1.07 * P).rowwise() + Eigen::RowVector3d(0.3, -2, 5);
    const SurveyValues w = measure_template_body(a, moved);
    for (int k = 0; k < kSurveyMeasureCount; ++k) EXPECT_NEAR(w[k], 1.07 * v[k], 1e-9) << k;
  }
}

TEST(SurveyFit, FindsTheSlidersOfABodyTheModelCanMake) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  std::mt19937 rng(11);
  for (int i = 0; i < 4; ++i) {
    BodySpec truth = random_spec(rng, default_fitted_modifiers());
    truth.african = truth.asian = 1.0 / 3, truth.caucasian = 1.0 / 3;
    SurveySubject subject;
    subject.male = truth.gender > 0.5;
    subject.values = fitter().measure(truth);
    const SurveyFit fit = fitter().fit(subject);
    for (int m = 0; m < kSurveyMeasureCount; ++m) EXPECT_LT(std::abs(fit.residual[m]), 0.001) << i << " " << m;
    EXPECT_EQ(fit.spec.gender, truth.gender);
  }
}

TEST(SurveyFit, FitsRealAdultsWithinMillimetres) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const auto all = read_ansur2(ansur_folder());
  std::vector<SurveySubject> sample;
  for (size_t i = 0; i < all.size(); i += 200) sample.push_back(all[i]);  // 31 subjects, men and women
  const std::vector<SurveyFit> fits = fit_survey(fitter(), sample, 2);
  for (int m = 0; m < kSurveyMeasureCount; ++m) {
    double mae = 0;
    for (const auto& f : fits) mae += std::abs(f.residual[m]);
    mae /= fits.size();
    // ISO 20685-1's tolerance for girths and lengths is 4-15 mm; the fit itself must stay well inside.
    EXPECT_LT(mae, m == static_cast<int>(SurveyMeasure::kBiacromialBreadth) ? 0.008 : 0.004)
        << survey_measure_name(static_cast<SurveyMeasure>(m));
  }
  // The same fits on one thread.
  const std::vector<SurveyFit> again = fit_survey(fitter(), sample, 1);
  for (size_t i = 0; i < fits.size(); ++i) EXPECT_EQ(fits[i].residual, again[i].residual);
}

TEST(PopulationSpace, IsThePcaOfTheFullBodies) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  std::mt19937 rng(5);
  std::vector<BodySpec> specs;
  std::vector<Eigen::MatrixXd> bodies;
  for (int i = 0; i < 8; ++i) {
    specs.push_back(random_spec(rng, default_fitted_modifiers()));
    bodies.push_back(build_body(model, specs.back()).mesh.V);
  }
  PopulationSpaceOptions o;
  o.max_rms = 1e-9;
  PopulationSpaceReport report;
  const ShapeSpace space = population_shape_space(model, specs, "test", o, &report);
  const ShapeSpace direct = learn_shape_space(bodies, 1.0, 7);
  ASSERT_EQ(space.components(), 7);  // 8 bodies span 7 directions
  ASSERT_EQ(direct.components(), 7);
  EXPECT_LT((space.mean - direct.mean).cwiseAbs().maxCoeff(), 1e-9);
  for (int k = 0; k < 7; ++k) {
    EXPECT_NEAR(space.variance_share[k], direct.variance_share[k], 1e-9) << k;
    // The same direction up to its sign, and the same standard deviation.
    EXPECT_NEAR(std::abs(space.basis.col(k).dot(direct.basis.col(k))), direct.basis.col(k).squaredNorm(),
                1e-6 * direct.basis.col(k).squaredNorm())
        << k;
  }
  EXPECT_LT(report.worst_rms.back(), 1e-9);
  EXPECT_EQ(space.faces, model.body_F);
  // The joints move with the same coefficients as the skin: exact with every component kept.
  ASSERT_TRUE(space.has_joints());
  for (size_t i = 0; i < specs.size(); ++i) {
    Eigen::VectorXd d(3 * bodies[i].rows());
    for (Eigen::Index v = 0; v < bodies[i].rows(); ++v) d.segment<3>(3 * v) = (bodies[i].row(v) - space.mean.row(v)).transpose();
    const Eigen::VectorXd c = (space.basis.transpose() * space.basis).ldlt().solve(space.basis.transpose() * d);
    const Eigen::MatrixXd truth = joint_centres(model.rig, build_body(model, specs[i]));
    EXPECT_LT((space.joints(c) - truth).cwiseAbs().maxCoeff(), 1e-9) << i;
    EXPECT_LT((space.body(c) - bodies[i]).cwiseAbs().maxCoeff(), 1e-9) << i;
  }
  // Fewer components: the report's worst error is that of the bodies projected onto them.
  o.max_rms = 1.0, o.max_components = 3;
  const ShapeSpace three = population_shape_space(model, specs, "test", o, &report);
  ASSERT_EQ(three.components(), 1);  // 1 m: one component is enough
  o.max_rms = 1e-9;
  const ShapeSpace capped = population_shape_space(model, specs, "test", o, &report);
  ASSERT_EQ(capped.components(), 3);
  double worst = 0;
  for (const Eigen::MatrixXd& V : bodies) {
    Eigen::VectorXd d(3 * V.rows());
    for (Eigen::Index i = 0; i < V.rows(); ++i) d.segment<3>(3 * i) = (V.row(i) - capped.mean.row(i)).transpose();
    const Eigen::MatrixXd& B = capped.basis;
    const Eigen::VectorXd c = (B.transpose() * B).ldlt().solve(B.transpose() * d);
    worst = std::max(worst, std::sqrt((d - B * c).squaredNorm() / V.rows()));
  }
  EXPECT_NEAR(report.worst_rms.back(), worst, 1e-9);
  EXPECT_THROW(population_shape_space(model, {specs[0]}, "one"), InvalidInput);
}

TEST(SurveyPlausibility, AnAverageBodyIsUsualAndAnInflatedGirthIsNamed) {
  POSEKIT_REQUIRE_MAKEHUMAN();
  const SurveyDistribution d = survey_distribution(read_ansur2(ansur_folder()), "ANSUR II");
  SurveyMask all;
  all.fill(true);
  SurveyValues mean_man;
  for (int m = 0; m < kSurveyMeasureCount; ++m) mean_man[m] = d.mean[1][m];
  const Plausibility average = judge_plausibility(d, mean_man, all);
  EXPECT_TRUE(average.male);
  EXPECT_LT(average.distance, 1e-6);
  EXPECT_GT(average.more_unusual_share, 0.999);
  // A chest 30% fuller than the rest of an average man says: rarer than any man of the survey, and
  // the chest is the measure to doubt; the others predict about the mean chest.
  SurveyValues inflated = mean_man;
  inflated[1] *= 1.3;
  const Plausibility p = judge_plausibility(d, inflated, all);
  EXPECT_LT(p.more_unusual_share, 0.001);
  EXPECT_EQ(p.most_unusual, SurveyMeasure::kChestCircumference);
  EXPECT_GT(p.most_unusual_z, 4.0);
  EXPECT_NEAR(p.expected_given_others, mean_man[1], 0.05 * mean_man[1]);
  // posekit measure's girths on the MakeHuman templates read as ordinary adults of their sex.
  for (int male = 0; male < 2; ++male) {
    BodySpec s;
    s.gender = male;
    const Body body = build_body(model, s);
    SurveyValues values;
    const SurveyMask given = survey_values_of(measure_body(body.mesh.V, body.mesh.F), &values);
    EXPECT_EQ(std::count(given.begin(), given.end(), true), 6);
    const Plausibility t = judge_plausibility(d, values, given);
    EXPECT_EQ(t.male, male == 1);
    EXPECT_GT(t.more_unusual_share, 0.01) << male << " " << t.distance;
  }
  SurveyMask one{};
  one[0] = true;
  EXPECT_THROW(judge_plausibility(d, mean_man, one), InvalidInput);
  EXPECT_THROW(survey_distribution(std::vector<SurveySubject>(5), "five"), InvalidInput);
}

TEST(Survey, SamplesWomenAndMenAlternatelyWithoutRepeats) {
  std::vector<SurveySubject> subjects(7);
  for (int i = 0; i < 7; ++i) subjects[i].id = std::to_string(i), subjects[i].male = i < 4;  // 4 men, 3 women
  const auto a = sample_survey(subjects, 6, 9), b = sample_survey(subjects, 6, 9);
  ASSERT_EQ(a.size(), 6u);
  std::set<std::string> ids;
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].male, k % 2 == 1) << k;
    EXPECT_EQ(a[k].id, b[k].id);  // the same seed, the same draw
    ids.insert(a[k].id);
  }
  EXPECT_EQ(ids.size(), 6u);
  EXPECT_THROW(sample_survey(subjects, 7, 9), InvalidInput);  // a fourth woman
}
