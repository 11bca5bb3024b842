#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "posekit/body/makehuman_model.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/rasterizer.h"
#include "posekit/customization/phone_set.h"
#include "posekit/customization/photo_evaluation.h"
#include "posekit/io/image_io.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/measurements.h"
#include "testing/small_dataset.h"
#include "testing/temp_dir.h"
#include "testing/test_meshes.h"

using namespace posekit;

namespace {

/// A MakeHuman body (default or heavier), its front and side cameras as the dataset places them.
struct Scene {
  TriangleMesh body;
  PhotoCameras cameras;
  RenderBuffers front, side;
};

const TriangleMesh& default_body() {
  static const TriangleMesh m = [] {
    const auto model = load_makehuman_model(test::test_data_root());
    return build_body(*model, BodySpec{}).mesh;
  }();
  return m;
}

Scene photograph(const TriangleMesh& body, double distance = 3.0) {
  Scene s;
  s.body = body;
  const double mid = 0.5 * (body.V.col(1).maxCoeff() + body.V.col(1).minCoeff());
  s.cameras.front = PinholeCamera::look_at({0, mid, distance}, {0, mid, 0}, Eigen::Vector3d::UnitY(), 800, 1200, 1400);
  s.cameras.side = PinholeCamera::look_at({distance, mid, 0}, {0, mid, 0}, Eigen::Vector3d::UnitY(), 800, 1200, 1400);
  s.front = render_mesh(body, s.cameras.front);
  s.side = render_mesh(body, s.cameras.side);
  return s;
}

Silhouette mask_of(const RenderBuffers& b) { return silhouette_from_render(b); }

double iou(const Silhouette& a, const Silhouette& b) {
  long inter = 0, uni = 0;
  for (size_t k = 0; k < a.mask.size(); ++k) inter += a.mask[k] && b.mask[k], uni += a.mask[k] || b.mask[k];
  return static_cast<double>(inter) / std::max(1L, uni);
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

TEST(Silhouette, ThePersonIsSeparatedFromAPlainBackgroundEvenThroughNoiseAndJpeg) {
  const Scene s = photograph(default_body());
  const Silhouette truth = mask_of(s.front);
  const Silhouette found = silhouette_from_pixels(s.front.width, s.front.height, 1, s.front.gray.data(), "front photo");
  EXPECT_GT(iou(found, truth), 0.985);
  // Sensor noise (sigma 4) and JPEG at quality 60.
  cv::Mat img(s.front.height, s.front.width, CV_8U, const_cast<std::uint8_t*>(s.front.gray.data()));
  cv::Mat noisy, noise(img.size(), CV_32F);
  cv::RNG rng(3);
  rng.fill(noise, cv::RNG::NORMAL, 0, 4);
  img.convertTo(noisy, CV_32F);
  noisy += noise;
  noisy.convertTo(noisy, CV_8U);
  std::vector<std::uint8_t> jpg;
  cv::imencode(".jpg", noisy, jpg, {cv::IMWRITE_JPEG_QUALITY, 60});
  const cv::Mat back = cv::imdecode(jpg, cv::IMREAD_GRAYSCALE);
  const Silhouette degraded = silhouette_from_pixels(back.cols, back.rows, 1, back.data, "front photo");
  EXPECT_GT(iou(degraded, truth), 0.975);
}

// A photo taken in a room: the floor in view under the feet, a wall lit from one side and darker
// upwards, optionally papered (a 40 px check of +-25 grey levels). `with_person` false: the empty scene.
std::vector<std::uint8_t> photo_in_room(const Scene& s, bool papered, bool with_person = true) {
  const PinholeCamera& c = s.cameras.front;
  const double floor_y = s.body.V.col(1).minCoeff(), wall_z = -1.2;
  std::vector<std::uint8_t> out(s.front.gray.size());
  for (int v = 0; v < s.front.height; ++v)
    for (int u = 0; u < s.front.width; ++u) {
      const size_t k = static_cast<size_t>(v) * s.front.width + u;
      double g = s.front.gray[k];
      if (!with_person || s.front.face[k] < 0) {
        const Eigen::Vector3d o = c.centre(), d = c.ray(u + 0.5, v + 0.5);
        const double t_wall = (wall_z - o.z()) / d.z(), t_floor = d.y() < 0 ? (floor_y - o.y()) / d.y() : 1e9;
        if (t_floor < t_wall) {
          g = 150;
        } else {
          const double y = o.y() + t_wall * d.y() - floor_y;
          g = 205 * (0.9 + 0.2 * u / (s.front.width - 1.0)) * (1 - 0.05 * y);
          if (papered) g += ((u / 40 + v / 40) % 2 ? 25 : -25);
        }
      }
      out[k] = static_cast<std::uint8_t>(std::clamp(std::lround(g), 0L, 255L));
    }
  return out;
}

TEST(Silhouette, AFloorInViewAndAnUnevenlyLitWallAreBackground) {
  const Scene s = photograph(default_body());
  const Silhouette truth = mask_of(s.front);
  const std::vector<std::uint8_t> room = photo_in_room(s, false);
  EXPECT_GT(iou(silhouette_from_pixels(s.front.width, s.front.height, 1, room.data(), "front photo"), truth), 0.98);
  // A papered wall is not modelled by the frame; a photo of the empty scene is.
  const std::vector<std::uint8_t> papered = photo_in_room(s, true), empty = photo_in_room(s, true, false);
  double without = 0;
  try {
    without = iou(silhouette_from_pixels(s.front.width, s.front.height, 1, papered.data(), "front photo"), truth);
  } catch (const InvalidInput&) {
  }
  EXPECT_LT(without, 0.9);
  test::TempDir dir;
  write_png(dir.file("empty.png"), Image8{s.front.width, s.front.height, 1, empty});
  SilhouetteOptions o;
  o.background_photo = dir.file("empty.png");
  EXPECT_GT(iou(silhouette_from_pixels(s.front.width, s.front.height, 1, papered.data(), "front photo", o), truth), 0.98);
  write_png(dir.file("small.png"), Image8{10, 10, 1, std::vector<std::uint8_t>(100, 200)});
  o.background_photo = dir.file("small.png");
  EXPECT_NE(error_of([&] { silhouette_from_pixels(s.front.width, s.front.height, 1, papered.data(), "front photo", o); }).find("10x10"),
            std::string::npos);
}

// The robustness set's renderer (issue 46 part 7) is written apart from the dataset's: its edges are
// anti-aliased (pixels partly covered), yet it sees the same body where the dataset's does (the
// silhouettes of the two agree), its body is shaded in colour, and the person is found in its room.
TEST(Silhouette, ThePhoneSetsRendererSeesTheBodyAsTheDatasetsDoesWithOtherEdges) {
  const Scene s = photograph(default_body());
  std::vector<float> coverage;
  const double floor_y = s.body.V.col(1).minCoeff();
  const Image8 photo = render_phone_photo(s.body, s.cameras.front, floor_y, 1.2, Eigen::Vector3d(80, 110, 160), &coverage);
  Silhouette half = mask_of(s.front);
  int partial = 0;
  for (size_t k = 0; k < coverage.size(); ++k) {
    half.mask[k] = coverage[k] >= 0.5f ? 255 : 0;
    partial += coverage[k] > 0.05f && coverage[k] < 0.95f;
  }
  EXPECT_GT(partial, 1000);  // the outline's pixels, some thousands at 1200 rows
  EXPECT_GT(iou(half, mask_of(s.front)), 0.98);
  // Colour: the skin's blue, green and red differ where the wall's hardly do.
  const int chest_row = half.top() + 3 * (half.bottom() - half.top()) / 10;
  const size_t centre = 3 * (static_cast<size_t>(chest_row) * half.width + (half.left() + half.right()) / 2);
  ASSERT_GT(coverage[centre / 3], 0.99f);
  EXPECT_GT(photo.pixels[centre + 2] - photo.pixels[centre], 30);
  EXPECT_GT(iou(silhouette_from_pixels(photo.width, photo.height, 3, photo.pixels.data(), "front photo"), half), 0.97);
}

// A phone-sized photo (here 2400 x 3600) is worked on at about 1200 rows and the mask brought back
// to full size: the same person, to about a pixel of the reduced image.
TEST(Silhouette, ALargePhotoIsReducedAndItsMaskBroughtBack) {
  const TriangleMesh body = default_body();
  const double mid = 0.5 * (body.V.col(1).maxCoeff() + body.V.col(1).minCoeff());
  const PinholeCamera cam = PinholeCamera::look_at({0, mid, 3.0}, {0, mid, 0}, Eigen::Vector3d::UnitY(), 2400, 3600, 4200);
  const RenderBuffers r = render_mesh(body, cam);
  const Silhouette truth = mask_of(r);
  const Silhouette found = silhouette_from_pixels(r.width, r.height, 1, r.gray.data(), "front photo");
  ASSERT_EQ(found.width, 2400);
  ASSERT_EQ(found.height, 3600);
  EXPECT_GT(iou(found, truth), 0.97);
  EXPECT_NEAR(found.bottom(), truth.bottom(), 3);
  EXPECT_NEAR(found.top(), truth.top(), 3);
}

// Skin shaded like the wall behind it leaves a hole in the chest: a torso has none, so it is filled;
// the gaps beside the torso (under the arms) stay open.
TEST(Silhouette, AHoleOnTheTorsoIsFilled) {
  const Scene s = photograph(default_body());
  const Silhouette truth = mask_of(s.front);
  std::vector<std::uint8_t> photo = s.front.gray;
  const int cu = static_cast<int>(std::lround(0.5 * (truth.left() + truth.right()))), cv = truth.top() + (truth.bottom() - truth.top()) / 3;
  for (int v = cv - 25; v <= cv + 25; ++v)
    for (int u = cu - 25; u <= cu + 25; ++u)
      if ((u - cu) * (u - cu) + (v - cv) * (v - cv) <= 625) photo[static_cast<size_t>(v) * s.front.width + u] = 235;
  const Silhouette found = silhouette_from_pixels(s.front.width, s.front.height, 1, photo.data(), "front photo");
  EXPECT_TRUE(found.inside(cu, cv));
  EXPECT_GT(iou(found, truth), 0.985);
}

TEST(Silhouette, PhotosWithoutOnePersonAreRefusedWithTheReason) {
  std::vector<std::uint8_t> plain(400 * 600, 200);
  EXPECT_NE(error_of([&] { silhouette_from_pixels(400, 600, 1, plain.data(), "front photo"); }).find("no person"), std::string::npos);
  // Two bodies side by side.
  TriangleMesh two = default_body();
  const Eigen::Index n = two.V.rows(), m = two.F.rows();
  two.V.conservativeResize(2 * n, 3);
  two.V.bottomRows(n) = two.V.topRows(n).rowwise() + Eigen::RowVector3d(0.9, 0, 0);
  two.V.topRows(n).col(0).array() -= 0.9;
  two.F.conservativeResize(2 * m, 3);
  two.F.bottomRows(m) = two.F.topRows(m).array() + static_cast<int>(n);
  Scene s = photograph(two, 4.5);
  EXPECT_NE(
      error_of([&] { silhouette_from_pixels(s.front.width, s.front.height, 1, s.front.gray.data(), "front photo"); }).find("two figures"),
      std::string::npos);
  // The gap between a forearm and the waist is background enclosed by the person: it stays.
  Silhouette ring;
  ring.width = 200, ring.height = 300;
  ring.mask.assign(200 * 300, 0);
  for (int v = 50; v < 250; ++v)
    for (int u = 50; u < 150; ++u) ring.mask[static_cast<size_t>(v) * 200 + u] = (u < 70 || u >= 130 || v < 70 || v >= 230) ? 255 : 0;
  test::TempDir tmp;
  write_silhouette_png(tmp.file("ring.png"), ring);
  const Silhouette read = read_silhouette_mask(tmp.file("ring.png"), "mask");
  EXPECT_FALSE(read.inside(100, 150)) << "a large enclosed gap is not a hole to fill";
  ring.mask[static_cast<size_t>(150) * 200 + 100] = 0;
  // A mask that fills the frame, and a person cut at the top.
  Silhouette full;
  full.width = 300, full.height = 500;
  full.mask.assign(300 * 500, 255);
  EXPECT_NE(error_of([&] { check_silhouette(full, "front mask"); }).find("of the frame"), std::string::npos);
  Scene close = photograph(default_body(), 1.2);
  EXPECT_NE(error_of([&] { check_silhouette(mask_of(close.front), "front mask"); }).find("touches the"), std::string::npos);
}

TEST(PhotoLandmarks, LevelsAndStatureAgreeWithTheBodysOwnFeatures) {
  const Scene s = photograph(default_body());
  const PhotoLandmarks L = find_photo_landmarks(mask_of(s.front), mask_of(s.side), s.cameras);
  const BodyFeatures f = find_body_features(s.body.V, s.body.F);
  EXPECT_NEAR(L.floor_y, f.floor_y, 0.01);
  EXPECT_NEAR(L.crown_y, f.crown_y, 0.01);
  EXPECT_NEAR(L.crotch_y, f.crotch_y, 0.03);
  for (int side : {kLeft, kRight}) {
    EXPECT_NEAR(L.armpit_y[side], f.armpit[side].y(), 0.04) << side;
    EXPECT_NEAR(L.hand_tip[side].y(), f.hand_tip[side].y(), 0.03) << side;
    EXPECT_GT(L.hand_tip[side].x() * (side == kLeft ? 1 : -1), 0.3) << "left is +X";
  }
  EXPECT_NEAR(L.axis_x, 0, 0.01);
  EXPECT_GT(L.front_to_side_ratio, 1.2);
}

// The check on every customized body: the mesh seen by the photos' cameras against the silhouettes.
TEST(PhotoLandmarks, PhotoAgreementTellsABodyThatLooksLikeThePhotosFromOneThatDoesNot) {
  const Scene s = photograph(default_body());
  const Silhouette front = mask_of(s.front);
  EXPECT_GT(photo_agreement(s.body, front, s.cameras.front), 0.95);
  TriangleMesh tall = s.body;
  tall.V.col(1) *= 1.3;
  EXPECT_LT(photo_agreement(tall, front, s.cameras.front), kMinPhotoAgreement);
  PinholeCamera big = s.cameras.front;  // a 12-megapixel camera: rendered at 600 rows, the same answer
  big.width *= 4, big.height *= 4, big.fx *= 4, big.fy *= 4, big.cx *= 4, big.cy *= 4;
  const Silhouette big_front = mask_of(render_mesh(s.body, big));
  EXPECT_NEAR(photo_agreement(s.body, big_front, big), photo_agreement(s.body, front, s.cameras.front), 0.03);
}

// What the photos show bounds what the regression predicts: a crown above the photos' crown comes
// down to it, a hand tip below the lowest point of its arm is drawn back along the hand.
TEST(PhotoLandmarks, PredictedFeaturesStayWithinWhatThePhotosShow) {
  const Scene s = photograph(default_body());
  BodyFeatures f = find_body_features(s.body.V, s.body.F);
  const ArmChains arms = arm_chains(f);
  const PhotoLandmarks L = find_photo_landmarks(mask_of(s.front), mask_of(s.side), s.cameras, &arms);
  f.top_y = f.crown_y = L.crown_y + 0.05;
  const Eigen::Vector3d wrist = f.wrist[kLeft], tip = f.hand_tip[kLeft];
  f.hand_tip[kLeft] = wrist + 1.5 * (tip - wrist);
  std::vector<std::string> notes;
  const BodyFeatures g = within_photos(f, L, &notes);
  EXPECT_DOUBLE_EQ(g.top_y, L.crown_y);
  EXPECT_NEAR(g.hand_tip[kLeft].y(), L.hand_tip[kLeft].y(), 1e-9);
  EXPECT_LT(((g.hand_tip[kLeft] - wrist).normalized() - (tip - wrist).normalized()).norm(), 1e-9) << "along the hand";
  EXPECT_LT((g.hand_tip[kRight] - f.hand_tip[kRight]).norm(), 0.005) << "the true tip is where the photo shows it";
  ASSERT_EQ(notes.size(), 2u);
  EXPECT_NE(notes[0].find("crown predicted 50 mm above"), std::string::npos) << notes[0];
}

// A phone at chest height aimed down at the body: the hands, held in front of the body, show lower
// and farther out than they are when read at the torso's depth; read at the arms' own depth they
// stay where the level camera puts them.
TEST(PhotoLandmarks, ArmsReadAtTheirOwnDepthDoNotMoveWithTheCameraHeight) {
  const Scene level = photograph(default_body());
  const BodyFeatures f = find_body_features(level.body.V, level.body.F);
  const ArmChains arms = arm_chains(f);
  ASSERT_EQ(arms.chain[kLeft].size(), 4u);
  PhotoCameras high = level.cameras;
  for (PinholeCamera* c : {&high.front, &high.side})
    *c = PinholeCamera::look_at({c->centre().x(), f.floor_y + 1.3, c->centre().z()}, {0, 0.5 * (f.floor_y + f.crown_y), 0},
                                Eigen::Vector3d::UnitY(), 800, 1200, 1100);
  const Silhouette front = mask_of(render_mesh(level.body, high.front)), side = mask_of(render_mesh(level.body, high.side));
  const PhotoLandmarks at_level = find_photo_landmarks(mask_of(level.front), mask_of(level.side), level.cameras, &arms);
  const PhotoLandmarks torso_depth = find_photo_landmarks(front, side, high);
  const PhotoLandmarks own_depth = find_photo_landmarks(front, side, high, &arms);
  for (int k : {kLeft, kRight}) {
    EXPECT_LT((own_depth.hand_tip[k] - at_level.hand_tip[k]).norm(), 0.006) << k;
    EXPECT_GT((torso_depth.hand_tip[k] - at_level.hand_tip[k]).norm(), 0.015) << k;
  }
}

// The standard pose's forearms cross in front of the waist in the side photo: the levels where they
// hide the torso's outline are found, and there the measured depth is the torso's, not the arm's.
TEST(PhotoLandmarks, ForearmsInFrontOfTheWaistAreSeenAndLeftOutOfTheDepth) {
  const Scene s = photograph(default_body());
  const Silhouette front = mask_of(s.front), side = mask_of(s.side);
  const PhotoLandmarks L = find_photo_landmarks(front, side, s.cameras);
  ASSERT_EQ(L.side_arm_occlusion.size(), 1u);
  const auto [lo, hi] = L.side_arm_occlusion.front();
  EXPECT_GT(lo, L.crotch_y);
  EXPECT_LT(hi, std::min(L.armpit_y[0], L.armpit_y[1]));
  EXPECT_GT(hi - lo, 0.02);
  // Depth at the hidden levels: without the occlusion the arm adds to it; with it, the torso's
  // depth there lies within the range of the seen levels around.
  const BodyFeatures f = find_body_features(s.body.V, s.body.F);
  const LayeredRepresentation planned = plan_layered_representation(f);
  const auto seen = measure_layers(planned, front, side, s.cameras, f.axis_x, L.side_arm_occlusion);
  const auto raw = measure_layers(planned, front, side, s.cameras, f.axis_x);
  const LayeredRepresentation truth = build_layered_representation(s.body.V, s.body.F, f);
  int hidden = 0;
  for (size_t i = 0; i < planned.layers.size(); ++i) {
    if (planned.layers[i].chain != 0 || planned.layers[i].centre.y() < lo || planned.layers[i].centre.y() > hi) continue;
    ++hidden;
    double zmin = 1e9, zmax = -1e9;
    for (int k = 0; k < truth.points_per_layer; ++k) {
      zmin = std::min(zmin, truth.mesh.V(static_cast<Eigen::Index>(i) * truth.points_per_layer + k, 2));
      zmax = std::max(zmax, truth.mesh.V(static_cast<Eigen::Index>(i) * truth.points_per_layer + k, 2));
    }
    EXPECT_LE(seen[i].half_depth, raw[i].half_depth + 1e-9) << i;
    EXPECT_NEAR(2 * seen[i].half_depth, zmax - zmin, 0.015) << "layer " << i << ": the torso's own depth";
  }
  EXPECT_GT(hidden, 0);
}

TEST(PhotoLandmarks, SwappedPhotosAndMismatchedCamerasAreErrors) {
  const Scene s = photograph(default_body());
  const std::string swapped = error_of([&] { find_photo_landmarks(mask_of(s.side), mask_of(s.front), s.cameras); });
  EXPECT_FALSE(swapped.empty());
  EXPECT_TRUE(swapped.find("side photo given as front") != std::string::npos || swapped.find("swapped") != std::string::npos) << swapped;
  PhotoCameras small = s.cameras;
  small.front.width = 640;
  EXPECT_NE(error_of([&] { find_photo_landmarks(mask_of(s.front), mask_of(s.side), small); }).find("but its camera"), std::string::npos);
}

TEST(PhotoCameras, CameraFilesAreReadAndCheckedAndTheStatureSetsTheScale) {
  test::TempDir dir;
  const Scene s = photograph(default_body());
  const std::string good = dir.file("camera.json");
  std::ofstream(good) << "{\"front\": " << camera_to_json(s.cameras.front) << ", \"side\": " << camera_to_json(s.cameras.side) << "}";
  const PhotoCameras read = read_photo_cameras(good);
  EXPECT_NEAR((read.side.R - s.cameras.side.R).norm(), 0, 1e-9);
  EXPECT_TRUE(read.assumed.empty());
  const std::string bad = dir.file("bad.json");
  std::ofstream(bad) << "{\"front\": " << camera_to_json(s.cameras.front) << "}";
  EXPECT_NE(error_of([&] { read_photo_cameras(bad); }).find("\"side\": missing"), std::string::npos);
  // Without a camera file the stated stature fixes the scale: the photos measure it back.
  const BodyFeatures f = find_body_features(s.body.V, s.body.F);
  const Silhouette front = mask_of(s.front), side = mask_of(s.side);
  const PhotoCameras assumed = cameras_from_stature(front, side, f.stature, 3.0);
  EXPECT_FALSE(assumed.assumed.empty());
  EXPECT_NEAR(find_photo_landmarks(front, side, assumed).stature, f.stature, 0.015);
}

// The population and its cameras are the caller's: given bodies photographed by phone cameras (held
// 1.0-1.5 m above the soles, 2.2-2.5 m away) train a model that records both, and the photos' 2-D
// features it learned from differ from those of the dataset's level cameras.
TEST(PhotoCustomization, TrainsOnGivenBodiesWithPhoneCameras) {
  CustomizationTrainingOptions o;
  o.data_root = test::test_data_root();
  o.mlp = false;
  o.specs = make_calibration_specs(7, 24);
  o.specs_note = "24 given bodies";
  o.cameras = CustomizationTrainingOptions::Cameras::kPhone;
  const CustomizationModel phone = train_customization_model(o);
  EXPECT_GE(phone.bodies, 20);
  EXPECT_NE(phone.population.find("24 given bodies (24)"), std::string::npos) << phone.population;
  EXPECT_NE(phone.population.find("phone cameras"), std::string::npos) << phone.population;
  o.cameras = CustomizationTrainingOptions::Cameras::kDataset;
  const CustomizationModel level = train_customization_model(o);
  EXPECT_EQ(level.population.find("phone cameras"), std::string::npos);
  ASSERT_EQ(level.descriptor_mean.size(), phone.descriptor_mean.size());
  // Seen from 1.0-1.5 m high instead of the mid-height, the same bodies' features move.
  EXPECT_GT((level.descriptor_mean - phone.descriptor_mean).cwiseQuotient(level.descriptor_scale).cwiseAbs().maxCoeff(), 0.5);
}

// A small population (linear models) customizes the small dataset's subjects from their photos:
// girths within 3 cm and the surface within 8 mm; the model file round-trips.
TEST(PhotoCustomization, ASmallPopulationCustomizesTheSubjectsFromTheirPhotos) {
  const auto& ds = test::small_dataset();
  ASSERT_FALSE(ds.root.empty());
  CustomizationTrainingOptions o;
  o.data_root = test::test_data_root();
  o.bodies = 40;
  o.mlp = false;
  const CustomizationModel model = train_customization_model(o);
  EXPECT_GE(model.bodies, 25);
  // A body far from the population's 2-D features is flagged; the population's own mean is not.
  ASSERT_GT(model.descriptor_limit, 0);
  PhotoLandmarks far;
  far.descriptor = model.descriptor_mean;
  EXPECT_LT(population_distance(model, far), model.descriptor_limit);
  EXPECT_EQ(population_range_excess(model, far), 0);
  // A whole range beyond the population's along its first axis (a body fatter than any trained on).
  PhotoLandmarks big = far;
  const double beyond = 2 * model.axis_high[0] - model.axis_low[0];
  big.descriptor += (beyond * model.descriptor_axes.col(0)).cwiseProduct(model.descriptor_scale);
  int axis = -1;
  EXPECT_GT(population_range_excess(model, big, &axis), 0.5);
  EXPECT_EQ(axis, 0);
  for (Eigen::Index k = 0; k < far.descriptor.size(); ++k) far.descriptor[k] += (k % 2 ? -4 : 4) * model.descriptor_scale[k];
  EXPECT_GT(population_distance(model, far), model.descriptor_limit);
  const PhotoEvaluation ev = evaluate_photo_customization(ds.root, model, PhotoVariation::kPhotos);
  ASSERT_FALSE(ev.subjects.empty());
  for (const auto& r : ev.subjects) {
    ASSERT_TRUE(r.ok && r.girths_measured) << r.id << ": " << r.error;
    EXPECT_LT(std::abs(r.stature_mm), 15) << r.id;
    for (double g : {r.bust_mm, r.waist_mm, r.hip_mm}) EXPECT_LT(std::abs(g), 30) << r.id;
    EXPECT_LT(r.surface_mm, 8) << r.id;
  }
  test::TempDir dir;
  save_customization_model(dir.file("m.pkc"), model);
  const CustomizationModel loaded = load_customization_model(dir.file("m.pkc"));
  const PhotoEvaluation again = evaluate_photo_customization(ds.root, loaded, PhotoVariation::kMasks);
  const PhotoEvaluation first = evaluate_photo_customization(ds.root, model, PhotoVariation::kMasks);
  for (size_t k = 0; k < first.subjects.size(); ++k) EXPECT_NEAR(again.subjects[k].bust_mm, first.subjects[k].bust_mm, 1e-6);
  std::ofstream(dir.file("not.pkc")) << "{\"format\": \"something else\"}";
  EXPECT_NE(error_of([&] { load_customization_model(dir.file("not.pkc")); }).find("not a posekit customization model"), std::string::npos);
}
