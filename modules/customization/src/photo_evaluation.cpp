#include "posekit/customization/photo_evaluation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <tuple>

#include "customization_detail.h"
#include "named_values.h"
#include "opencv_calls.h"
#include "photo_degradation.h"
#include "posekit/core/closest_point.h"
#include "posekit/core/error.h"
#include "posekit/core/timer.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/image_io.h"
#include "posekit/io/mesh_io.h"
#include "posekit/shape/measurements.h"

namespace posekit {
namespace fs = std::filesystem;
namespace {

const std::pair<PhotoVariation, const char*> kNames[] = {{PhotoVariation::kPhotos, "photos"},
                                                         {PhotoVariation::kMasks, "masks"},
                                                         {PhotoVariation::kErode2, "erode2"},
                                                         {PhotoVariation::kDilate2, "dilate2"},
                                                         {PhotoVariation::kHeightPlus1cm, "height+1cm"},
                                                         {PhotoVariation::kNearer20cm, "nearer20cm"},
                                                         {PhotoVariation::kFarther20cm, "farther20cm"},
                                                         {PhotoVariation::kTurned5deg, "turned5"},
                                                         {PhotoVariation::kJpegNoise, "jpeg-noise"},
                                                         {PhotoVariation::kCamera130Level, "camera1.30"},
                                                         {PhotoVariation::kCamera130Aimed, "camera1.30-aimed"},
                                                         {PhotoVariation::kCamera100Level, "camera1.00"},
                                                         {PhotoVariation::kRoom, "room"},
                                                         {PhotoVariation::kPhone, "phone"},
                                                         {PhotoVariation::kPhoneMasks, "phone-masks"}};

}  // namespace

void blur_image(Image8* img, double sigma) {
  const int radius = static_cast<int>(std::ceil(3 * sigma));
  std::vector<double> kernel(static_cast<size_t>(2 * radius + 1));
  double sum = 0;
  for (int k = -radius; k <= radius; ++k) sum += kernel[static_cast<size_t>(k + radius)] = std::exp(-0.5 * k * k / (sigma * sigma));
  for (double& k : kernel) k /= sum;
  const int w = img->width, h = img->height, n = img->channels;
  std::vector<float> a(static_cast<size_t>(w) * h), b(a.size());
  for (int c = 0; c < n; ++c) {
    for (size_t i = 0; i < a.size(); ++i) a[i] = img->pixels[n * i + c];
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        double x = 0;
        for (int k = -radius; k <= radius; ++k)
          x += kernel[static_cast<size_t>(k + radius)] * a[static_cast<size_t>(v) * w + std::clamp(u + k, 0, w - 1)];
        b[static_cast<size_t>(v) * w + u] = static_cast<float>(x);
      }
    for (int v = 0; v < h; ++v)
      for (int u = 0; u < w; ++u) {
        double x = 0;
        for (int k = -radius; k <= radius; ++k)
          x += kernel[static_cast<size_t>(k + radius)] * b[static_cast<size_t>(std::clamp(v + k, 0, h - 1)) * w + u];
        img->pixels[n * (static_cast<size_t>(v) * w + u) + c] = static_cast<std::uint8_t>(std::clamp(std::lround(x), 0L, 255L));
      }
  }
}

