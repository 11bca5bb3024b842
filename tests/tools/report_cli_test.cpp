// posekit report on the small dataset, as a user runs it: every figure and table the paper's
// evaluation has, links that resolve in a browser, each figure in 3-D, and a rerun from the cache.
// One report made once for all of it (a report is the longest test of the suite).
#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "posekit/io/atomic_file.h"
#include "testing/small_dataset.h"
#include "testing/temp_dir.h"
#include "tools/browser_check.h"
#include "tools/cli_runner.h"

using namespace posekit;
namespace fs = std::filesystem;

namespace {

/// Figures, tables and captions of report.md / index.html, and every link they hold resolves.
void expect_every_figure_and_link(const std::string& report) {
  const std::string html = read_file_bytes(report + "/index.html");
  const std::string md = read_file_bytes(report + "/report.md");
  for (const char* figure : {"fig2_template_poses.png", "fig3_transferred_poses.png", "fig4_customization_vs_scan.png",
                             "fig5_female_from_photos.png", "fig6_male_from_photos.png", "fig7_female_poses.png", "fig8_male_poses.png",
                             "fig9_posed_vs_scans.png", "fig9b_distances_to_scans.png"})
    EXPECT_NE(html.find(figure), std::string::npos) << figure;
  // Numbered as the paper numbers them: each figure once.
  for (const char* title : {"Figure 7:", "Figure 8:", "Figure 9:"}) {
    const size_t at = md.find(std::string("## ") + title);
    EXPECT_NE(at, std::string::npos) << title;
    EXPECT_EQ(md.find(std::string("## ") + title, at + 1), std::string::npos) << title << " twice";
  }
  EXPECT_NE(md.find("maximum bending"), std::string::npos);
  EXPECT_NE(md.find("Posed models against posed scans: summary"), std::string::npos);
  for (const char* section : {"Table 1", "Pose accuracy", "Customization from photos"}) EXPECT_NE(html.find(section), std::string::npos);
  int links = 0;
  const std::regex html_link("(?:src|href)=\"([^\"]+)\"");
  for (auto it = std::sregex_iterator(html.begin(), html.end(), html_link); it != std::sregex_iterator(); ++it, ++links)
    EXPECT_TRUE(fs::is_regular_file(fs::path(report) / (*it)[1].str())) << (*it)[1].str();
  const std::regex md_link("!\\[[^\\]]*\\]\\(([^)]+)\\)");
  for (auto it = std::sregex_iterator(md.begin(), md.end(), md_link); it != std::sregex_iterator(); ++it)
    EXPECT_TRUE(fs::is_regular_file(fs::path(report) / (*it)[1].str())) << (*it)[1].str();
  EXPECT_GE(links, 12);  // each figure has an img and a link
  // Figures are real PNGs of some size, and each is captioned with the command that made it.
  for (const auto& entry : fs::directory_iterator(report)) {
    if (entry.path().extension() != ".png") continue;
    const std::string bytes = read_file_bytes(entry.path().string());
    EXPECT_EQ(bytes.substr(1, 3), "PNG") << entry.path();
    EXPECT_GT(bytes.size(), 20000u) << entry.path();
  }
  EXPECT_NE(md.find("Made by: `posekit"), std::string::npos);
  // Figure 9's poses are fitted to the scans: each fitted body lies near the true posed one.
  int fitted_rows = 0;
  std::istringstream rows(md);
  for (std::string line; std::getline(rows, line);) {
    if (line.find("| fit | learned |") == std::string::npos || line.rfind("| fit |", 0) == 0) continue;  // not the summary's row
    std::vector<std::string> cells;
    std::istringstream cs(line);
    for (std::string c; std::getline(cs, c, '|');) cells.push_back(c);
    ASSERT_GE(cells.size(), 10u) << line;
    EXPECT_LT(std::stod(cells[9]), 12.0) << line;  // vertex error vs truth, mm: measured 4.5-8.7
    ++fitted_rows;
  }
  EXPECT_EQ(fitted_rows, 6) << "two subjects, three scanned poses each";
}

}  // namespace

