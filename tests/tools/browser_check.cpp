#include "tools/browser_check.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>

#include "posekit/core/sanitizer.h"
#include "posekit/io/atomic_file.h"

namespace posekit::test {

bool have_program(const std::string& name) { return std::system(("command -v " + name + " > /dev/null 2>&1").c_str()) == 0; }

bool other_programs_checked() {
#if POSEKIT_ADDRESS_SANITIZER
  return false;
#else
  return true;
#endif
}

std::optional<BrowserView> open_in_chromium(const TempDir& dir, const std::string& html) {
  if (!other_programs_checked() || !have_program("chromium")) return std::nullopt;
  const std::string chromium =
      "timeout 120 chromium --headless --no-sandbox --disable-gpu --enable-unsafe-swiftshader --use-angle=swiftshader "
      "--window-size=1200,1400 --virtual-time-budget=20000 ";
  const std::string url = "file://" + std::filesystem::absolute(html).string();
  BrowserView view;
  EXPECT_EQ(std::system((chromium + "--dump-dom " + url + " > " + dir.file("dom.html") + " 2> " + dir.file("chromium.log")).c_str()), 0);
  const std::string dom = read_file_bytes(dir.file("dom.html"));
  const size_t at = dom.find("<body");
  view.body = at == std::string::npos ? dom.substr(0, 300) : dom.substr(at, dom.find('>', at) - at + 1);
  const std::string png = dir.file("screenshot.png");
  EXPECT_EQ(std::system((chromium + "--screenshot=" + png + " " + url + " >> " + dir.file("chromium.log") + " 2>&1").c_str()), 0);
  if (std::filesystem::exists(png)) view.screenshot = read_image(png, ImageColor::kBgr);
  return view;
}

double coloured_share(const Image8& image) {
  if (image.pixels.empty()) return 0;
  size_t coloured = 0;
  for (size_t i = 0; i + 2 < image.pixels.size(); i += 3) {
    const int b = image.pixels[i], g = image.pixels[i + 1], r = image.pixels[i + 2];
    coloured += std::max({r, g, b}) - std::min({r, g, b}) > 40;
  }
  return static_cast<double>(coloured) / static_cast<double>(image.pixels.size() / 3);
}

nlohmann::json check_report_links_in_browser(const std::string& report_dir, const std::string& scratch) {
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
      scratch + "/profile --dump-dom 'file://" + std::filesystem::absolute(page).string() + "' > " + dump + " 2>/dev/null";
  const int status = std::system(cmd.c_str());
  std::filesystem::remove(page);
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

}  // namespace posekit::test
