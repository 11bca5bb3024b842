#pragma once
// Headless Chromium checks of the pages posekit writes (web viewer, report), for the CLI tests.
#include <nlohmann/json.hpp>
#include <optional>
#include <string>

#include "posekit/io/image_io.h"
#include "testing/temp_dir.h"

namespace posekit::test {

bool have_program(const std::string& name);

/// Whether the tests open posekit's files in other programs (CloudCompare, Open3D, Chromium): in
/// the release pass. The sanitizer pass checks posekit's own memory, not other programs' reading.
bool other_programs_checked();

/// A page as headless Chromium (software WebGL) shows it from file://: the body tag after its
/// scripts ran (the web viewer writes data-posekit-viewers and data-posekit-errors there) and a
/// screenshot. Empty when Chromium is not installed.
struct BrowserView {
  std::string body;
  Image8 screenshot;
};
std::optional<BrowserView> open_in_chromium(const TempDir& dir, const std::string& html);

/// Share of the screenshot's pixels that are neither page white nor grey text: what WebGL drew.
double coloured_share(const Image8& image);

/// A report folder's index.html checked in Chromium: a copy of it with a script that, once the page
/// has loaded, counts images that did not load, tables without rows, with ragged rows or not
/// rendered, and links whose target cannot be fetched. The script's findings, or {"error": ...}.
nlohmann::json check_report_links_in_browser(const std::string& report_dir, const std::string& scratch);

}  // namespace posekit::test
