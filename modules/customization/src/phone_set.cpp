#include "posekit/customization/phone_set.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <random>

#include "customization_detail.h"
#include "named_values.h"
#include "opencv_calls.h"
#include "photo_degradation.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/timer.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/mesh_io.h"
#include "posekit/population/ansur.h"
#include "posekit/population/survey_fit.h"
#include "posekit/shape/measurements.h"

namespace posekit {
namespace fs = std::filesystem;
namespace {

const std::pair<PhoneCondition, const char*> kConditions[] = {{PhoneCondition::kMasks, "masks"},
                                                              {PhoneCondition::kRoom, "room"},
                                                              {PhoneCondition::kPhone, "phone"},
                                                              {PhoneCondition::kTurned, "turned"}};

double bmi_of(const SurveySubject& s) {
  const double h = s.values[static_cast<size_t>(SurveyMeasure::kStature)];
  return s.weight_kg > 0 && h > 0 ? s.weight_kg / (h * h) : 0;
}

PhoneSetBody fitted_body(const SurveyBodyFitter& fitter, const MakeHumanModel& mh, const SurveySubject& s, const std::string& id,
                         const std::string& kind) {
  PhoneSetBody b;
  b.id = id, b.kind = kind, b.survey_id = s.id, b.bmi = bmi_of(s), b.male = s.male;
  b.mesh = build_body(mh, fitter.fit(s).spec).mesh;
  return b;
}

/// The cameras a body is photographed with (the same for every condition): distance, height, focal
/// length drawn for it; the front camera on +Z, the side camera on +X (the body's left), both aimed
/// at the body's middle.
PhotoCameras phone_set_cameras(const TriangleMesh& body, std::mt19937& rng) {
  std::uniform_real_distribution<double> distance(2.2, 2.5), height(1.0, 1.5), focal(2800, 3200);
  const Eigen::RowVector3d lo = body.V.colwise().minCoeff(), hi = body.V.colwise().maxCoeff();
  const Eigen::Vector3d mid(0.5 * (lo.x() + hi.x()), 0.5 * (lo.y() + hi.y()), 0.5 * (lo.z() + hi.z()));
  const double d = distance(rng), h = lo.y() + height(rng), f = focal(rng);
  PhotoCameras cams;
  cams.front = PinholeCamera::look_at(Eigen::Vector3d(mid.x(), h, mid.z() + d), mid, Eigen::Vector3d::UnitY(), 3000, 4000, f);
  cams.side = PinholeCamera::look_at(Eigen::Vector3d(mid.x() + d, h, mid.z()), mid, Eigen::Vector3d::UnitY(), 3000, 4000, f);
  return cams;
}

Silhouette coverage_silhouette(const std::vector<float>& coverage, int width, int height) {
  Silhouette s;
  s.width = width, s.height = height;
  s.mask.resize(coverage.size());
  for (size_t i = 0; i < coverage.size(); ++i) s.mask[i] = coverage[i] >= 0.5f ? 255 : 0;
  return s;
}

/// Scores a result against the body it was made from (measured as any mesh).
void score(const CustomizedBody& result, const TriangleMesh& truth, const BodyMeasurements& truth_measures, PhotoSubjectResult* r) {
  const BodyMeasurements m = measure_body(result.mesh.V, result.mesh.F);
  r->stature_mm = 1000 * (m.stature - truth_measures.stature);
  const char* names[3] = {"bust", "waist", "hip"};
  double* errors[3] = {&r->bust_mm, &r->waist_mm, &r->hip_mm};
  r->girths_measured = true;
  for (int k = 0; k < 3; ++k) {
    const Girth *got = m.find(names[k]), *want = truth_measures.find(names[k]);
    if (!want || !want->measured) {
      r->girths_measured = false;
      r->error = std::string("the truth's ") + names[k] + " not measured";
    } else if (!got || !got->measured) {
      r->girths_measured = false;
      r->error = std::string("the result's ") + names[k] + " not measured" + (got ? ": " + got->note : "");
    } else {
      *errors[k] = 1000 * (got->value - want->value);
    }
  }
  r->surface_mm = 1000 * TriangleTree(result.mesh.V, result.mesh.F).closest(truth.V, 1).distance.mean();
  r->warnings = result.warnings;
  r->photo_agreement = result.photo_agreement;
}

}  // namespace

const std::vector<PhoneCondition>& all_phone_conditions() {
  static const std::vector<PhoneCondition> v = table_values(kConditions);
  return v;
}

const char* phone_condition_name(PhoneCondition c) { return table_name(kConditions, c); }

PhoneCondition parse_phone_condition(const std::string& name) { return parse_table_name(kConditions, name, "phone set condition"); }

std::vector<PhoneSetBody> make_phone_set_bodies(const PhoneSetOptions& o) {
  std::vector<PhoneSetBody> out;
  if (o.ansur_bodies > 0 || o.extremes) {
    const std::vector<SurveySubject> survey = read_survey(o.survey);
    const auto mh = load_makehuman_model(o.data_root);
    const SurveyBodyFitter fitter(mh);
    if (o.ansur_bodies > 0)
      for (const SurveySubject& s : sample_survey(survey, o.ansur_bodies, o.seed))
        out.push_back(fitted_body(fitter, *mh, s, "ansur-" + s.id, "ansur"));
    if (o.extremes) {
      auto pick = [&](const char* what, bool male, auto better) {
        const SurveySubject* best = nullptr;
        for (const SurveySubject& s : survey)
          if (s.male == male && (!best || better(s, *best))) best = &s;
        if (best) out.push_back(fitted_body(fitter, *mh, *best, std::string("extreme-") + what + "-" + best->id, "extreme"));
      };
      const auto stature = [](const SurveySubject& s) { return s.values[static_cast<size_t>(SurveyMeasure::kStature)]; };
      pick("bmi-woman", false, [](const SurveySubject& a, const SurveySubject& b) { return bmi_of(a) > bmi_of(b); });
      pick("bmi-man", true, [](const SurveySubject& a, const SurveySubject& b) { return bmi_of(a) > bmi_of(b); });
      pick("tallest-man", true, [&](const SurveySubject& a, const SurveySubject& b) { return stature(a) > stature(b); });
      pick("shortest-woman", false, [&](const SurveySubject& a, const SurveySubject& b) { return stature(a) < stature(b); });
    }
  }
  if (!o.dataset_dir.empty()) {
    const fs::path root(o.dataset_dir);
    std::ifstream in(root / "manifest.json");
    if (!in) throw IoError("cannot open '" + (root / "manifest.json").string() + "'");
    nlohmann::json manifest;
    try {
      in >> manifest;
      for (const auto& s : manifest.at("subjects")) {
        PhoneSetBody b;
        b.id = s.at("id").get<std::string>(), b.kind = "dataset";
        b.bmi = s.value("bmi", 0.0), b.male = s.value("gender", "") == "male";
        b.mesh = read_mesh((root / s.at("rest").get<std::string>()).string());
        out.push_back(std::move(b));
      }
    } catch (const nlohmann::json::exception& e) {
      throw InvalidInput("'" + (root / "manifest.json").string() + "': " + e.what());
    }
  }
  return out;
}

namespace {

/// The room behind the body: a floor at floor_y and a wall `wall_behind` metres behind the body's
/// axis, square to the camera, lit from one side (BGR colour of a pixel's ray).
struct Room {
  const PinholeCamera& cam;
  double floor_y, wall_depth;
  Eigen::Vector3d eye, forward;
  Room(const PinholeCamera& c, const TriangleMesh& mesh, double floor, double wall_behind)
      : cam(c), floor_y(floor), eye(c.centre()), forward(c.R.row(2).transpose()) {
    wall_depth = (mesh.V.colwise().mean().transpose() - eye).dot(forward) + wall_behind;
  }
  Eigen::Vector3d colour(double u, double v) const {
    const Eigen::Vector3d d = cam.ray(u, v);
    const double t_wall = wall_depth / d.dot(forward), t_floor = d.y() < 0 ? (floor_y - eye.y()) / d.y() : 1e9;
    if (t_floor < t_wall) return Eigen::Vector3d(105, 120, 138) * (1.0 + 0.08 * std::exp(-0.4 * t_floor));  // a warm grey floor
    const Eigen::Vector3d p = eye + t_wall * d;
    return Eigen::Vector3d(196, 208, 214) * (0.88 + 0.24 * u / cam.width) * (1 - 0.04 * (p.y() - floor_y));  // an off-white wall
  }
};

/// The set's rasterizer, a band of rows at a time: each pixel's kSub x kSub subsamples hold the
/// nearest surface's depth and shaded colour.
class SupersampledBody {
 public:
  static constexpr int kSub = 4, kBand = 32, kSamples = kSub * kSub;

