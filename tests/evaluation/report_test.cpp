#include "posekit/paper/report.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <regex>
#include <sstream>

#include "posekit/io/atomic_file.h"
#include "testing/small_dataset.h"

using namespace posekit;
namespace fs = std::filesystem;

namespace {

/// Checks a report in a real headless browser (Chromium): a copy of index.html with a script that,
/// once the page has loaded, counts images that did not load, tables without rows, with ragged rows
/// or not rendered, and links whose target cannot be fetched. Returns the script's findings.
nlohmann::json check_in_browser(const std::string& report_dir, const std::string& scratch) {
  const char* script = R"JS(<script>
window.addEventListener('load', function () {
  var r = {images: 0, broken_images: [], tables: 0, bad_tables: [], links: 0, broken_links: []};
  document.querySelectorAll('img').forEach(function (img) {
    r.images++;
    if (!img.complete || img.naturalWidth === 0) r.broken_images.push(img.getAttribute('src'));
  });
  document.querySelectorAll('table').forEach(function (t, i) {
    r.tables++;
    var rows = t.querySelectorAll('tr'), head = rows.length ? rows[0].cells.length : 0, ok = rows.length >= 2;
    for (var k = 1; k < rows.length; ++k) ok = ok && rows[k].cells.length === head;
    if (!ok || t.getBoundingClientRect().height === 0) r.bad_tables.push(i);
  });
  document.querySelectorAll('a[href]').forEach(function (a) {
    var h = a.getAttribute('href');
    if (/^[a-z]+:/i.test(h)) return;
    r.links++;
    if (h.charAt(0) === '#') { if (!document.getElementById(h.slice(1))) r.broken_links.push(h); return; }
    try { var x = new XMLHttpRequest(); x.open('GET', h, false); x.send(); if (x.status !== 0 && x.status !== 200) r.broken_links.push(h); }
    catch (e) { r.broken_links.push(h); }
  });
  var pre = document.createElement('pre'); pre.id = 'posekit-check'; pre.textContent = JSON.stringify(r);
  document.body.appendChild(pre);
});
</script>)JS";
  std::string html = read_file_bytes(report_dir + "/index.html");
  const auto body_end = html.rfind("</body>");
  html.insert(body_end == std::string::npos ? html.size() : body_end, script);
  const std::string page = report_dir + "/.browser_check.html";
  write_file_atomically(page, [&](std::ostream& out) { out << html; });
  const std::string dump = scratch + "/dom.html";
  const std::string cmd =
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --allow-file-access-from-files "
      "--virtual-time-budget=20000 --user-data-dir=" +
      scratch + "/profile --dump-dom 'file://" + fs::absolute(page).string() + "' > " + dump + " 2>/dev/null";
  const int status = std::system(cmd.c_str());
  fs::remove(page);
  if (status != 0) return nlohmann::json{{"error", "chromium failed (exit " + std::to_string(status) + "): " + cmd}};
  const std::string dom = read_file_bytes(dump);
  const auto start = dom.find("<pre id=\"posekit-check\">");
  if (start == std::string::npos) return nlohmann::json{{"error", "the check script left no result"}};
  const auto from = start + std::string("<pre id=\"posekit-check\">").size();
  std::string text = dom.substr(from, dom.find("</pre>", from) - from);
  for (const auto& [entity, c] : {std::pair<std::string, std::string>{"&lt;", "<"}, {"&gt;", ">"}, {"&amp;", "&"}})
    for (auto at = text.find(entity); at != std::string::npos; at = text.find(entity, at)) text.replace(at, entity.size(), c);
  return nlohmann::json::parse(text);
}

}  // namespace

TEST(Report, OnTheSmallDatasetLinksOnlyFilesThatExistAndLoadsInABrowser) {
  const auto& ds = test::small_dataset();
  test::TempDir dir;
  ReportOptions o;
  o.registration_runs = 1;
  o.nicp_subjects = 1;
  o.calibration_bodies = 8;  // the prior's code path, kept short for the sanitizer build
  o.customization_bodies = 30;
  const ReportSummary s = write_report(ds.root, dir.file("report"), o);
  const std::string html = read_file_bytes(dir.file("report/index.html"));
  const std::string md = read_file_bytes(dir.file("report/report.md"));
  // Every figure the paper's evaluation has, and both tables.
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
  EXPECT_NE(html.find("Table 1"), std::string::npos);
  EXPECT_NE(html.find("Pose accuracy"), std::string::npos);
  EXPECT_NE(html.find("Customization from photos"), std::string::npos);
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
  // Figure 9's poses are fitted to the scans (issue 18): each fitted body lies near the true posed one.
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

  // In a real browser: every image loads, every table has rows and renders, no link is broken.
  ASSERT_EQ(std::system("command -v chromium >/dev/null 2>&1"), 0) << "the browser check needs Chromium (Debian: chromium)";
  test::TempDir scratch;
  const nlohmann::json seen = check_in_browser(dir.file("report"), scratch.path());
  ASSERT_FALSE(seen.contains("error")) << seen;
  EXPECT_GE(seen["images"].get<int>(), 6) << seen;
  EXPECT_TRUE(seen["broken_images"].empty()) << seen;
  EXPECT_GE(seen["tables"].get<int>(), 3) << seen;
  EXPECT_TRUE(seen["bad_tables"].empty()) << seen;
  EXPECT_GE(seen["links"].get<int>(), 6) << seen;
  EXPECT_TRUE(seen["broken_links"].empty()) << seen;
  // The check sees a missing figure.
  fs::rename(dir.file("report/fig2_template_poses.png"), dir.file("report/moved.png"));
  const nlohmann::json broken = check_in_browser(dir.file("report"), scratch.path());
  ASSERT_FALSE(broken.contains("error")) << broken;
  EXPECT_EQ(broken["broken_images"].size(), 1u) << broken;
  EXPECT_EQ(broken["broken_links"].size(), 1u) << broken;
}
