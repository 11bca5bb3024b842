#include "posekit/paper/report.h"

#include <algorithm>
#include <array>
#include <atomic>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>

#include "posekit/body/subjects.h"
#include "posekit/core/data_root.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"
#include "posekit/core/timer.h"
#include "posekit/customization/photo_evaluation.h"
#include "posekit/datasets/dataset.h"
#include "posekit/deformation/part_pose_estimation.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/deformation/pose_fitting.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/pose_synthesis.h"
#include "posekit/deformation/segmentation_calibration.h"
#include "posekit/evaluation/pose_evaluation.h"
#include "posekit/evaluation/scan_comparison.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/paper/registration_table.h"
#include "posekit/population/makehuman_shape_space.h"
#include "posekit/registration/ctffd.h"
#include "posekit/registration/shape_space.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/layered_representation.h"
#include "posekit/shape/measurements.h"
#include "posekit/viewers/viewer.h"
#include "posekit/viewers/web_viewer.h"
#include "report_cache.h"

namespace fs = std::filesystem;

namespace posekit {
namespace {

std::string fixed(double v, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << v;
  return s.str();
}

std::string html_escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<') out += "&lt;";
    else if (c == '>') out += "&gt;";
    else if (c == '&') out += "&amp;";
    else out += c;
  }
  return out;
}

struct Table {
  std::string title;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::string note;
};

struct Figure {
  std::string file, title, caption, command;
  std::string web = {};  ///< the interactive figure's HTML (web_viewer.h), or empty
};

/// The report under construction: figures, tables and warnings in reading order.
struct Document {
  struct Item {
    bool is_figure;
    Figure figure;
    Table table;
  };
  std::vector<Item> items;
  std::vector<std::string> warnings;
  nlohmann::ordered_json data;

  void figure(Figure f) { items.push_back({true, std::move(f), {}}); }
  void table(Table t) { items.push_back({false, {}, std::move(t)}); }

  std::string markdown(const std::string& title, const std::string& intro) const {
    std::ostringstream md;
    md << "# " << title << "\n\n" << intro << "\n\n";
    for (const auto& item : items) {
      if (item.is_figure) {
        const Figure& f = item.figure;
        md << "## " << f.title << "\n\n![" << f.title << "](" << f.file << ")\n\n" << f.caption << "\n\nMade by: `" << f.command << "`\n\n";
      } else {
        const Table& t = item.table;
        md << "## " << t.title << "\n\n|";
        for (const auto& h : t.header) md << " " << h << " |";
        md << "\n|";
        for (size_t i = 0; i < t.header.size(); ++i) md << "---|";
        md << "\n";
        for (const auto& r : t.rows) {
          md << "|";
          for (const auto& c : r) md << " " << c << " |";
          md << "\n";
        }
        if (!t.note.empty()) md << "\n" << t.note << "\n";
        md << "\n";
      }
    }
    if (!warnings.empty()) {
      md << "## Warnings\n\n";
      for (const auto& w : warnings) md << "- " << w << "\n";
    }
    return md.str();
  }

  bool interactive = false;  ///< the web viewer's assets are in the report folder

  std::string html(const std::string& title, const std::string& intro) const {
    std::ostringstream h;
    h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>" << html_escape(title)
      << "</title>\n<style>body{font-family:sans-serif;max-width:1200px;margin:2em auto;padding:0 1em;color:#222}"
         "img{max-width:100%;border:1px solid #ddd}figure{margin:2em 0}figcaption{margin-top:.5em}"
         "code{background:#f4f4f4;padding:.1em .3em}table{border-collapse:collapse;margin:1em 0}"
         "td,th{border:1px solid #ccc;padding:.25em .6em;text-align:right}th{background:#f0f0f0}"
         "td:first-child,th:first-child{text-align:left}.warn{color:#a40}</style>\n"
      << (interactive ? web_viewer_head() : std::string()) << "</head><body>\n<h1>" << html_escape(title) << "</h1>\n<p>"
      << html_escape(intro) << "</p>\n";
    for (const auto& item : items) {
      if (item.is_figure) {
        const Figure& f = item.figure;
        h << "<figure><h2>" << html_escape(f.title) << "</h2><a href=\"" << f.file << "\"><img src=\"" << f.file << "\" alt=\""
          << html_escape(f.title) << "\"></a>";
        if (!f.web.empty()) h << "<details open><summary>In 3-D (drag to turn, wheel to zoom)</summary>" << f.web << "</details>";
        h << "<figcaption>" << html_escape(f.caption) << "<br>Made by: <code>" << html_escape(f.command)
          << "</code></figcaption></figure>\n";
      } else {
        const Table& t = item.table;
        h << "<h2>" << html_escape(t.title) << "</h2>\n<table><tr>";
        for (const auto& c : t.header) h << "<th>" << html_escape(c) << "</th>";
        h << "</tr>\n";
        for (const auto& r : t.rows) {
          h << "<tr>";
          for (const auto& c : r) h << "<td>" << html_escape(c) << "</td>";
          h << "</tr>\n";
        }
        h << "</table>\n";
        if (!t.note.empty()) h << "<p>" << html_escape(t.note) << "</p>\n";
      }
    }
    if (!warnings.empty()) {
      h << "<h2>Warnings</h2><ul>\n";
      for (const auto& w : warnings) h << "<li class=\"warn\">" << html_escape(w) << "</li>\n";
      h << "</ul>\n";
    }
    h << "</body></html>\n";
    return h.str();
  }
};

PointCloud load_scan_m(const std::string& path) { return load_scan(path, Unit::kMillimetre); }

TriangleMesh with_scalar(TriangleMesh mesh, const std::string& name, const Eigen::VectorXd& values) {
  mesh.vertex_scalars[name] = values;
  return mesh;
}

/// A pose not in the pose dataset: a wave with the right arm while stepping forward on the left.
/// The signed-distance colour map (mm) of the heatmap figures: symmetric, over the 95th percentile
/// of the figure's |distances| (heatmap_range), zero green.
ColourMap signed_error_map() {
  ColourMap map;
  map.kind = ColourMapKind::kDiverging;
  map.title = "model to scan (mm)";
  return map;
}

/// The view that shows a pose's motion: from the side when the body moved more along the front
/// camera's line of sight (z) than across it (x), as in squats, reaches and steps; else the front.
CameraPreset view_showing_motion(const Eigen::MatrixXd& rest, const Eigen::MatrixXd& posed) {
  const Eigen::MatrixXd moved = (posed - rest).cwiseAbs();
  return moved.col(2).sum() > moved.col(0).sum() ? CameraPreset::kSide : CameraPreset::kFront;
}