namespace {

/// The phone's cameras (kPhone): the dataset's directions, 2.3 m from the body's axis, 1.30 m above
/// the soles, aimed at the body's mid-height, 3000 x 4000 px, f = 3000 px.
PhotoCameras phone_cameras(const PhotoCameras& dataset, const TriangleMesh& subject) {
  const double floor = subject.V.col(1).minCoeff(), mid = 0.5 * (floor + subject.V.col(1).maxCoeff());
  PhotoCameras out = dataset;
  for (PinholeCamera* c : {&out.front, &out.side}) {
    Eigen::Vector3d away = c->centre();
    away.y() = 0;
    const Eigen::Vector3d eye = 2.3 * away.normalized() + Eigen::Vector3d(0, floor + 1.3, 0);
    *c = PinholeCamera::look_at(eye, Eigen::Vector3d(0, mid, 0), Eigen::Vector3d::UnitY(), 3000, 4000, 3000);
  }
  return out;
}

/// A rendered body photographed in a room: where no triangle covers a pixel, its ray meets the
/// floor (y = floor_y; grey 150, lighter towards the camera) or a wall `wall_behind` metres behind
/// the body's axis, square to the camera (grey 205, +-10% from one side of the frame to the other,
/// 5% darker per metre upwards). Gray, as 3 channels.
Image8 photo_in_room(const RenderBuffers& r, const PinholeCamera& cam, double floor_y, double wall_behind) {
  Image8 out{r.width, r.height, 3, std::vector<std::uint8_t>(static_cast<size_t>(r.width) * r.height * 3)};
  const Eigen::Vector3d o = cam.centre(), forward = cam.R.row(2).transpose();
  const double wall_depth = depth_of(cam, Eigen::Vector3d(0, floor_y, 0)) + wall_behind;
  for (int v = 0; v < r.height; ++v)
    for (int u = 0; u < r.width; ++u) {
      const size_t k = static_cast<size_t>(v) * r.width + u;
      double g = r.gray[k];
      if (r.face[k] < 0) {
        const Eigen::Vector3d d = cam.ray(u + 0.5, v + 0.5);
        const double t_wall = wall_depth / d.dot(forward), t_floor = d.y() < 0 ? (floor_y - o.y()) / d.y() : 1e9;
        if (t_floor < t_wall) {
          g = 150 + 10 * std::exp(-0.5 * t_floor);
        } else {
          const Eigen::Vector3d p = o + t_wall * d;
          g = 205 * (0.9 + 0.2 * u / std::max(1, r.width - 1)) * (1 - 0.05 * (p.y() - floor_y));
        }
      }
      const auto b = static_cast<std::uint8_t>(std::clamp(std::lround(g), 0L, 255L));
      for (int c = 0; c < 3; ++c) out.pixels[3 * k + c] = b;
    }
  return out;
}

/// The dataset's cameras moved to `height` above the subject's soles, at the same distance from the
/// body's axis; level, or aimed at the body's mid-height. The focal length is a phone's wider one
/// (1100 px for 1200 rows), so that a level camera at chest height still sees the feet.
PhotoCameras cameras_at_height(const PhotoCameras& dataset, const TriangleMesh& subject, double height, bool aimed) {
  const double floor = subject.V.col(1).minCoeff(), mid = 0.5 * (floor + subject.V.col(1).maxCoeff());
  PhotoCameras out = dataset;
  for (PinholeCamera* c : {&out.front, &out.side}) {
    Eigen::Vector3d eye = c->centre();
    const Eigen::Vector3d target(0, aimed ? mid : floor + height, 0);
    eye.y() = floor + height;
    *c = PinholeCamera::look_at(eye, target, Eigen::Vector3d::UnitY(), c->width, c->height, 1100);
  }
  return out;
}

nlohmann::json read_json(const fs::path& p) {
  std::ifstream in(p);
  if (!in) throw IoError("cannot open '" + p.string() + "'");
  try {
    nlohmann::json j;
    in >> j;
    return j;
  } catch (const std::exception& e) {
    throw InvalidInput("'" + p.string() + "': not JSON (" + e.what() + ")");
  }
}

Silhouette morph(const Silhouette& s, bool erode, int px) { return opencv_calls::morph_silhouette(s, erode, px); }

Silhouette degraded_photo(const std::string& path, const std::string& what, unsigned seed) {
  Image8 photo = read_image(path, ImageColor::kBgr);
  opencv_calls::add_gaussian_noise(&photo, seed, 4.0);
  const std::vector<std::uint8_t> jpg = encode_jpeg(photo, 60);
  Image8 back = decode_image(std::string(jpg.begin(), jpg.end()), ImageColor::kBgr, what);
  return silhouette_from_pixels(back.width, back.height, 3, back.pixels.data(), what);
}

}  // namespace

const std::vector<PhotoVariation>& all_photo_variations() {
  static const std::vector<PhotoVariation> v = table_values(kNames);
  return v;
}

const char* photo_variation_name(PhotoVariation v) { return table_name(kNames, v); }

PhotoVariation parse_photo_variation(const std::string& name) { return parse_table_name(kNames, name, "photo variation"); }

