#pragma once
// Shape customization from two orthogonal photos (section 3.2 of Zhu & Mok): 2-D body features on
// the front and side silhouettes, the feature-aligned layered representation placed by them, each
// layer's cross-section predicted from the silhouettes' widths and depths by models learned from a
// MakeHuman population, and the template deformed to the result by ct-FFD.
#include <Eigen/Core>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "posekit/body/body_spec.h"
#include "posekit/core/triangle_mesh.h"
#include "posekit/customization/silhouette.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

/// 2-D features found by rules on the two silhouettes, in world metres (Y up, facing +Z).
struct PhotoLandmarks {
  double floor_y = 0, crown_y = 0, stature = 0;
  double axis_x = 0, axis_z = 0;              ///< the torso's centre line (front: x, side: z at mid-torso)
  double crotch_y = 0, neck_y = 0;            ///< top of the gap between the legs; narrowest above the shoulders
  double armpit_y[2] = {0, 0};                ///< top of the gap between the arm and the torso (kLeft, kRight)
  double hip_y = 0, waist_y = 0, bust_y = 0;  ///< extremes of the elliptic girth of width and depth
  Eigen::Vector2d hand_tip[2];                ///< x, y of the lowest point of each arm
  /// World heights (low, high) where a forearm held in front of the body hides the torso's front
  /// outline in the side photo.
  std::vector<std::pair<double, double>> side_arm_occlusion;
  double front_to_side_ratio = 0;  ///< front width over side depth at the hip (a pelvis is wider
                                   ///< than deep: below 0.95, the photos are swapped)
  /// Everything above and the torso, leg and arm profiles, relative to the floor and the axis: the
  /// input of the learned feature regression.
  Eigen::VectorXd descriptor;
  std::vector<std::string> warnings;
};

/// Where each arm lies in space (shoulder, elbow, wrist, hand tip; world), so that the arm's outline
/// in the front photo is read at the arm's own distance from the camera: the standard pose holds the
/// hands in front of the body, and a camera above or below them sees them displaced in height by
/// (camera height - arm height) x (depth difference / distance).
struct ArmChains {
  std::vector<Eigen::Vector3d> chain[2];  ///< kLeft, kRight
};
ArmChains arm_chains(const BodyFeatures& features);

/// Finds the 2-D features. `arms`: read the arms at these depths (else at the torso's depth).
/// Throws InvalidInput naming the photo and the feature that cannot be found (no gap between the
/// legs, arms touching the torso, a side view given as front).
PhotoLandmarks find_photo_landmarks(const Silhouette& front, const Silhouette& side, const PhotoCameras& cameras,
                                    const ArmChains* arms = nullptr);

/// Half extents of a layer's section seen in the photos: along the layer's side axis in the front
/// photo, along its front axis in the side photo (arms: not seen, -1), and the box centre.
struct LayerExtent {
  double half_width = 0, half_depth = -1;
  Eigen::Vector3d box_centre = Eigen::Vector3d::Zero();
};
/// Measures every layer of a planned representation (plan_layered_representation) on the photos,
/// walking out from each layer's centre along its plane until the silhouette ends (a leg's walk
/// stops at the legs' middle). A torso layer in `side_occlusion` (PhotoLandmarks) takes its front
/// edge from the nearest seen layers below and above. Throws InvalidInput naming a layer the photos
/// do not show.
std::vector<LayerExtent> measure_layers(const LayeredRepresentation& planned, const Silhouette& front, const Silhouette& side,
                                        const PhotoCameras& cameras, double legs_middle_x,
                                        const std::vector<std::pair<double, double>>& side_occlusion = {});