PartPose novel_pose() {
  PartPose p;
  p.joint(find_joint_index("right_shoulder")) = Eigen::Vector3d(0, 0, -1.6);
  p.joint(find_joint_index("right_elbow")) = Eigen::Vector3d(0, -1.2, 0);
  p.joint(find_joint_index("left_hip")) = Eigen::Vector3d(-0.6, 0, 0);
  p.joint(find_joint_index("left_knee")) = Eigen::Vector3d(0.7, 0, 0);
  p.joint(find_joint_index("neck")) = Eigen::Vector3d(0, 0.4, 0);
  return p;
}

/// One fitted pose of a subject's posed scan (Figure 9).
struct FitTask {
  std::string id, pose, scan_path, rest_path;
  PoseMethod method;
  PoseFitResult result;
  std::string error;
};

/// write_report's stages, one per figure or table, over what they share: the document being
/// written, the cache, the pose model, the subjects set up for posing and their customized bodies.
class ReportWriter {
 public:
  ReportWriter(const std::string& dir, const std::string& out_dir, const ReportOptions& o)
      : dir(dir),
        out_dir(out_dir),
        o(o),
        manifest(read_json_file((std::filesystem::path(dir) / "manifest.json").string())),
        subjects(manifest.at("subjects")),
        cache(o.cache_dir) {
    std::error_code ec;
    fs::create_directories(out_dir, ec);
    if (ec || !fs::is_directory(out_dir)) throw IoError(out_dir + ": cannot create the report folder (" + ec.message() + ")");
    cmd = o.command_line.empty() ? "posekit report --dataset " + dir + " --out " + out_dir : o.command_line;
    // What every cached result depends on besides its own options: this build, and its inputs' files.
    if (cache.enabled()) {
      const std::string binary = report_detail::binary_fingerprint();
      dataset_print = binary + "\n" + report_detail::folder_fingerprint(dir);
      data_print = binary + "\n" + report_detail::folder_fingerprint(find_data_root(""));
    }
    plain.panel_width = 300;
    plain.panel_height = 520;
    co.threads = o.threads;
    try {  // the interactive figures' scripts (three.js from npm at build time)
      write_web_viewer_assets(out_dir);
      doc.interactive = true;
    } catch (const Error& e) {
      doc.warnings.push_back(std::string("no interactive figures: ") + e.what());
    }
  }

  /// The pose model: given, reused from the cache, or trained on the dataset (with its segmentation prior).
  void pose_model() {
    if (!o.model_path.empty()) {
      model = std::make_shared<const PoseModel>(read_pose_model(o.model_path));
    } else {
      const std::string file =
          cache.path("pose model", dataset_print + "\ncalibration bodies " + std::to_string(o.calibration_bodies), ".pkm");
      const std::string note_file = file.empty() ? "" : file + ".warning";
      if (cached(file)) {
        model = std::make_shared<const PoseModel>(read_pose_model(file));
        reuse("pose model", file);
        if (cached(note_file)) doc.warnings.push_back(read_file_bytes(note_file));
      } else {
        PoseModel trained = train_on_dataset(dir);
        CalibrationOptions calibration;
        calibration.bodies = o.calibration_bodies;
        const PriorReport prior = add_segmentation_prior(&trained, "", calibration);
        const std::string note = prior.not_made.empty() ? "" : "segmentation prior: the template alone (" + prior.not_made + ")";
        if (!note.empty()) doc.warnings.push_back(note);
        if (!file.empty()) {
          if (!note.empty())
            write_file_atomically(
                note_file, [&](std::ostream& out) { out << note; }, false);
          write_pose_model(file, trained);
        }
        model = std::make_shared<const PoseModel>(std::move(trained));
      }
    }
    tick("model");
  }

  /// Figure 2: the template in held-out poses of the dataset and one novel combination.
  void figure2() {
    templ.V = model->template_V;
    templ.F = model->template_F;
    SubjectSetupOptions as_template;
    as_template.is_template = true;
    try {
      template_synth = std::make_unique<PoseSynthesizer>(model, templ, as_template);
    } catch (const Error& e) {
      doc.warnings.push_back(std::string("template: cannot be posed (") + e.what() + ")");
    }

    // Poses for Figures 2 and 3: held-out poses of the dataset and one novel combination.
    const PoseDataset poses = load_pose_dataset(dir);
    for (const char* name : {"walk_phase_1", "reach_forward", "squat_half", "guard", "random_3"})
      for (size_t i = 0; i < poses.names.size(); ++i)
        if (poses.names[i] == name && poses.has_pose[i] && shown.size() < 4) shown.emplace_back(name, poses.poses[i]);
    for (size_t i = 0; i < poses.names.size() && shown.size() < 4; ++i)
      if (poses.test[i] && poses.has_pose[i]) shown.emplace_back(poses.names[i], poses.poses[i]);
    shown.emplace_back("novel: wave and step", novel_pose());

    if (template_synth) {
      std::vector<ViewPanel> panels;
      for (const auto& [name, pose] : shown) {
        ViewPanel p;
        p.mesh = templ;
        p.mesh.V = template_synth->pose(pose);
        p.camera = view_showing_motion(templ.V, p.mesh.V);
        p.caption = name + (p.camera == CameraPreset::kSide ? " (side)" : "");
        panels.push_back(std::move(p));
      }
      render(panels, plain, "fig2_template_poses.png",
             {"", "Figure 2: the template in synthesized poses",
              "The pose-dataset template posed by the learned model (T^R T^Q, Eq. 1) from joint rotations alone: " +
                  std::to_string(shown.size() - 1) +
                  " held-out poses of the dataset (not used in training) and one pose that is in no dataset. A pose whose motion is "
                  "mostly along the front camera's line of sight is seen from the side.",
              "posekit pose --model model.pkm --subject " + path_in("template/rest.ply") + " --pose <pose.json> --out posed.ply"});
    }
    tick("figure 2");
  }