  SupersampledBody(const TriangleMesh& mesh, const PinholeCamera& cam, const Eigen::Vector3d& skin_bgr)
      : mesh_(mesh), cam_(cam), skin_(skin_bgr), normals_(vertex_normals(mesh.V, mesh.F)), screen_(mesh.V.rows(), 3) {
    for (Eigen::Index i = 0; i < mesh.V.rows(); ++i) {
      const Eigen::Vector3d p = cam.R * mesh.V.row(i).transpose() + cam.t;
      screen_.row(i) << cam.fx * p.x() / p.z() + cam.cx, cam.fy * p.y() / p.z() + cam.cy, p.z();
    }
    const int bands = (cam.height + kBand - 1) / kBand;
    in_band_.resize(static_cast<size_t>(bands));
    for (int f = 0; f < mesh.F.rows(); ++f) {
      double lo = 1e30, hi = -1e30, zmin = 1e30;
      for (int a = 0; a < 3; ++a)
        lo = std::min(lo, screen_(mesh.F(f, a), 1)), hi = std::max(hi, screen_(mesh.F(f, a), 1)),
        zmin = std::min(zmin, screen_(mesh.F(f, a), 2));
      if (zmin < 0.01 || hi < 0 || lo >= cam.height) continue;
      for (int b = std::max(0, static_cast<int>(lo) / kBand); b <= std::min(bands - 1, static_cast<int>(hi) / kBand); ++b)
        in_band_[static_cast<size_t>(b)].push_back(f);
    }
    // Directions towards the lights, said in the camera's frame (x right, y down, z ahead) and turned
    // to the world: a key light from the upper left, a fill from the right.
    key_ = cam.R.transpose() * Eigen::Vector3d(-0.5, -0.7, -0.5).normalized();
    fill_ = cam.R.transpose() * Eigen::Vector3d(0.8, 0.1, -0.6).normalized();
    depth_.resize(static_cast<size_t>(cam.width) * kBand * kSamples);
    colour_.resize(depth_.size());
  }
  int bands() const { return static_cast<int>(in_band_.size()); }