void summarise_photo_evaluation(PhotoEvaluation* ev) {
  double sb = 0, sw = 0, sh = 0, ss = 0, sd = 0;
  int ok = 0, girths_ok = 0;
  ev->failed = ev->girths_not_measured = ev->within_2cm = 0;
  ev->worst_girth_mm = 0;
  for (const PhotoSubjectResult& r : ev->subjects) {
    if (!r.ok) {
      ++ev->failed;
      continue;
    }
    ++ok;
    ss += std::abs(r.stature_mm), sd += r.surface_mm;
    if (!r.girths_measured) {
      ++ev->girths_not_measured;
      continue;
    }
    ++girths_ok;
    sb += std::abs(r.bust_mm), sw += std::abs(r.waist_mm), sh += std::abs(r.hip_mm);
    ev->worst_girth_mm = std::max({ev->worst_girth_mm, std::abs(r.bust_mm), std::abs(r.waist_mm), std::abs(r.hip_mm)});
    ev->within_2cm += std::abs(r.bust_mm) <= 20 && std::abs(r.waist_mm) <= 20 && std::abs(r.hip_mm) <= 20;
  }
  ev->mean_abs_stature_mm = ok ? ss / ok : 0, ev->mean_surface_mm = ok ? sd / ok : 0;
  ev->mean_abs_bust_mm = girths_ok ? sb / girths_ok : 0, ev->mean_abs_waist_mm = girths_ok ? sw / girths_ok : 0;
  ev->mean_abs_hip_mm = girths_ok ? sh / girths_ok : 0;
}

