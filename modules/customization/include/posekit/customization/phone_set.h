#pragma once
// A robustness set that imitates phone photos of real people (issue 46, part 7): bodies of ANSUR II
// proportions (MakeHuman fitted to surveyed adults, with the survey's extremes), 3000 x 4000 photos
// from 2.2-2.5 m with the camera 1.0-1.5 m high, a floor and a lit wall, lens blur, noise and JPEG,
// turns of up to 5 degrees; rendered by a renderer written apart from the dataset's (supersampled
// coverage, two lights and colour), so that a method does not learn one renderer's outline.
#include <functional>
#include <string>
#include <vector>

#include "posekit/customization/photo_evaluation.h"
#include "posekit/io/image_io.h"

namespace posekit {

struct PhoneSetBody {
  std::string id;         ///< "ansur-<SubjectId>", "extreme-<what>-<SubjectId>" or the dataset's id
  std::string kind;       ///< "ansur", "extreme" or "dataset"
  std::string survey_id;  ///< the survey's SubjectId (empty for a dataset's body)
  TriangleMesh mesh;      ///< at rest (A-pose), metres, Y up, facing +Z
  double bmi = 0;         ///< from the survey's weight and stature (0: not known)
  bool male = false;
};

struct PhoneSetOptions {
  std::string data_root;  ///< MakeHuman data root
  std::string survey;     ///< ANSUR II's folder (or a survey CSV)
  int ansur_bodies = 12;  ///< surveyed adults drawn at random, women and men alternately
  /// The survey's extremes added: the heaviest woman and man by BMI, the tallest man, the shortest
  /// woman (each fitted as the others).
  bool extremes = true;
  std::string dataset_dir;  ///< also the subjects of this dataset (older MakeHuman bodies); empty: none
  unsigned seed = 46;
};
/// The set's bodies. Throws IoError / InvalidInput naming a missing survey or dataset.
std::vector<PhoneSetBody> make_phone_set_bodies(const PhoneSetOptions& options);

/// How a body's photos are taken. Every condition draws the same cameras for a body (distance
/// 2.2-2.5 m, 1.0-1.5 m above the soles, aimed at the body's middle, f 2800-3200 px, 3000 x 4000).
enum class PhoneCondition {
  kMasks,   ///< the true silhouettes (the renderer's coverage over half), exact camera file
  kRoom,    ///< photos: the floor in view, a wall 1.0-1.6 m behind lit from one side, skin of several tones
  kPhone,   ///< ... with lens blur (0.6 px), noise (sigma 2) and JPEG quality 70
  kTurned,  ///< ... and the body turned by up to 5 degrees either way about the vertical
};
const std::vector<PhoneCondition>& all_phone_conditions();
const char* phone_condition_name(PhoneCondition c);
PhoneCondition parse_phone_condition(const std::string& name);

/// The set's renderer: each pixel's 4 x 4 subsamples tested against every triangle (depth per
/// subsample, perspective-correct), the body shaded by smooth normals under a key light, a fill light
/// and ambient light in `skin_bgr`, and the room (a floor at floor_y, a wall `wall_behind` metres
/// behind the body's axis, lit from one side) where the body does not cover a subsample. `coverage`
/// (may be null): each pixel's share of covered subsamples.
Image8 render_phone_photo(const TriangleMesh& mesh, const PinholeCamera& camera, double floor_y, double wall_behind,
                          const Eigen::Vector3d& skin_bgr, std::vector<float>* coverage = nullptr);

/// A way to customize from two silhouettes (the paper's method, the body model's fit).
using PhotoCustomizer = std::function<CustomizedBody(const Silhouette& front, const Silhouette& side, const PhotoCameras& cameras)>;

/// Every body photographed under `condition` and customized by each method (the same photos for all
/// methods), scored against the body's own mesh: stature and girths as measure_body takes them on
/// it, the surface distance. One evaluation per method, labelled "<condition>". `progress(done,
/// total)` when given. `inputs_out` (non-empty): each body's photos (JPEG) or masks and camera file
/// are written to inputs_out/<condition>/<id>/, to rerun one with `posekit customize`.
std::vector<PhotoEvaluation> evaluate_phone_set(const std::vector<PhoneSetBody>& bodies, PhoneCondition condition,
                                                const std::vector<PhotoCustomizer>& methods, unsigned seed = 46,
                                                const std::function<void(int, int)>& progress = nullptr,
                                                const std::string& inputs_out = "");

}  // namespace posekit