TEST(Cli, Report) {
  ASSERT_FALSE(test::test_data_root().empty());
  test::TempDir dir;
  const std::string ds = test::small_dataset().root, report = dir.file("report");
  // One subject of non-rigid ICP and a prior of 8 calibration bodies: every code path, kept short.
  const std::string command =
      "report --dataset " + ds + " --out " + report + " --runs 1 --nicp-subjects 1 --calibration-bodies 8 --customization-bodies 30";
  const test::CommandResult r = test::run_posekit(command, true);
  ASSERT_EQ(r.code, 0) << r.out;
  EXPECT_NE(r.out.find("peak RSS"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("posekit report: stages (s): model "), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("posekit report: reused"), std::string::npos) << r.out;
  expect_every_figure_and_link(report);

  // In a real browser: every image loads, every table has rows and renders, no link is broken.
  ASSERT_TRUE(test::have_program("chromium")) << "the browser checks need Chromium (Debian: chromium)";
  test::TempDir scratch;
  const nlohmann::json seen = test::check_report_links_in_browser(report, scratch.path());
  ASSERT_FALSE(seen.contains("error")) << seen;
  EXPECT_GE(seen["images"].get<int>(), 6) << seen;
  EXPECT_TRUE(seen["broken_images"].empty()) << seen;
  EXPECT_GE(seen["tables"].get<int>(), 3) << seen;
  EXPECT_TRUE(seen["bad_tables"].empty()) << seen;
  EXPECT_GE(seen["links"].get<int>(), 6) << seen;
  EXPECT_TRUE(seen["broken_links"].empty()) << seen;
  // Each figure also in 3-D: it renders offline, every figure, no console errors.
  const std::string index = read_file_bytes(report + "/index.html");
  size_t figures = 0;
  for (size_t at = index.find("data-posekit-figure="); at != std::string::npos; at = index.find("data-posekit-figure=", at + 1)) ++figures;
  EXPECT_GE(figures, 4u) << "interactive figures in index.html";
  if (const auto page = test::open_in_chromium(dir, report + "/index.html")) {
    EXPECT_NE(page->body.find("data-posekit-viewers=\"ok " + std::to_string(figures) + "\""), std::string::npos) << page->body;
    EXPECT_EQ(page->body.find("data-posekit-errors"), std::string::npos) << page->body;
    EXPECT_GT(test::coloured_share(page->screenshot), 0.005) << "the first screen shows no figure";
  }

  // Again with nothing changed: the trained models and Table 1 come from the cache, the same numbers.
  const auto first = nlohmann::json::parse(read_file_bytes(report + "/report.json"));
  const test::CommandResult again = test::run_posekit(command, true);
  ASSERT_EQ(again.code, 0) << again.out;
  for (const char* what : {"reused pose model", "reused customization model", "reused pose fits", "reused shape space", "reused Table 1"})
    EXPECT_NE(again.out.find(std::string("posekit report: ") + what), std::string::npos) << what << "\n" << again.out;
  const auto second = nlohmann::json::parse(read_file_bytes(report + "/report.json"));
  EXPECT_EQ(second["table1"], first["table1"]);
  EXPECT_EQ(second["pose_errors"], first["pose_errors"]);
  EXPECT_EQ(second["reused_from_cache"].size(), 5u);
  EXPECT_LT(second["seconds"].get<double>(), first["seconds"].get<double>());

  // The browser check sees a missing figure.
  fs::rename(report + "/fig2_template_poses.png", report + "/moved.png");
  const nlohmann::json broken = test::check_report_links_in_browser(report, scratch.path());
  ASSERT_FALSE(broken.contains("error")) << broken;
  EXPECT_EQ(broken["broken_images"].size(), 1u) << broken;
  EXPECT_EQ(broken["broken_links"].size(), 1u) << broken;
}
