#include "posekit/evaluation/report.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <regex>

#include "posekit/io/atomic_file.h"
#include "testing/small_dataset.h"

using namespace posekit;
namespace fs = std::filesystem;

TEST(Report, OnTheSmallDatasetLinksOnlyFilesThatExist) {
  const auto& ds = test::small_dataset();
  test::TempDir dir;
  ReportOptions o;
  o.registration_runs = 1;
  o.nicp_subjects = 1;
  o.calibration_bodies = 8;  // the prior's code path, kept short for the sanitizer build
  const ReportSummary s = write_report(ds.root, dir.file("report"), o);
  const std::string html = read_file_bytes(dir.file("report/index.html"));
  const std::string md = read_file_bytes(dir.file("report/report.md"));
  // Every figure the paper's evaluation has, and both tables.
  for (const char* figure : {"fig2_template_poses.png", "fig3_transferred_poses.png", "fig4_customization_vs_scan.png",
                             "fig7_female_subjects.png", "fig7_male_subjects.png", "fig9_posed_vs_scans.png"})
    EXPECT_NE(html.find(figure), std::string::npos) << figure;
  EXPECT_NE(html.find("Table 1"), std::string::npos);
  EXPECT_NE(html.find("Pose accuracy"), std::string::npos);
  // Every src/href in the HTML and every image in the Markdown exists.
  int links = 0;
  const std::regex html_link("(?:src|href)=\"([^\"]+)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), html_link); it != std::sregex_iterator(); ++it, ++links)
    EXPECT_TRUE(fs::is_regular_file(fs::path(dir.file("report")) / (*it)[1].str())) << (*it)[1].str();
  const std::regex md_link("!\\[[^\\]]*\\]\\(([^)]+)\\)");
  for (auto it = std::sregex_iterator(md.begin(), md.end(), md_link); it != std::sregex_iterator(); ++it)
    EXPECT_TRUE(fs::is_regular_file(fs::path(dir.file("report")) / (*it)[1].str())) << (*it)[1].str();
  EXPECT_GE(links, 12);  // each figure has an img and a link
  // Figures are real PNGs of some size, and each is captioned with the command that made it.
  for (const auto& f : s.files) {
    if (f.size() < 4 || f.substr(f.size() - 4) != ".png") continue;
    const std::string bytes = read_file_bytes(dir.file("report/" + f));
    EXPECT_EQ(bytes.substr(1, 3), "PNG") << f;
    EXPECT_GT(bytes.size(), 20000u) << f;
  }
  EXPECT_NE(md.find("Made by: `posekit"), std::string::npos);
}