/// The learned part: features from landmarks (ridge regression) and, per layer, the section's 32
/// points and centroid from its extents and its neighbours' (a linear model or an MLP, whichever
/// predicted the validation bodies better).
struct CustomizationModel {
  int points_per_layer = 32;
  Eigen::MatrixXd feature_weights;  ///< (#descriptor + 1) x #feature targets
  struct Layer {
    bool use_mlp = false;
    Eigen::MatrixXd linear;  ///< (#inputs + 1) x #outputs, on standardised values
    std::string mlp;         ///< OpenCV ANN_MLP, serialised
    Eigen::VectorXd in_mean, in_scale, out_mean, out_scale;
    double linear_error_mm = 0, mlp_error_mm = 0;  ///< mean point error on the validation bodies
  };
  std::vector<Layer> layers;
  TriangleMesh template_mesh;  ///< the body deformed by ct-FFD (MakeHuman's default)
  // How it was made.
  int bodies = 0, validation_bodies = 0;
  unsigned seed = 0;
  double training_seconds = 0;
  std::string population;       ///< what the population was (and what was left out)
  double feature_error_mm = 0;  ///< mean joint error of the feature regression (validation)
  /// The training population's 2-D features: mean and spread of each, and the inverse of their
  /// correlation (plus 0.01 on the diagonal); descriptor_limit: the distance (population_distance)
  /// 99.5% of the validation bodies stay under. descriptor_axes: the correlation's 10 principal
  /// axes (columns), with the training bodies' range along each (axis_low, axis_high).
  Eigen::VectorXd descriptor_mean, descriptor_scale;
  Eigen::MatrixXd descriptor_precision;
  double descriptor_limit = 0;
  Eigen::MatrixXd descriptor_axes;
  Eigen::VectorXd axis_low, axis_high;
  /// Loaded state (template features, representation and parametrisation; MLPs): set by
  /// prepare_customization_model, which load and train call.
  struct Runtime;
  std::shared_ptr<const Runtime> runtime;
};

struct CustomizationTrainingOptions {
  std::string data_root;     ///< MakeHuman data root
  int bodies = 2000;         ///< training population (make_calibration_specs)
  unsigned seed = 20261124;  ///< the population's seed (the dataset's subjects use another)
  double validation_fraction = 0.2;
  bool mlp = true;  ///< also train the MLPs (else linear only)
  int mlp_hidden = 20, mlp_iterations = 300;
  int threads = 2;
  /// Each body is turned about the vertical by a uniform angle within +-max_turn_degrees before it
  /// is rendered (people do not stand exactly square to the camera; symmetric bodies only would tie
  /// each arm's prediction to the mean of both arms' readings).
  double max_turn_degrees = 0;
  /// The cameras the population is photographed with. kDataset: the dataset's (800 x 1200 px,
  /// f 1400 px, level at the body's mid-height within 5 cm, 2.6-3.4 m away). kPhone: a phone held
  /// by someone standing (900 x 1200 px, f 840-960 px: a 3000 x 4000 photo's 2800-3200 px at the
  /// rows the silhouettes are worked at; 2.2-2.5 m away, 1.0-1.5 m above the soles, aimed at the
  /// body's mid-height).
  enum class Cameras { kDataset, kPhone } cameras = Cameras::kDataset;
  /// The population's bodies; empty: make_calibration_specs(seed, bodies). `specs_note` says in the
  /// model file what they are (e.g. MakeHuman fitted to surveyed adults).
  std::vector<BodySpec> specs;
  std::string specs_note;
  /// Leaves bodies out of the population: return false to leave one out (e.g. the heaviest).
  std::function<bool(int index, double bmi, double gender)> keep;
  std::string population_note;  ///< recorded in the model (what `keep` does)
  std::function<void(int done, int total, const std::string& what)> progress;
};

/// The body features (joints and levels) the model predicts from the photos' 2-D features.
BodyFeatures predict_body_features(const CustomizationModel& model, const PhotoLandmarks& landmarks);

/// The predicted features kept within what the photos show (section 3.2's levels are read off the
/// photos where they speak): a crown above the photos' crown is moved down to it, a hand tip below
/// the lowest point of its arm seen in the front photo is drawn back along the hand to that level.
/// Each change over 1 cm is noted in `notes` (may be null).
BodyFeatures within_photos(BodyFeatures features, const PhotoLandmarks& landmarks, std::vector<std::string>* notes);

