#pragma once
// Interactive figures for web pages: the panels of a figure (viewer.h) drawn by three.js (WebGL) in
// the browser, rotated with the mouse, zoomed with the wheel. Everything a page needs sits beside
// it, so that it opens offline from file://: three.min.js (fetched from npm when posekit is built),
// the viewer's script, and one script of data per figure.
#include <string>
#include <vector>

#include "posekit/viewers/viewer.h"

namespace posekit {

/// three.min.js as the build fetched it: $POSEKIT_THREE_JS, else the build tree's or the install's
/// share/posekit. Empty when there is none (posekit built without npm).
std::string find_three_js();

/// Copies three.js (and its licence) into `dir` and writes the viewer script there. Throws IoError
/// naming where three.js was looked for when there is none.
void write_web_viewer_assets(const std::string& dir);

/// What a page's <head> needs for its figures: their style, three.min.js and the viewer script.
std::string web_viewer_head();

/// Writes `dir`/`id`.js, the figure's data: each panel's mesh side by side (turned as its camera
/// preset says), coloured by its scalar on options.colour_map (the same colours as the PNG figures),
/// its overlay as points (at most 60,000), its caption, and the colour bar. Returns the HTML that
/// shows it in a page holding the assets (write_web_viewer_assets, web_viewer_head): the canvas, the
/// captions, the colour bar and the data's script tag.
std::string write_web_figure(const std::string& dir, const std::string& id, const std::vector<ViewPanel>& panels,
                             const ViewOptions& options);

/// A page of its own (atomically, the assets beside it): the figure and a title. For `posekit view --html`.
void write_web_page(const std::string& html_path, const std::vector<ViewPanel>& panels, const ViewOptions& options);

}  // namespace posekit