  /// Figure 3: the same poses transferred to a customized subject (the heaviest woman, else the first).
  void figure3() {
    // Figure 3: the same poses transferred to a customized subject (the heaviest woman, else the first).
    std::string transfer_id;
    double best_bmi = -1;
    for (const auto& s : subjects)
      if (s.value("gender", "") == "female" && s.value("bmi", 0.0) > best_bmi)
        best_bmi = s.value("bmi", 0.0), transfer_id = s.value("id", "");
    if (transfer_id.empty() && !subjects.empty()) transfer_id = subjects[0].value("id", "");
    for (const auto& s : subjects) {
      const std::string id = s.value("id", "?");
      try {
        rests[id] = load_subject_mesh(path_in(s.at("rest").get<std::string>()));
        synths[id] = std::make_unique<PoseSynthesizer>(model, rests[id]);
      } catch (const Error& e) {
        doc.warnings.push_back("subject " + id + ": cannot be set up for posing (" + e.what() + ")");
      }
    }
    if (synths.count(transfer_id)) {
      std::vector<ViewPanel> panels;
      for (const auto& [name, pose] : shown) {
        ViewPanel p;
        p.mesh = rests[transfer_id];
        p.mesh.V = synths[transfer_id]->pose(pose);
        p.camera = view_showing_motion(rests[transfer_id].V, p.mesh.V);
        p.caption = name + (p.camera == CameraPreset::kSide ? " (side)" : "");
        panels.push_back(std::move(p));
      }
      render(panels, plain, "fig3_transferred_poses.png",
             {"", "Figure 3: the same poses transferred to a customized model",
              "Subject " + transfer_id +
                  " (its own mesh and topology) in the poses of Figure 2: its segmentation and skeleton give "
                  "T^R, the template's T^Q comes through the ct-FFD correspondence (section 3.3.3). Views as in Figure 2.",
              "posekit pose --model model.pkm --subject " + path_in("subjects/" + transfer_id + "/rest.ply") +
                  " --pose <pose.json> --out posed.ply"});
    }
    tick("figure 3");
  }

  /// Customization from photos (section 3.2): every subject from its front and side photos.
  void customization_from_photos() {
    // Customization from photos (section 3.2): every subject from its front and side photos.
    {
      std::optional<CustomizationModel> photo_model;
      try {
        if (!o.customization_path.empty()) {
          photo_model = load_customization_model(o.customization_path);
        } else {
          CustomizationTrainingOptions t;
          t.data_root = find_data_root("");
          t.bodies = o.customization_bodies;
          t.threads = o.threads > 0 ? o.threads : 2;
          const std::string file = cache.path(
              "customization model", data_print + "\nbodies " + std::to_string(t.bodies) + " threads " + std::to_string(t.threads), ".pkc");
          if (cached(file)) {
            photo_model = load_customization_model(file);
            reuse("customization model", file);
          } else {
            photo_model = train_customization_model(t);
            if (!file.empty()) save_customization_model(file, *photo_model);
          }
        }
      } catch (const Error& e) {
        doc.warnings.push_back(std::string("customization from photos: no model (") + e.what() + ")");
      }
      if (photo_model) {
        Table photo_table{"Customization from photos",
                          {"subject", "stature mm", "bust mm", "waist mm", "hip mm", "surface mm", "photos to mesh s"},
                          {},
                          "Each subject customized from its front and side photos (silhouettes extracted from the images, the "
                          "camera file for scale) and measured as any mesh, minus the ground truth; surface: mean distance "
                          "of the subject's own mesh to the result. The paper claims bust, waist and hip within 2 cm; ISO "
                          "20685-1 allows a mean absolute error of 15 mm (bust) and 12 mm (waist, hip). Model: " +
                              photo_model->population + "."};
        const PhotoEvaluation ev = evaluate_photo_customization(dir, *photo_model, PhotoVariation::kPhotos);
        nlohmann::ordered_json photo_json = nlohmann::ordered_json::array();
        for (const auto& r : ev.subjects) {
          if (!r.ok) {
            photo_table.rows.push_back({r.id, "failed: " + r.error, "", "", "", "", ""});
            continue;
          }
          auto girth = [&](double v) { return r.girths_measured ? fixed(v, 1) : std::string("n/a"); };
          photo_table.rows.push_back({r.id, fixed(r.stature_mm, 1), girth(r.bust_mm), girth(r.waist_mm), girth(r.hip_mm),
                                      fixed(r.surface_mm, 2), fixed(r.seconds, 2)});
          photo_json.push_back({{"subject", r.id},
                                {"stature_mm", r.stature_mm},
                                {"bust_mm", r.bust_mm},
                                {"waist_mm", r.waist_mm},
                                {"hip_mm", r.hip_mm},
                                {"surface_mm", r.surface_mm},
                                {"seconds", r.seconds}});
        }
        photo_table.rows.push_back({"mean |error|", fixed(ev.mean_abs_stature_mm, 1), fixed(ev.mean_abs_bust_mm, 1),
                                    fixed(ev.mean_abs_waist_mm, 1), fixed(ev.mean_abs_hip_mm, 1), fixed(ev.mean_surface_mm, 2), ""});
        doc.data["customization_from_photos"] = photo_json;
        doc.table(photo_table);
        for (const auto& s : subjects) {
          const std::string id = s.value("id", "?");
          try {
            const auto& ph = s.at("photos");
            const CustomizedBody body =
                customize_from_silhouettes(silhouette_from_photo(path_in(ph.at("front").get<std::string>()), "front photo of " + id),
                                           silhouette_from_photo(path_in(ph.at("side").get<std::string>()), "side photo of " + id),
                                           read_photo_cameras(path_in(ph.at("camera").get<std::string>())), *photo_model);
            from_photos[id] = body.mesh;
          } catch (const std::exception& e) {
            doc.warnings.push_back("subject " + id + ": not customized from its photos (" + e.what() + ")");
          }
        }
      }
    }
    tick("customization from photos");
  }

  /// Figures 5 and 6: all women and all men customized from their photos.
  void figures5_and_6() {
    // Figures 5 and 6: all women and all men customized from their photos.
    for (const auto& [gender, number] : {std::pair<std::string, int>{"female", 5}, {"male", 6}}) {
      std::vector<ViewPanel> panels;
      for (const auto& s : subjects) {
        const std::string id = s.value("id", "");
        if (s.value("gender", "") != gender || !from_photos.count(id)) continue;
        ViewPanel p;
        p.mesh = from_photos[id];
        p.caption = id + " BMI " + fixed(s.value("bmi", 0.0), 1);
        panels.push_back(std::move(p));
      }
      if (panels.empty()) continue;
      ViewOptions v = plain;
      v.panel_width = 220;
      v.panel_height = 440;
      render(panels, v, "fig" + std::to_string(number) + "_" + gender + "_from_photos.png",
             {"", "Figure " + std::to_string(number) + ": " + gender + " models customized from photos",
              "The template customized to every " + gender +
                  " subject from its front and side photos alone (section 3.2), "
                  "in the standard pose.",
              "posekit customize --front <front.png> --side <side.png> --camera <camera.json> --out body.ply"});
    }
    tick("figures 5 and 6");
  }