/// Renders the population's front and side silhouettes with the dataset's camera model (distance
/// 2.6-3.4 m, level, f = 1400 px, 800 x 1200) and fits the models.
CustomizationModel train_customization_model(const CustomizationTrainingOptions& options);
/// Writes / reads a model file (.pkc, JSON; written atomically). Throws IoError / InvalidInput.
void save_customization_model(const std::string& path, const CustomizationModel& model);
CustomizationModel load_customization_model(const std::string& path);
/// Builds the runtime state (template features, representation and ct-FFD parametrisation, MLPs).
void prepare_customization_model(CustomizationModel* model);

/// Mahalanobis distance of a body's 2-D features from the model's training population (each
/// standardised; regularised). Beyond model.descriptor_limit the body is unlike any the model
/// learned from, and its sections are extrapolated. 0 when the model has no population statistics.
double population_distance(const CustomizationModel& model, const PhotoLandmarks& landmarks);
/// How far a body lies beyond the training bodies' range along the population's first 4 principal axes:
/// the largest excess over the range, in units of that range (0: inside on every axis). A body
/// fatter or taller than any trained on is inside the Mahalanobis limit (the population is spread
/// evenly, not normally) but beyond the range of its first axes.
double population_range_excess(const CustomizationModel& model, const PhotoLandmarks& landmarks, int* axis = nullptr);

struct CustomizedBody {
  TriangleMesh mesh;                     ///< the template deformed by ct-FFD, template topology
  LayeredRepresentation representation;  ///< predicted from the photos
  BodyFeatures features;                 ///< predicted from the 2-D features
  PhotoLandmarks landmarks;
  double scale = 1;                                        ///< applied to meet a stated stature, about scale_origin
  Eigen::Vector3d scale_origin = Eigen::Vector3d::Zero();  ///< on the soles, below the body's axis
  double population_distance = 0;                          ///< of the photos' body from the training population
  double population_range_excess = 0;                      ///< beyond the population's range (population_range_excess)
  /// The result seen by the two cameras against the silhouettes: intersection over union, the lower
  /// view (photo_agreement).
  double photo_agreement = 0;
  std::vector<std::string> warnings;
};

/// Intersection over union of a mesh's projection by `camera` (rendered at most 600 rows high) with
/// the silhouette, sampled at the rendering's pixel centres.
double photo_agreement(const TriangleMesh& mesh, const Silhouette& silhouette, const PinholeCamera& camera);

/// The lowest photo_agreement a result may have. Good results on the dataset's 16 subjects under
/// every photo variation of `customize eval` score 0.90-0.97 (the 600-row rendering loses fingers);
/// the wrecks seen score under 0.1. 0.8 is an outline about 4% of the body's height off all round.
constexpr double kMinPhotoAgreement = 0.8;

/// Customizes the template to the person in the two silhouettes. stated_stature > 0: the result is
/// scaled about the soles to it, and a camera file that disagrees with it by over 2 cm is a warning.
/// A result that does not look like the photos (photo_agreement under kMinPhotoAgreement) throws
/// BelowConfidence naming the agreement, unless accept_poor (then it is returned with a warning).
CustomizedBody customize_from_silhouettes(const Silhouette& front, const Silhouette& side, const PhotoCameras& cameras,
                                          const CustomizationModel& model, double stated_stature = 0, bool accept_poor = false);

/// Debug image: the silhouette, the 2-D feature levels (crotch, hip, waist, bust, armpits, neck,
/// soles, crown) and the predicted representation's points projected into that view (PNG).
void write_photo_features_png(const std::string& path, const Silhouette& silhouette, const PinholeCamera& camera,
                              const CustomizedBody& body);

/// Girth (m) of the representation's section nearest a level of its torso: the convex-hull
/// perimeter, as a tape would measure.
double representation_torso_girth(const LayeredRepresentation& rep, double y);

}  // namespace posekit