  /// Rasterizes band b (rows b * kBand ...).
  void rasterize(int b) {
    const int v0 = b * kBand, v1 = std::min(cam_.height, v0 + kBand), W = cam_.width;
    std::fill(depth_.begin(), depth_.end(), std::numeric_limits<float>::infinity());
    for (int f : in_band_[static_cast<size_t>(b)]) {
      const int ia = mesh_.F(f, 0), ib = mesh_.F(f, 1), ic = mesh_.F(f, 2);
      const Eigen::Vector2d A = screen_.row(ia).head<2>().transpose(), B = screen_.row(ib).head<2>().transpose(),
                            C = screen_.row(ic).head<2>().transpose();
      const double area = (B - A).x() * (C - A).y() - (B - A).y() * (C - A).x();
      if (std::abs(area) < 1e-12) continue;
      const int u_lo = std::max(0, static_cast<int>(std::floor(std::min({A.x(), B.x(), C.x()})))),
                u_hi = std::min(W - 1, static_cast<int>(std::floor(std::max({A.x(), B.x(), C.x()}))));
      const int v_lo = std::max(v0, static_cast<int>(std::floor(std::min({A.y(), B.y(), C.y()})))),
                v_hi = std::min(v1 - 1, static_cast<int>(std::floor(std::max({A.y(), B.y(), C.y()}))));
      const double iza = 1 / screen_(ia, 2), izb = 1 / screen_(ib, 2), izc = 1 / screen_(ic, 2);
      for (int v = v_lo; v <= v_hi; ++v)
        for (int u = u_lo; u <= u_hi; ++u)
          for (int sy = 0; sy < kSub; ++sy)
            for (int sx = 0; sx < kSub; ++sx) {
              const Eigen::Vector2d P(u + (sx + 0.5) / kSub, v + (sy + 0.5) / kSub);
              const double wa = ((B - P).x() * (C - P).y() - (B - P).y() * (C - P).x()) / area;
              const double wb = ((C - P).x() * (A - P).y() - (C - P).y() * (A - P).x()) / area;
              const double wc = 1 - wa - wb;
              if (wa < 0 || wb < 0 || wc < 0) continue;
              const double iz = wa * iza + wb * izb + wc * izc;  // perspective-correct: 1/z is linear on the screen
              const size_t k = (static_cast<size_t>(v - v0) * W + u) * kSamples + sy * kSub + sx;
              if (static_cast<float>(1 / iz) >= depth_[k]) continue;
              depth_[k] = static_cast<float>(1 / iz);
              const Eigen::Vector3d n =
                  (wa * iza * normals_.row(ia) + wb * izb * normals_.row(ib) + wc * izc * normals_.row(ic)).transpose().normalized();
              const double light = 0.22 + 0.62 * std::max(0.0, n.dot(key_)) + 0.28 * std::max(0.0, n.dot(fill_));
              colour_[k] = (skin_ * light).cast<float>();
            }
    }
  }