  /// Figure 4 and the scan table: the template customized to each subject from its photos (and by
  /// ct-FFD from its mesh), against the scan.
  void scans_and_figure4() {
    // Figure 4 and the scan table: the template customized to each subject from its photos (and by
    // ct-FFD from its mesh), against the scan.
    Table scans_table{"Models against scans (rest pose)",
                      {"subject", "model", "scan to model mean mm", "RMS mm", "95th pct mm", "coverage %", "bust diff cm", "waist diff cm",
                       "hip diff cm"},
                      {},
                      "Distances from every scan point to the model's surface (exact), outliers beyond 20 mm counted apart. "
                      "Girth differences are model minus scan; ISO 20685-1 allows 9 mm for these large girths, the paper "
                      "claims under 2 cm. n/a: a girth not measured on the model or the scan, e.g. when the scan "
                      "does not separate the arms from the torso below the armpits and its bust band cannot be trusted "
                      "(`posekit measure` on the scan names the reason)."};
    std::vector<ViewPanel> customization_panels;
    LayeredRepresentation template_rep;
    bool have_template_rep = false;
    try {
      template_rep = build_layered_representation(templ.V, templ.F, find_body_features(templ.V, templ.F));
      have_template_rep = true;
    } catch (const Error& e) {
      doc.warnings.push_back(std::string("template representation: ") + e.what());
    }
    const CtffdParametrization template_param = have_template_rep ? ctffd_parametrize(templ.V, template_rep) : CtffdParametrization{};
    nlohmann::ordered_json scan_json = nlohmann::ordered_json::array();
    for (const auto& s : subjects) {
      const std::string id = s.value("id", "?");
      if (!rests.count(id)) continue;
      std::string scan_path;
      for (const auto& sc : s.value("scans", nlohmann::json::array()))
        if (sc.value("pose", "") == "rest") scan_path = path_in(sc.at("cloud").get<std::string>());
      if (scan_path.empty()) continue;
      try {
        const PointCloud scan = load_scan_m(scan_path);
        if (const std::string m = unit_mismatch(rests[id], scan); !m.empty()) {
          doc.warnings.push_back("subject " + id + ": " + scan_path + ": " + m);
          continue;
        }
        std::vector<std::pair<std::string, TriangleMesh>> models = {{"subject mesh", rests[id]}};
        if (have_template_rep) {
          TriangleMesh customized = templ;
          customized.V = ctffd_evaluate(
              template_param, build_layered_representation(rests[id].V, rests[id].F, find_body_features(rests[id].V, rests[id].F)));
          models.emplace_back("template customized by ct-FFD", customized);
        }
        if (from_photos.count(id)) models.emplace_back("customized from photos", from_photos[id]);
        for (const auto& [what, mesh] : models) {
          const ScanComparison r = compare_with_scan(mesh, scan, co);
          std::vector<GirthDiscrepancy> girths;
          try {
            girths = girth_discrepancies(mesh, scan);
          } catch (const Error& e) {
            doc.warnings.push_back("subject " + id + " (" + what + "): girths not measured (" + e.what() + ")");
          }
          auto diff = [&](const std::string& name) {
            for (const auto& g : girths)
              if (g.name == name) return g.measured ? fixed(g.difference_cm, 1) : std::string("n/a");
            return std::string("n/a");
          };
          scans_table.rows.push_back({id, what, fixed(r.scan_stats.mean_mm, 2), fixed(r.scan_stats.rms_mm, 2),
                                      fixed(r.scan_stats.p95_mm, 2), fixed(100 * r.coverage, 1), diff("bust"), diff("waist"), diff("hip")});
          scan_json.push_back({{"subject", id},
                               {"model", what},
                               {"scan_to_model_mean_mm", r.scan_stats.mean_mm},
                               {"rms_mm", r.scan_stats.rms_mm},
                               {"p95_mm", r.scan_stats.p95_mm},
                               {"coverage", r.coverage}});
          if (what == (from_photos.empty() ? "template customized by ct-FFD" : "customized from photos") &&
              customization_panels.size() < 4) {
            ViewPanel p;
            p.mesh = with_scalar(mesh, "model_to_scan_mm", 1000 * r.model_to_scan);
            p.scalar = "model_to_scan_mm";
            p.caption = id + " (BMI " + fixed(s.value("bmi", 0.0), 1) + ")";
            customization_panels.push_back(std::move(p));
          }
        }
      } catch (const Error& e) {
        doc.warnings.push_back("subject " + id + ": scan comparison failed (" + e.what() + ")");
      }
    }
    doc.data["scans"] = scan_json;
    if (!customization_panels.empty()) {
      ViewOptions v = plain;
      v.colour_map = signed_error_map();
      render(customization_panels, v, "fig4_customization_vs_scan.png",
             {"", "Figure 4: customized models against scans",
              from_photos.empty()
                  ? "The template customized to each subject by ct-FFD (its representation deformed into the subject's) coloured "
                    "by its signed distance to the subject's simulated scan (positive: the scan lies outside the model; grey: no "
                    "scan data, e.g. the soles). (No photo customization model: see the warnings.)"
                  : "The template customized to each subject from its two photos (section 3.2) coloured by its signed distance "
                    "to the subject's simulated scan (positive: the scan lies outside the model; grey: no scan data, e.g. the soles).",
              from_photos.empty()
                  ? "posekit register " + path_in("template/rest.ply") +
                        " <subject rest.ply> --deformed customized.ply && posekit compare customized.ply <scan.pcd> --png heatmap.png"
                  : "posekit customize --front <front.png> --side <side.png> --camera <camera.json> --out customized.ply "
                    "&& posekit compare customized.ply <scan.pcd> --png heatmap.png"});
    }
    doc.table(scans_table);
    girth_figure();
    tick("scans");
  }

  /// Where the girths' tapes go (measure --contours): a woman and a man, front and side.
  void girth_figure() {
    std::vector<ViewPanel> panels;
    for (const char* gender : {"female", "male"})
      for (const auto& s : subjects) {
        const std::string id = s.value("id", "");
        if (s.value("gender", "") != gender || !rests.count(id)) continue;
        try {
          const BodyMeasurements m = measure_body(rests[id].V, rests[id].F);
          ViewPanel p;
          p.mesh = rests[id];
          for (const Girth& g : m.girths) {
            if (!g.measured) continue;
            // Drawn 3 mm outside the surface, where its hull touches the body, so that the surface does not hide it.
            const Eigen::RowVector3d centre = g.tape.colwise().mean();
            Eigen::MatrixXd shown = g.tape;
            for (Eigen::Index k = 0; k < shown.rows(); ++k)
              shown.row(k) = centre + (g.tape.row(k) - centre) * (1 + 0.003 / std::max(1e-3, (g.tape.row(k) - centre).norm()));
            p.lines.push_back(shown);
          }
          for (CameraPreset c : {CameraPreset::kFront, CameraPreset::kSide}) {
            p.camera = c;
            p.caption = id + (c == CameraPreset::kFront ? " front" : " side");
            panels.push_back(p);
          }
        } catch (const Error& e) {
          doc.warnings.push_back("subject " + id + ": not measured (" + e.what() + ")");
        }
        break;
      }
    if (panels.empty()) return;
    ViewOptions v = plain;
    v.panel_width = 220;
    v.panel_height = 480;
    render(panels, v, "girths_tape_paths.png",
           {"", "Girths: where the tape goes",
            "The girths posekit measures (bust, underbust, waist, hip, thigh, knee, calf, ankle, upper arm, wrist, neck) on a "
            "woman and a man of the dataset: each the convex hull of the body's section, as a tape stretched round it (drawn 3 "
            "mm outside the surface).",
            "posekit measure <rest.ply> --contours tapes.obj"});
  }