namespace {

/// A subject's two silhouettes under a variation, and the cameras and body they belong to.
struct VariationInputs {
  Silhouette front, side;
  Silhouette rendered_truth[2];  ///< the true silhouettes of photos made here (phone variations)
  double rendering_seconds = 0;  ///< making those photos (not timed)
  PhotoCameras cameras;
  TriangleMesh subject;       ///< where the person stood (turned for turned5)
  double stated_stature = 0;  ///< 0: none stated
};

/// The subject's dataset photos, masks or a re-rendering of its mesh, as `variation` says.
void photograph_subject(const fs::path& root, const nlohmann::json& photos, const std::string& id, PhotoVariation variation,
                        VariationInputs* in) {
  const std::string front_photo = (root / photos.at("front").get<std::string>()).string();
  const std::string side_photo = (root / photos.at("side").get<std::string>()).string();
  PhotoCameras& cams = in->cameras;
  TriangleMesh& subject = in->subject;
  switch (variation) {
    case PhotoVariation::kPhotos:
      in->front = silhouette_from_photo(front_photo, "front photo of " + id);
      in->side = silhouette_from_photo(side_photo, "side photo of " + id);
      break;
    case PhotoVariation::kJpegNoise:
      in->front = degraded_photo(front_photo, "front photo of " + id, 17);
      in->side = degraded_photo(side_photo, "side photo of " + id, 29);
      break;
    case PhotoVariation::kTurned5deg: {
      // The subject turned 5 degrees about the vertical through its centre.
      const Eigen::RowVector3d c = subject.V.colwise().mean();
      const Eigen::Matrix3d R = Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
      subject.V = ((subject.V.rowwise() - c) * R.transpose()).rowwise() + c;  // the surface compared where the person stood
      in->front = silhouette_from_render(render_mesh(subject, cams.front));
      in->side = silhouette_from_render(render_mesh(subject, cams.side));
      break;
    }
    case PhotoVariation::kCamera130Level:
    case PhotoVariation::kCamera130Aimed:
    case PhotoVariation::kCamera100Level: {
      const double h = variation == PhotoVariation::kCamera100Level ? 1.0 : 1.3;
      cams = cameras_at_height(cams, subject, h, variation == PhotoVariation::kCamera130Aimed);
      in->front = silhouette_from_render(render_mesh(subject, cams.front));
      in->side = silhouette_from_render(render_mesh(subject, cams.side));
      break;
    }
    case PhotoVariation::kRoom: {
      const double floor_y = subject.V.col(1).minCoeff();
      for (const auto& [view, cam, sil] :
           {std::tuple<const char*, const PinholeCamera&, Silhouette&>{"front", cams.front, in->front}, {"side", cams.side, in->side}}) {
        const Image8 photo = photo_in_room(render_mesh(subject, cam), cam, floor_y, 1.2);
        sil =
            silhouette_from_pixels(photo.width, photo.height, 3, photo.pixels.data(), std::string(view) + " photo of " + id + " in a room");
      }
      break;
    }
    case PhotoVariation::kPhone:
    case PhotoVariation::kPhoneMasks: {
      const double floor_y = subject.V.col(1).minCoeff();
      cams = phone_cameras(cams, subject);
      unsigned seed = 41;
      for (const auto& [view, cam, sil, truth] :
           {std::tuple<const char*, const PinholeCamera&, Silhouette&, Silhouette&>{"front", cams.front, in->front, in->rendered_truth[0]},
            {"side", cams.side, in->side, in->rendered_truth[1]}}) {
        const Stopwatch untimed;
        const RenderBuffers render = render_mesh(subject, cam);
        truth = silhouette_from_render(render);
        if (variation == PhotoVariation::kPhoneMasks) {
          in->rendering_seconds += untimed.seconds();
          sil = truth;
          continue;
        }
        Image8 photo = photo_in_room(render, cam, floor_y, 1.2);
        blur_image(&photo, 0.6);
        opencv_calls::add_gaussian_noise(&photo, seed++, 2.0);
        const std::vector<std::uint8_t> jpg = encode_jpeg(photo, 70);
        const std::string what = std::string(view) + " phone photo of " + id;
        photo = decode_image(std::string(jpg.begin(), jpg.end()), ImageColor::kBgr, what);
        in->rendering_seconds += untimed.seconds();
        sil = silhouette_from_pixels(photo.width, photo.height, 3, photo.pixels.data(), what);
      }
      break;
    }
    default:
      in->front = read_silhouette_mask((root / photos.at("front_mask").get<std::string>()).string(), "front mask of " + id);
      in->side = read_silhouette_mask((root / photos.at("side_mask").get<std::string>()).string(), "side mask of " + id);
      break;
  }
  if (variation == PhotoVariation::kErode2 || variation == PhotoVariation::kDilate2) {
    in->front = morph(in->front, variation == PhotoVariation::kErode2, 2);
    in->side = morph(in->side, variation == PhotoVariation::kErode2, 2);
  }
}

/// The variations without a camera file: a stated stature (maybe 1 cm off) and an assumed distance
/// (maybe 20 cm off).
void state_the_stature(PhotoVariation variation, double true_stature, VariationInputs* in) {
  if (variation != PhotoVariation::kHeightPlus1cm && variation != PhotoVariation::kNearer20cm && variation != PhotoVariation::kFarther20cm)
    return;
  const PinholeCamera& front = in->cameras.front;
  const double true_distance = (front.centre() - Eigen::Vector3d(0, front.centre().y(), 0)).norm();
  const double d = true_distance + (variation == PhotoVariation::kNearer20cm ? -0.2 : variation == PhotoVariation::kFarther20cm ? 0.2 : 0);
  in->stated_stature = true_stature + (variation == PhotoVariation::kHeightPlus1cm ? 0.01 : 0);
  in->cameras = cameras_from_stature(in->front, in->side, in->stated_stature, d);
}

void write_variation_inputs(const fs::path& dir, const VariationInputs& in) {
  create_folders(dir.string());
  write_silhouette_png((dir / "front_mask.png").string(), in.front);
  write_silhouette_png((dir / "side_mask.png").string(), in.side);
  const std::string text = "{\n\"front\": " + camera_to_json(in.cameras.front) + ",\n\"side\": " + camera_to_json(in.cameras.side) + "}\n";
  write_file_atomically((dir / "camera.json").string(), [&](std::ostream& os) { os << text; }, false);
}

double silhouette_iou(const Silhouette& truth, const Silhouette& mine) {
  long inter = 0, uni = 0;
  for (size_t k = 0; k < truth.mask.size() && k < mine.mask.size(); ++k)
    inter += truth.mask[k] && mine.mask[k], uni += truth.mask[k] || mine.mask[k];
  return static_cast<double>(inter) / std::max(1L, uni);
}

/// The result's stature, girths and surface against the subject's (its measurements file).
void score_against_truth(const CustomizedBody& body, const nlohmann::json& truth, const VariationInputs& in, PhotoSubjectResult* r) {
  r->warnings = body.warnings;
  r->photo_agreement = body.photo_agreement;
  const BodyMeasurements m = measure_body(body.mesh.V, body.mesh.F);
  r->stature_mm = 1000 * (m.stature - truth.at("stature").get<double>());
  const auto& g = truth.at("girths");
  const Girth *b = m.find("bust"), *w = m.find("waist"), *h = m.find("hip");
  r->girths_measured = b && w && h && b->measured && w->measured && h->measured;
  if (r->girths_measured) {
    r->bust_mm = 1000 * (b->value - g.at("bust").get<double>());
    r->waist_mm = 1000 * (w->value - g.at("waist").get<double>());
    r->hip_mm = 1000 * (h->value - g.at("hip").get<double>());
  } else {
    for (const Girth* x : {b, w, h})
      if (x && !x->measured) {
        r->error = "the result's " + x->name + " not measured: " + x->note;
        break;
      }
  }
  // Distance from the subject's vertices to the result: the result is where the person is in the
  // photos' world, and so is the subject's mesh (the dataset's cameras look at it). Without a camera
  // file the result stands in the assumed cameras' world: it is moved onto the subject by the
  // difference of the bounding boxes' floor centres (no rotation, no scale).
  TriangleMesh placed = body.mesh;
  if (!in.cameras.assumed.empty()) {
    auto floor_centre = [](const Eigen::MatrixXd& V) {
      const Eigen::RowVector3d lo = V.colwise().minCoeff(), hi = V.colwise().maxCoeff();
      return Eigen::RowVector3d(0.5 * (lo.x() + hi.x()), lo.y(), 0.5 * (lo.z() + hi.z()));
    };
    placed.V = placed.V.rowwise() + (floor_centre(in.subject.V) - floor_centre(placed.V));
  }
  const TriangleTree tree(placed.V, placed.F);
  r->surface_mm = 1000 * tree.closest(in.subject.V, 2).distance.mean();
}

/// One subject of the dataset customized under `variation` and scored.
PhotoSubjectResult evaluate_subject(const fs::path& root, const nlohmann::json& s, const CustomizationModel& model,
                                    PhotoVariation variation, const std::string& inputs_out, const BodyModel* body_model) {
  PhotoSubjectResult r;
  r.id = s.at("id").get<std::string>();
  const auto& photos = s.at("photos");
  const nlohmann::json truth = read_json(root / s.at("measurements").get<std::string>());
  VariationInputs in;
  in.cameras = read_photo_cameras((root / photos.at("camera").get<std::string>()).string());
  const Stopwatch t0;
  in.subject = read_mesh((root / s.at("rest").get<std::string>()).string());
  photograph_subject(root, photos, r.id, variation, &in);
  state_the_stature(variation, truth.at("stature").get<double>(), &in);
  if (!inputs_out.empty()) write_variation_inputs(fs::path(inputs_out) / photo_variation_name(variation) / r.id, in);
  const CustomizedBody body = body_model ? customize_by_body_model(*body_model, in.front, in.side, in.cameras, in.stated_stature)
                                         : customize_from_silhouettes(in.front, in.side, in.cameras, model, in.stated_stature);
  r.seconds = t0.seconds() - in.rendering_seconds;
  if (variation == PhotoVariation::kPhone || variation == PhotoVariation::kPhoneMasks)
    r.silhouette_iou =
        std::min({r.silhouette_iou, silhouette_iou(in.rendered_truth[0], in.front), silhouette_iou(in.rendered_truth[1], in.side)});
  if (variation < PhotoVariation::kTurned5deg || variation == PhotoVariation::kJpegNoise || variation == PhotoVariation::kRoom)
    for (const auto& [mine, key] : {std::pair<const Silhouette*, const char*>{&in.front, "front_mask"}, {&in.side, "side_mask"}})
      r.silhouette_iou =
          std::min(r.silhouette_iou, silhouette_iou(read_silhouette_mask((root / photos.at(key).get<std::string>()).string(), key), *mine));
  score_against_truth(body, truth, in, &r);
  r.ok = true;
  return r;
}

}  // namespace

PhotoEvaluation evaluate_photo_customization(const std::string& dataset_dir, const CustomizationModel& model, PhotoVariation variation,
                                             const std::vector<std::string>& ids, const std::string& inputs_out,
                                             const BodyModel* body_model) {
  const fs::path root(dataset_dir);
  const nlohmann::json manifest = read_json(root / "manifest.json");
  PhotoEvaluation ev;
  ev.variation = variation;
  for (const auto& s : manifest.at("subjects")) {
    const std::string id = s.at("id").get<std::string>();
    if (!ids.empty() && std::find(ids.begin(), ids.end(), id) == ids.end()) continue;
    try {
      ev.subjects.push_back(evaluate_subject(root, s, model, variation, inputs_out, body_model));
    } catch (const Error& e) {
      PhotoSubjectResult r;
      r.id = id;
      r.error = e.what();
      ev.subjects.push_back(std::move(r));
    }
  }
  summarise_photo_evaluation(&ev);
  return ev;
}

}  // namespace posekit