  /// Band b's pixels: the mean of their subsamples, the room where no surface covers one.
  void resolve(int b, const Room& room, Image8* out, std::vector<float>* coverage) const {
    const int v0 = b * kBand, v1 = std::min(cam_.height, v0 + kBand), W = cam_.width;
    for (int v = v0; v < v1; ++v)
      for (int u = 0; u < W; ++u) {
        const size_t base = (static_cast<size_t>(v - v0) * W + u) * kSamples;
        Eigen::Vector3d sum = Eigen::Vector3d::Zero();
        int covered = 0;
        for (int k = 0; k < kSamples; ++k)
          if (depth_[base + k] < std::numeric_limits<float>::infinity()) sum += colour_[base + k].cast<double>(), ++covered;
        if (covered < kSamples) sum += (kSamples - covered) * room.colour(u + 0.5, v + 0.5);
        sum /= kSamples;
        std::uint8_t* px = &out->pixels[3 * (static_cast<size_t>(v) * W + u)];
        for (int c = 0; c < 3; ++c) px[c] = static_cast<std::uint8_t>(std::clamp(std::lround(sum(c)), 0L, 255L));
        if (coverage) (*coverage)[static_cast<size_t>(v) * W + u] = static_cast<float>(covered) / kSamples;
      }
  }