  /// The poses of Figures 7 and 8: the dataset's held-out poses of the subjects and the pose
  /// dataset's two most bent poses (the largest joint rotation, on two different joints).
  std::vector<std::pair<std::string, PartPose>> dynamic_poses() {
    std::vector<std::pair<std::string, PartPose>> poses;
    for (const auto& s : subjects) {
      for (const auto& p : s.value("posed", nlohmann::json::array()))
        poses.emplace_back(p.value("pose", ""), read_part_pose(path_in(p.at("pose_json").get<std::string>())));
      if (!poses.empty()) break;
    }
    struct Bent {
      double angle;
      int joint;
      std::string name;
      PartPose pose;
    };
    std::vector<Bent> bent;
    for (const auto& p : manifest.value("pose_dataset", nlohmann::json::object()).value("poses", nlohmann::json::array())) {
      const PartPose pose = read_part_pose(path_in(p.at("pose").get<std::string>()));
      Bent b{0, -1, p.value("name", ""), pose};
      for (int j = 0; j < kNumJoints; ++j)
        if (pose.joint(j).norm() > b.angle) b.angle = pose.joint(j).norm(), b.joint = j;
      bent.push_back(b);
    }
    std::sort(bent.begin(), bent.end(), [](const Bent& a, const Bent& b) { return a.angle > b.angle; });
    int first_joint = -1;
    for (const Bent& b : bent) {
      if (b.joint < 0 || b.joint == first_joint) continue;
      poses.emplace_back(b.name, b.pose);
      if (first_joint >= 0) break;
      first_joint = b.joint;
    }
    return poses;
  }

  /// Two subjects of a sex with a posable model: its lowest and highest BMI (the paper's Figure 9:
  /// two women), others when there are fewer.
  std::vector<std::string> two_subjects(const std::string& gender) {
    std::vector<std::pair<double, std::string>> of_sex, others;
    for (const auto& s : subjects) {
      const std::string id = s.value("id", "");
      if (!synths.count(id)) continue;
      (s.value("gender", "") == gender ? of_sex : others).emplace_back(s.value("bmi", 0.0), id);
    }
    std::sort(of_sex.begin(), of_sex.end());
    std::vector<std::string> ids;
    if (!of_sex.empty()) ids.push_back(of_sex.front().second);
    if (of_sex.size() > 1) ids.push_back(of_sex.back().second);
    for (size_t k = 0; ids.size() < 2 && k < others.size(); ++k) ids.push_back(others[k].second);
    return ids;
  }

  /// Figures 7 and 8 (the paper's "dynamic deformed female / male models"): two subjects of each sex
  /// posed by the learned method in the held-out poses and the two most bent poses of the pose
  /// dataset ("even in poses with maximum bending angles").
  void figures7and8() {
    const std::vector<std::pair<std::string, PartPose>> poses = dynamic_poses();
    int number = 7;
    for (const char* gender : {"female", "male"}) {
      std::vector<ViewPanel> panels;
      std::string names;
      for (const std::string& id : two_subjects(gender)) {
        for (const auto& [name, pose] : poses) {
          ViewPanel panel;
          panel.mesh = rests[id];
          panel.mesh.V = synths[id]->pose(pose);
          panel.caption = id + " " + name;
          panel.camera = view_showing_motion(rests[id].V, panel.mesh.V);
          panels.push_back(std::move(panel));
        }
        names += (names.empty() ? "" : " and ") + id;
      }
      const std::string n = std::to_string(number++);
      if (panels.empty()) continue;
      std::string pose_names;
      for (const auto& [name, pose] : poses) pose_names += (pose_names.empty() ? "" : ", ") + name;
      ViewOptions v = plain;
      v.panel_width = 160;
      v.panel_height = 400;
      render(panels, v, "fig" + n + "_" + gender + "_poses.png",
             {"", "Figure " + n + ": dynamic deformed " + gender + " models",
              "Two " + std::string(gender) + " subjects (" + names +
                  ": the lowest and highest BMI) posed by the learned method (Eq. 5-6) in " + pose_names +
                  ": the held-out poses and the pose dataset's two most bent poses, as the paper shows them \"even in poses " +
                  "with maximum bending angles\". A pose that moves mostly towards the camera is seen from the side.",
              "posekit pose --model model.pkm --subject <rest.ply> --pose <pose.json> --out posed.ply"});
    }
    tick("figures 7 and 8");
  }

  /// The poses of the posed scans fitted, two at a time (each is single-threaded and its own; the
  /// same results as one by one), each reused from the cache while the model, the subject and the
  /// scan are unchanged.
  std::vector<FitTask> fit_posed_scans() {
    // The fits first, two at a time (each is single-threaded and its own; the same results as one by
    // one), each reused from the cache while the model, the subject and the scan are unchanged.
    std::vector<FitTask> fits;
    for (const auto& s : subjects) {
      const std::string id = s.value("id", "");
      if (!synths.count(id)) continue;
      for (const auto& p : s.value("posed", nlohmann::json::array()))
        for (const auto& sc : s.value("scans", nlohmann::json::array()))
          if (sc.value("pose", "") == p.value("pose", ""))
            for (PoseMethod m : {PoseMethod::kLearned, PoseMethod::kLbs})
              fits.push_back({id,
                              p.value("pose", ""),
                              path_in(sc.at("cloud").get<std::string>()),
                              path_in(s.at("rest").get<std::string>()),
                              m,
                              {},
                              ""});
    }
    const std::string model_print = !cache.enabled() ? ""
                                    : o.model_path.empty()
                                        ? dataset_print + "\ncalibration bodies " + std::to_string(o.calibration_bodies)
                                        : report_detail::binary_fingerprint() + "\n" + report_detail::file_fingerprint(o.model_path);
    std::atomic<int> fits_reused{0};
    parallel_for_ranges(
        static_cast<long>(fits.size()), o.threads > 0 ? std::min(o.threads, 2) : 2,
        [&](long begin, long end) {
          for (long k = begin; k < end; ++k) {
            FitTask& t = fits[static_cast<size_t>(k)];
            try {
              const std::string file =
                  cache.path("pose fit",
                             model_print + "\nsubject " + report_detail::file_fingerprint(t.rest_path) + "\nscan " +
                                 report_detail::file_fingerprint(t.scan_path) + "\nmethod " + pose_method_name(t.method),
                             ".fit");
              if (cached(file) && report_detail::read_pose_fit(file, &t.result)) {
                ++fits_reused;
                continue;
              }
              PoseFitOptions fo;
              fo.method = t.method;
              t.result = fit_pose(*synths.at(t.id), load_scan_m(t.scan_path).P, fo);
              if (!file.empty()) report_detail::write_pose_fit(file, t.result);
            } catch (const Error& e) {
              t.error = e.what();
            }
          }
        },
        1);
    if (fits_reused > 0) summary.reused.push_back("pose fits (" + std::to_string(fits_reused) + " of " + std::to_string(fits.size()) + ")");
    return fits;
  }

