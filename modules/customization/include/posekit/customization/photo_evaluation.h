#pragma once
// Photo customization against the dataset's ground truth: per subject, girth and stature errors
// and the distance to the subject's own mesh, on the photos as given or degraded (robustness).
#include <string>
#include <vector>

#include "posekit/customization/model_silhouette_fit.h"
#include "posekit/customization/photo_customization.h"

namespace posekit {

/// How the photos are given or degraded before customization.
enum class PhotoVariation {
  kPhotos,          ///< the photos, silhouettes extracted, with the camera file
  kMasks,           ///< the dataset's ground-truth masks, with the camera file
  kErode2,          ///< masks eroded by 2 px
  kDilate2,         ///< masks dilated by 2 px
  kHeightPlus1cm,   ///< no camera file: the stated height 1 cm over the truth (3 m, focal from it)
  kNearer20cm,      ///< no camera file: the true height, the camera assumed 20 cm nearer than it was
  kFarther20cm,     ///< ... 20 cm farther
  kTurned5deg,      ///< the body turned 5 degrees about the vertical (re-rendered), camera file
  kJpegNoise,       ///< photos with sensor noise (sigma 4 grey levels) and JPEG quality 60
  kCamera130Level,  ///< masks re-rendered with both cameras 1.30 m above the soles, level, f = 1100 px (a phone at chest height)
  kCamera130Aimed,  ///< ... 1.30 m above the soles, aimed at the body's mid-height (pitched down)
  kCamera100Level,  ///< ... 1.00 m above the soles, level
  kRoom,            ///< photos re-rendered in a room: the floor in view (the feet on it), a wall 1.2 m
                    ///< behind lit from one side (+-10% across the frame) and darker upwards; silhouettes extracted
  kPhone,           ///< a phone's photos: 3000 x 4000 px, f = 3000 px, 2.3 m away, 1.30 m high aimed at mid-height,
                    ///< in the room of kRoom, lens blur (sigma 0.6 px), noise (sigma 2) and JPEG quality 70;
                    ///< `seconds` is the silhouettes' extraction and the customization (not the rendering)
  kPhoneMasks,      ///< kPhone's cameras with the true silhouettes (no extraction): the geometry alone
};
const std::vector<PhotoVariation>& all_photo_variations();
const char* photo_variation_name(PhotoVariation v);
/// Parses a name (photos, masks, erode2, dilate2, height+1cm, nearer20cm, farther20cm, turned5,
/// jpeg-noise, camera1.30, camera1.30-aimed, camera1.00, room, phone, phone-masks); throws InvalidInput listing them.
PhotoVariation parse_photo_variation(const std::string& name);

struct PhotoSubjectResult {
  std::string id;
  bool ok = false;
  std::string error;                                             ///< why it failed (or, when ok, why a girth was not measured)
  double stature_mm = 0, bust_mm = 0, waist_mm = 0, hip_mm = 0;  ///< signed errors (customized - truth)
  bool girths_measured = false;                                  ///< bust, waist and hip measured on the result (else the errors are 0)
  double surface_mm = 0;                                         ///< mean distance of the subject's vertices to the result
  double seconds = 0;                                            ///< silhouettes to mesh
  double silhouette_iou = 1;                                     ///< of the silhouettes used against the true masks (the lower view)
  double photo_agreement = 0;                                    ///< of the result against the silhouettes used (CustomizedBody)
  std::vector<std::string> warnings;
};

struct PhotoEvaluation {
  PhotoVariation variation = PhotoVariation::kPhotos;
  std::string label;  ///< what was evaluated when not a dataset variation (the phone set's condition)
  std::vector<PhotoSubjectResult> subjects;
  int failed = 0;               ///< not customized (the reason in each subject's error)
  int girths_not_measured = 0;  ///< customized, but `measure` declined bust, waist or hip
  /// Girth means over the subjects with girths measured; stature and surface over all customized.
  double mean_abs_bust_mm = 0, mean_abs_waist_mm = 0, mean_abs_hip_mm = 0, mean_abs_stature_mm = 0, mean_surface_mm = 0;
  double worst_girth_mm = 0;  ///< largest |bust|, |waist|, |hip| error
  int within_2cm = 0;         ///< subjects with bust, waist and hip within 2 cm
};

/// Customizes every subject of a dataset (its manifest) from its photos under `variation`.
/// `ids`: only these subjects (empty: all). `inputs_out` (non-empty): each subject's silhouettes and
/// camera file as customized are written to inputs_out/<variation>/<id>/ (front_mask.png,
/// side_mask.png, camera.json), so that a failure can be rerun with `posekit customize --debug`.
/// `body_model` (non-null): customized by the body model's fit to the silhouettes (customize_by_body_model)
/// instead of the paper's method; `model` is then unused.
PhotoEvaluation evaluate_photo_customization(const std::string& dataset_dir, const CustomizationModel& model, PhotoVariation variation,
                                             const std::vector<std::string>& ids = {}, const std::string& inputs_out = "",
                                             const BodyModel* body_model = nullptr);

}  // namespace posekit