 private:
  const TriangleMesh& mesh_;
  const PinholeCamera& cam_;
  Eigen::Vector3d skin_, key_, fill_;
  Eigen::MatrixXd normals_, screen_;  ///< screen_: u, v, depth per vertex
  std::vector<std::vector<int>> in_band_;
  std::vector<float> depth_;
  std::vector<Eigen::Vector3f> colour_;
};

}  // namespace

Image8 render_phone_photo(const TriangleMesh& mesh, const PinholeCamera& cam, double floor_y, double wall_behind,
                          const Eigen::Vector3d& skin_bgr, std::vector<float>* coverage) {
  SupersampledBody body(mesh, cam, skin_bgr);
  const Room room(cam, mesh, floor_y, wall_behind);
  Image8 out{cam.width, cam.height, 3, std::vector<std::uint8_t>(static_cast<size_t>(cam.width) * cam.height * 3)};
  if (coverage) coverage->assign(static_cast<size_t>(cam.width) * cam.height, 0.0f);
  for (int b = 0; b < body.bands(); ++b) {
    body.rasterize(b);
    body.resolve(b, room, &out, coverage);
  }
  return out;
}

namespace {

/// One body photographed under a condition: the silhouettes the methods get, how long extracting
/// them took, their IoU with the true silhouettes, or why they could not be had.
struct PhoneShot {
  PhotoCameras cameras;
  TriangleMesh shown;  ///< the body as photographed (turned under kTurned)
  Silhouette silhouette[2];
  double extraction_seconds = 0, iou = 1;
  std::string error;
};

PhoneShot photograph(const PhoneSetBody& body, size_t index, PhoneCondition condition, unsigned seed, const std::string& inputs_out) {
  // Skin tones from light to dark (BGR), taken in turn.
  const Eigen::Vector3d tones[] = {{150, 175, 220}, {115, 145, 195}, {80, 110, 160}, {50, 68, 105}};
  PhoneShot shot;
  std::mt19937 rng(seed + 7919 * static_cast<unsigned>(index));
  shot.cameras = phone_set_cameras(body.mesh, rng);
  std::uniform_real_distribution<double> turn_draw(-5, 5), wall_draw(1.0, 1.6);
  const double turn = turn_draw(rng), wall = wall_draw(rng);
  shot.shown = body.mesh;
  if (condition == PhoneCondition::kTurned) {
    const Eigen::RowVector3d c = shot.shown.V.colwise().mean();
    const Eigen::Matrix3d R = Eigen::AngleAxisd(turn * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    shot.shown.V = ((shot.shown.V.rowwise() - c) * R.transpose()).rowwise() + c;
  }
  const double floor_y = shot.shown.V.col(1).minCoeff();
  const fs::path dir = inputs_out.empty() ? fs::path() : fs::path(inputs_out) / phone_condition_name(condition) / body.id;
  if (!inputs_out.empty()) create_folders(dir.string());
  try {
    for (int k = 0; k < 2; ++k) {
      const PinholeCamera& cam = k == 0 ? shot.cameras.front : shot.cameras.side;
      const std::string view = k == 0 ? "front" : "side";
      std::vector<float> coverage;
      Image8 photo = render_phone_photo(shot.shown, cam, floor_y, wall, tones[index % 4], &coverage);
      const Silhouette truth = coverage_silhouette(coverage, cam.width, cam.height);
      if (condition == PhoneCondition::kMasks) {
        shot.silhouette[k] = truth;
        if (!inputs_out.empty()) write_silhouette_png((dir / (view + "_mask.png")).string(), truth);
        continue;
      }
      const std::string what = view + " photo of " + body.id;
      if (condition != PhoneCondition::kRoom) {
        blur_image(&photo, 0.6);
        opencv_calls::add_gaussian_noise(&photo, seed + static_cast<unsigned>(2 * index + k), 2.0);
        const std::vector<std::uint8_t> jpg = encode_jpeg(photo, 70);
        photo = decode_image(std::string(jpg.begin(), jpg.end()), ImageColor::kBgr, what);
      }
      if (!inputs_out.empty()) {
        const std::vector<std::uint8_t> jpg = encode_jpeg(photo, 92);
        write_file_atomically((dir / (view + ".jpg")).string(), [&](std::ostream& os) {
          os.write(reinterpret_cast<const char*>(jpg.data()), static_cast<std::streamsize>(jpg.size()));
        });
      }
      const Stopwatch t;
      shot.silhouette[k] = silhouette_from_pixels(photo.width, photo.height, 3, photo.pixels.data(), what);
      shot.extraction_seconds += t.seconds();
      long both = 0, either = 0;
      for (size_t p = 0; p < truth.mask.size(); ++p)
        both += shot.silhouette[k].mask[p] && truth.mask[p], either += shot.silhouette[k].mask[p] || truth.mask[p];
      shot.iou = std::min(shot.iou, static_cast<double>(both) / std::max(1L, either));
    }
    if (!inputs_out.empty()) {
      const std::string text =
          "{\n\"front\": " + camera_to_json(shot.cameras.front) + ",\n\"side\": " + camera_to_json(shot.cameras.side) + "}\n";
      write_file_atomically((dir / "camera.json").string(), [&](std::ostream& os) { os << text; }, false);
    }
  } catch (const Error& e) {
    shot.error = e.what();
  }
  return shot;
}

}  // namespace

std::vector<PhotoEvaluation> evaluate_phone_set(const std::vector<PhoneSetBody>& bodies, PhoneCondition condition,
                                                const std::vector<PhotoCustomizer>& methods, unsigned seed,
                                                const std::function<void(int, int)>& progress, const std::string& inputs_out) {
  std::vector<PhotoEvaluation> out(methods.size());
  for (auto& ev : out) ev.label = phone_condition_name(condition);
  for (size_t i = 0; i < bodies.size(); ++i) {
    const PhoneShot shot = photograph(bodies[i], i, condition, seed, inputs_out);
    const BodyMeasurements truth = measure_body(bodies[i].mesh.V, bodies[i].mesh.F);
    for (size_t m = 0; m < methods.size(); ++m) {
      PhotoSubjectResult r;
      r.id = bodies[i].id;
      r.silhouette_iou = shot.iou;
      r.error = shot.error;
      if (shot.error.empty()) {
        try {
          const Stopwatch t;
          const CustomizedBody result = methods[m](shot.silhouette[0], shot.silhouette[1], shot.cameras);
          r.seconds = shot.extraction_seconds + t.seconds();
          score(result, shot.shown, truth, &r);
          r.ok = true;
        } catch (const Error& e) {
          r.error = e.what();
        }
      }
      out[m].subjects.push_back(std::move(r));
    }
    if (progress) progress(static_cast<int>(i) + 1, static_cast<int>(bodies.size()));
  }
  for (auto& ev : out) summarise_photo_evaluation(&ev);
  return out;
}

}  // namespace posekit