  /// Figure 9: posed models beside their posed scans, with heatmaps.
  void figure9() {
    // Figure 9: posed models beside their posed scans, with heatmaps. A user with real scans has no
    // joint angles: the poses are fitted to the scans (posekit fit), and the dataset's own angles are
    // kept beside them for reference.
    Table posed_table{"Posed models against posed scans",
                      {"subject", "pose", "pose from", "method", "scan to model mean mm", "RMS mm", "95th pct mm", "outliers",
                       "vertex error vs truth mm", "joint angle error deg"},
                      {},
                      "Each subject posed by each method against the simulated scan of the subject in that pose (ground "
                      "truth posed by the MakeHuman rig). Pose from 'fit': fitted to the scan with that method in the loop "
                      "(posekit fit: no markers, no joint angles); 'dataset': the pose's own joint rotations. Vertex error: "
                      "mean distance to the true posed mesh; joint angle error: mean over the root and 15 joints against "
                      "the dataset's pose."};
    std::map<std::pair<std::string, std::string>, std::array<double, 6>> summary_of;  // sums and count per (pose from, method)
    std::vector<ViewPanel> fig9, fig9_heat;
    const std::vector<std::string> fig9_ids = two_subjects("female");
    const std::vector<FitTask> fits = fit_posed_scans();
    auto fit_of = [&](const std::string& id, const std::string& pose, PoseMethod m) -> const FitTask& {
      for (const FitTask& t : fits)
        if (t.id == id && t.pose == pose && t.method == m) return t;
      throw InvalidInput("no fit of " + id + " " + pose);
    };
    for (const auto& s : subjects) {
      const std::string id = s.value("id", "");
      if (!synths.count(id)) continue;
      for (const auto& p : s.value("posed", nlohmann::json::array())) {
        const std::string pose = p.value("pose", "");
        std::string scan_path;
        for (const auto& sc : s.value("scans", nlohmann::json::array()))
          if (sc.value("pose", "") == pose) scan_path = path_in(sc.at("cloud").get<std::string>());
        if (scan_path.empty()) continue;
        try {
          const PointCloud scan = load_scan_m(scan_path);
          const PartPose part_pose = read_part_pose(path_in(p.at("pose_json").get<std::string>()));
          const Eigen::MatrixXd truth = read_mesh(path_in(p.at("mesh").get<std::string>())).V;
          auto add_row = [&](const std::string& from, PoseMethod m, const PartPose& used, const Eigen::MatrixXd& V) {
            TriangleMesh posed = rests[id];
            posed.V = V;
            const ScanComparison r = compare_with_scan(posed, scan, co);
            const std::string vertex_error =
                truth.rows() == V.rows() ? fixed(1000 * (V - truth).rowwise().norm().mean(), 2) : std::string("");
            double angle = rotation_difference(used.root_rotation, part_pose.root_rotation);
            for (int j = 0; j < kNumJoints; ++j) angle += rotation_difference(used.joint(j), part_pose.joint(j));
            auto& sums = summary_of[{from, pose_method_name(m)}];
            sums[0] += r.scan_stats.mean_mm, sums[1] += r.scan_stats.rms_mm, sums[2] += r.scan_stats.p95_mm;
            sums[3] += truth.rows() == V.rows() ? 1000 * (V - truth).rowwise().norm().mean() : 0;
            sums[4] += angle / (kNumJoints + 1) * 180 / M_PI, sums[5] += 1;
            posed_table.rows.push_back({id, pose, from, pose_method_name(m), fixed(r.scan_stats.mean_mm, 2), fixed(r.scan_stats.rms_mm, 2),
                                        fixed(r.scan_stats.p95_mm, 2), std::to_string(r.scan_stats.outliers), vertex_error,
                                        fixed(angle / (kNumJoints + 1) * 180 / M_PI, 1)});
            // Figure 9 as the paper composes it: two women in three poses, the posed model beside its
            // scan, each readable; the distances in a figure of their own.
            if (from == "fit" && m == PoseMethod::kLearned && pose != "rest" &&
                std::find(fig9_ids.begin(), fig9_ids.end(), id) != fig9_ids.end()) {
              ViewPanel model_panel;
              model_panel.mesh = posed;
              model_panel.caption = id + " " + pose;
              model_panel.camera = view_showing_motion(rests[id].V, posed.V);
              ViewPanel scan_panel;
              scan_panel.overlay = scan;
              scan_panel.caption = "its scan";
              scan_panel.camera = model_panel.camera;
              ViewPanel heat;
              heat.mesh = with_scalar(posed, "model_to_scan_mm", 1000 * r.model_to_scan);
              heat.scalar = "model_to_scan_mm";
              heat.caption = id + " " + pose;
              heat.camera = model_panel.camera;
              fig9.push_back(std::move(model_panel));
              fig9.push_back(std::move(scan_panel));
              fig9_heat.push_back(std::move(heat));
            }
          };
          for (PoseMethod m : {PoseMethod::kLearned, PoseMethod::kLbs}) {
            const FitTask& fit = fit_of(id, pose, m);
            if (!fit.error.empty()) throw InvalidInput(fit.error);
            add_row("fit", m, fit.result.pose, fit.result.V);
            for (const auto& w : fit.result.warnings) doc.warnings.push_back("subject " + id + " pose " + pose + ": fit: " + w);
          }
          for (PoseMethod m : {PoseMethod::kLearned, PoseMethod::kRigid, PoseMethod::kLbs})
            add_row("dataset", m, part_pose, synths[id]->pose(part_pose, m));
        } catch (const Error& e) {
          doc.warnings.push_back("subject " + id + " pose " + pose + ": comparison failed (" + e.what() + ")");
        }
      }
    }
    if (!fig9.empty()) {
      ViewOptions v = plain;
      v.panel_width = 150;
      v.panel_height = 400;
      v.point_size = 1.0;
      render(fig9, v, "fig9_posed_vs_scans.png",
             {"", "Figure 9: posed models and their scans",
              "Two subjects in the scanned poses: each model posed by the learned method in the pose fitted to the scan "
              "(posekit fit: no markers, no joint angles), beside the scan itself (the simulated scanner's points).",
              "posekit fit --model model.pkm --subject <rest.ply> --target <subject>/<pose>.pcd --out fitted.ply"});
      ViewOptions h = plain;
      h.panel_width = 200;
      h.panel_height = 440;
      h.colour_map = signed_error_map();
      render(fig9_heat, h, "fig9b_distances_to_scans.png",
             {"", "Figure 9b: the models of Figure 9 against their scans",
              "The same posed models coloured by their signed distance to the scan (positive: the scan lies outside the "
              "model; grey: no scan data nearby), on the scale of the data's 95th percentile.",
              "posekit compare fitted.ply <subject>/<pose>.pcd --png heatmap.png"});
    }
    Table overview{"Posed models against posed scans: summary",
                   {"pose from", "method", "cases", "scan to model mean mm", "RMS mm", "95th pct mm", "vertex error vs truth mm",
                    "joint angle error deg"},
                   {},
                   "Means over every subject and scanned pose of the table below (one row per subject, pose, pose source and "
                   "method)."};
    for (const auto& [key, sums] : summary_of) {
      const double n = std::max(sums[5], 1.0);
      overview.rows.push_back({key.first, key.second, std::to_string(static_cast<int>(sums[5])), fixed(sums[0] / n, 2),
                               fixed(sums[1] / n, 2), fixed(sums[2] / n, 2), fixed(sums[3] / n, 2), fixed(sums[4] / n, 1)});
    }
    if (!overview.rows.empty()) doc.table(overview);
    doc.table(posed_table);
    tick("figure 9");
  }

  /// Table 1: registration time and correspondence accuracy.
  void table1() {
    // Table 1.
    try {
      RegistrationTableOptions ro;
      ro.runs = o.registration_runs;
      ro.nicp_runs = o.nicp_subjects > 0 ? 1 : 0;
      ro.nicp_subjects = o.nicp_subjects;
      ro.model = model;
      // Table 1 depends on the dataset, the model, the shape space and the runs asked for.
      std::string table_inputs = dataset_print + "\nruns " + std::to_string(ro.runs) + " nicp subjects " +
                                 std::to_string(ro.nicp_subjects) + " calibration bodies " + std::to_string(o.calibration_bodies);
      if (cache.enabled() && !o.model_path.empty()) table_inputs += "\nmodel " + report_detail::file_fingerprint(o.model_path);
      std::string space_file;
      if (!o.shape_space_path.empty()) {
        ro.shape_space = std::make_shared<const ShapeSpace>(read_shape_space(o.shape_space_path));
        if (cache.enabled()) table_inputs += "\nshape space " + report_detail::file_fingerprint(o.shape_space_path);
      } else if (o.shape_space_bodies > 1) {
        space_file = cache.path("shape space", data_print + "\nbodies " + std::to_string(o.shape_space_bodies), ".pks");
        table_inputs += "\nshape space of " + std::to_string(o.shape_space_bodies) + " bodies";
        if (cached(space_file)) {
          ro.shape_space = std::make_shared<const ShapeSpace>(read_shape_space(space_file));
          reuse("shape space", space_file);
        } else {
          PopulationOptions po;
          po.count = o.shape_space_bodies;
          ro.shape_space = std::make_shared<const ShapeSpace>(makehuman_shape_space(*load_makehuman_model(find_data_root("")), po));
          if (!space_file.empty()) write_shape_space(space_file, *ro.shape_space);
        }
      }
      const std::string table_file = cache.path("table 1", table_inputs + "\n" + data_print, ".json");
      RegistrationTable t;
      std::string measured_when;
      if (cached(table_file)) {
        const nlohmann::json j = nlohmann::json::parse(read_file_bytes(table_file));
        t = report_detail::registration_table_from_json(j.at("table"));
        measured_when = j.at("measured").get<std::string>();
        reuse("Table 1", table_file);
      } else {
        t = measure_registration_table(dir, ro);
        if (!table_file.empty()) {
          const std::time_t now = std::time(nullptr);
          char when[32];
          std::strftime(when, sizeof when, "%Y-%m-%d %H:%M UTC", std::gmtime(&now));
          const nlohmann::json j = {{"measured", when}, {"table", report_detail::registration_table_to_json(t)}};
          write_file_atomically(
              table_file, [&](std::ostream& out) { out << j.dump(1); }, false);
        }
      }
      Table table{"Table 1: registration time and correspondence accuracy",
                  {"method", "median s", "min s", "max s", "point error mean mm", "p95 mm", "max mm", "triangle match mean mm", "p95 mm",
                   "pose transfer mm", "subjects"},
                  {},
                  "Template (" + std::to_string(t.template_vertices) + " vertices) registered to the subjects (~" +
                      std::to_string(t.mean_subject_vertices) + " vertices, ~" + std::to_string(t.mean_subject_triangles) +
                      " triangles), " + std::to_string(o.registration_runs) +
                      " runs each, single thread. Point error: each subject vertex's closest point on the registered "
                      "template, taken back to the template, against its true point. Triangle match (Eq. 2b): the "
                      "distance on the template between the matched triangle's centroid and the true point of the "
                      "subject triangle's centroid; the true correspondence itself scores " +
                      fixed(t.triangle_floor_mean_mm, 1) + " mm mean (" + fixed(t.triangle_floor_p95_mm, 1) +
                      " mm p95) on it. Pose transfer: mean vertex error of the subjects posed by the learned method with "
                      "that correspondence against their posed ground truth (with the true correspondence: " +
                      (t.pose_transfer_true_mm >= 0 ? fixed(t.pose_transfer_true_mm, 2) + " mm" : std::string("not measured")) +
                      "). The paper (Matlab, Core i7, 12,428 vertices): ICP 24 s for 1 iteration, 229 s "
                      "for 6, ct-FFD 5.1 s. Made by: posekit bench registration --dataset " +
                      dir +
                      (measured_when.empty() ? std::string()
                                             : ". Timed on " + measured_when +
                                                   " and reused from the cache (its inputs are "
                                                   "unchanged; posekit report --no-cache times it again)")};
      nlohmann::ordered_json rows = nlohmann::ordered_json::array();
      for (const auto& r : t.rows) {
        if (r.seconds.empty()) continue;
        table.rows.push_back({r.method, fixed(r.median_s, 3), fixed(r.min_s, 3), fixed(r.max_s, 3), fixed(r.point_mean_mm, 1),
                              fixed(r.point_p95_mm, 1), fixed(r.point_max_mm, 1), fixed(r.mean_error_mm, 1), fixed(r.p95_error_mm, 1),
                              r.pose_transfer_mm >= 0 ? fixed(r.pose_transfer_mm, 2) : "", std::to_string(r.subjects)});
        rows.push_back({{"method", r.method},
                        {"median_s", r.median_s},
                        {"point_mean_mm", r.point_mean_mm},
                        {"point_p95_mm", r.point_p95_mm},
                        {"point_max_mm", r.point_max_mm},
                        {"mean_error_mm", r.mean_error_mm},
                        {"p95_error_mm", r.p95_error_mm},
                        {"pose_transfer_mm", r.pose_transfer_mm},
                        {"subjects", r.subjects}});
      }
      doc.data["table1"] = rows;
      doc.table(table);
    } catch (const Error& e) {
      doc.warnings.push_back(std::string("Table 1: not measured (") + e.what() + ")");
    }
    tick("table 1");
  }

  /// The pose error table.
  void pose_accuracy() {
    // Pose error table.
    try {
      const PoseEvaluation ev = evaluate_poses(dir, model);
      Table table{"Pose accuracy against ground truth",
                  {"set", "method", "mean mm", "95th pct mm", "max mm"},
                  {},
                  "Per-vertex error: (a) the template in " + std::to_string(ev.test_poses) +
                      " held-out poses, (b) the subjects in their posed ground truth. Median time per pose (learned): " +
                      fixed(ev.pose_ms_median, 2) + " ms. Made by: posekit eval pose --dataset " + dir};
      nlohmann::ordered_json rows = nlohmann::ordered_json::array();
      for (auto [set, errors] :
           {std::pair{"template (held-out poses)", &ev.template_errors}, std::pair{"customized subjects", &ev.subject_errors}})
        for (const auto& m : *errors) {
          table.rows.push_back({set, pose_method_name(m.method), fixed(m.all.mean_mm, 2), fixed(m.all.p95_mm, 2), fixed(m.all.max_mm, 1)});
          rows.push_back({{"set", set},
                          {"method", pose_method_name(m.method)},
                          {"mean_mm", m.all.mean_mm},
                          {"p95_mm", m.all.p95_mm},
                          {"max_mm", m.all.max_mm}});
        }
      doc.data["pose_errors"] = rows;
      doc.table(table);
    } catch (const Error& e) {
      doc.warnings.push_back(std::string("pose accuracy: not measured (") + e.what() + ")");
    }
    tick("pose accuracy");
  }

  /// The report in Markdown, JSON and HTML.
  ReportSummary finish() {
    summary.seconds = t_start.seconds();
    nlohmann::ordered_json stages = nlohmann::ordered_json::object();
    for (const auto& [what, seconds] : summary.stage_seconds) stages[what] = seconds;
    doc.data["stage_seconds"] = stages;
    doc.data["reused_from_cache"] = summary.reused;
    doc.data["warnings"] = doc.warnings;
    doc.data["seconds"] = summary.seconds;
    const std::string title = "posekit report: " + dir;
    const std::string intro =
        "Figures and tables of Zhu & Mok, Efficient Pose Deformations for Human Models in Customized "
        "Sizes and Shapes, regenerated from the dataset in " +
        dir + " by: " + cmd + " (" + fixed(summary.seconds, 1) + " s). Lengths in mm unless stated.";
    const std::string md = doc.markdown(title, intro), html = doc.html(title, intro), json = doc.data.dump(2) + "\n";
    write_file_atomically((fs::path(out_dir) / "report.md").string(), [&](std::ostream& s) { s << md; }, false);
    write_file_atomically((fs::path(out_dir) / "report.json").string(), [&](std::ostream& s) { s << json; }, false);
    write_file_atomically((fs::path(out_dir) / "index.html").string(), [&](std::ostream& s) { s << html; }, false);
    summary.files.push_back("report.md");
    summary.files.push_back("report.json");
    summary.files.push_back("index.html");
    summary.warnings = doc.warnings;
    return summary;
  }

 private:
  void tick(const std::string& what) {
    summary.stage_seconds.emplace_back(what, stage_clock.seconds());
    stage_clock = Stopwatch();
    if (o.progress) o.progress(++step, total_steps, what);
  }
  static bool cached(const std::string& file) {
    std::error_code exists_ec;
    return !file.empty() && fs::is_regular_file(file, exists_ec);
  }
  void reuse(const std::string& what, const std::string& file) {
    summary.reused.push_back(what + " (" + fs::path(file).filename().string() + ")");
  }
  std::string path_in(const std::string& rel) const { return (fs::path(dir) / rel).string(); }
  void render(const std::vector<ViewPanel>& panels, const ViewOptions& v, const std::string& file, Figure f) {
    try {
      render_panels_png(panels, v, (fs::path(out_dir) / file).string());
      f.file = file;
      summary.files.push_back(file);
      if (doc.interactive) {
        const std::string id = fs::path(file).stem().string();
        f.web = write_web_figure(out_dir, id, panels, v);
        summary.files.push_back(id + ".js");
      }
      doc.figure(std::move(f));
    } catch (const Error& e) {
      doc.warnings.push_back(f.title + ": not made (" + e.what() + ")");
    }
  }

  const Stopwatch t_start;
  const std::string& dir;
  const std::string& out_dir;
  const ReportOptions& o;
  const nlohmann::json manifest;
  const nlohmann::json subjects;
  std::string cmd;
  Document doc;
  ReportSummary summary;
  const int total_steps = 10;
  int step = 0;
  Stopwatch stage_clock;
  const report_detail::ResultCache cache;
  std::string dataset_print, data_print;
  ViewOptions plain;
  ScanComparisonOptions co;
  std::shared_ptr<const PoseModel> model;
  TriangleMesh templ;
  std::unique_ptr<PoseSynthesizer> template_synth;
  std::vector<std::pair<std::string, PartPose>> shown;  ///< the poses of Figures 2 and 3
  std::map<std::string, std::unique_ptr<PoseSynthesizer>> synths;
  std::map<std::string, TriangleMesh> rests;
  std::map<std::string, TriangleMesh> from_photos;
};

}  // namespace

ReportSummary write_report(const std::string& dir, const std::string& out_dir, const ReportOptions& o) {
  ReportWriter report(dir, out_dir, o);
  report.pose_model();
  report.figure2();
  report.figure3();
  report.customization_from_photos();
  report.figures5_and_6();
  report.scans_and_figure4();
  report.figures7and8();
  report.figure9();
  report.table1();
  report.pose_accuracy();
  return report.finish();
}

}  // namespace posekit
