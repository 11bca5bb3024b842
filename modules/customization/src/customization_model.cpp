#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <sstream>

#include "customization_detail.h"
#include "opencv_calls.h"
#include "posekit/body/makehuman_model.h"
#include "posekit/body/subjects.h"
#include "posekit/core/error.h"
#include "posekit/core/parallel.h"
#include "posekit/core/plugin.h"
#include "posekit/core/timer.h"
#include "posekit/customization/photo_customization.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/image_io.h"
#include "posekit/registration/ctffd.h"
#include "posekit/version.h"

namespace posekit {

struct CustomizationModel::Runtime {
  BodyFeatures template_features;
  LayeredRepresentation template_rep;
  CtffdParametrization param;
  std::vector<opencv_calls::Mlp> mlps;
};

namespace {

constexpr int kLayerInputs = 12;
constexpr double kRangeMargin = 0.02;  // beyond the population's range by 2% of it: extrapolated
// The range is checked along the first 4 principal axes, the largest variations: along
// the minor ones 1600 bodies do not fill the range (f03 lies 19% beyond axis 8 and is customized
// within 16 mm).
constexpr int kRangeAxes = 4;
constexpr int kFeatureScalars = 10, kFeaturePoints = 19;
constexpr int kFeatureTargets = kFeatureScalars + 3 * kFeaturePoints;
constexpr int kFirstArmPoint = 3, kLastArmPoint = 12;  // feature_points: armpits, shoulders, elbows, wrists, hand tips

std::vector<Eigen::Vector3d*> feature_points(BodyFeatures& f) {
  return {&f.crotch,   &f.neck_base, &f.neck_top, &f.armpit[0], &f.armpit[1],   &f.shoulder[0], &f.shoulder[1],
          &f.elbow[0], &f.elbow[1],  &f.wrist[0], &f.wrist[1],  &f.hand_tip[0], &f.hand_tip[1], &f.knee[0],
          &f.knee[1],  &f.ankle[0],  &f.ankle[1], &f.hip[0],    &f.hip[1]};
}

/// The features a layered representation is placed by, relative to the photos' floor and axis.
Eigen::VectorXd feature_targets(BodyFeatures f, const PhotoLandmarks& L) {
  Eigen::VectorXd t(kFeatureTargets);
  int k = 0;
  for (double y : {f.top_y, f.crotch_y, f.hip_y, f.waist_y, f.underbust_y, f.bust_y, f.arms_separate_y}) t[k++] = y - L.floor_y;
  t[k++] = f.axis_x - L.axis_x;
  t[k++] = f.crotch_axis_z - L.axis_z;
  t[k++] = f.floor_y - L.floor_y;  // the soles below the photos' lowest rows (a toe tip's height, for one)
  const auto pts = feature_points(f);
  for (Eigen::Vector3d* p : pts) {
    t[k++] = p->x() - L.axis_x;
    t[k++] = p->y() - L.floor_y;
    t[k++] = p->z() - L.axis_z;
  }
  return t;
}

BodyFeatures features_from_targets(const Eigen::VectorXd& t, const PhotoLandmarks& L) {
  BodyFeatures f;
  int k = 0;
  for (double* y : {&f.top_y, &f.crotch_y, &f.hip_y, &f.waist_y, &f.underbust_y, &f.bust_y, &f.arms_separate_y}) *y = t[k++] + L.floor_y;
  f.axis_x = t[k++] + L.axis_x;
  f.crotch_axis_z = t[k++] + L.axis_z;
  f.floor_y = t[k++] + L.floor_y;
  const auto pts = feature_points(f);
  for (Eigen::Vector3d* p : pts) {
    p->x() = t[k++] + L.axis_x;
    p->y() = t[k++] + L.floor_y;
    p->z() = t[k++] + L.axis_z;
  }
  f.crown_y = f.top_y;
  f.stature = f.crown_y - f.floor_y;
  f.neck_joint = f.neck_base;
  f.head_joint = f.neck_top;
  return f;
}

Eigen::VectorXd with_bias(const Eigen::VectorXd& x) {
  Eigen::VectorXd b(x.size() + 1);
  b << x, 1.0;
  return b;
}

/// Ridge regression Y ~ [X 1] W on standardised columns, returned in original units.
Eigen::MatrixXd ridge(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, double lambda) {
  const Eigen::RowVectorXd mean = X.colwise().mean();
  Eigen::RowVectorXd scale = ((X.rowwise() - mean).array().square().colwise().mean()).sqrt();
  for (Eigen::Index c = 0; c < scale.size(); ++c)
    if (scale[c] < 1e-9) scale[c] = 1;
  Eigen::MatrixXd Z(X.rows(), X.cols() + 1);
  Z.leftCols(X.cols()) = (X.rowwise() - mean).array().rowwise() / scale.array();
  Z.col(X.cols()).setOnes();
  Eigen::MatrixXd A = Z.transpose() * Z;
  A.diagonal().head(X.cols()).array() += lambda * X.rows();
  const Eigen::MatrixXd Ws = A.ldlt().solve(Z.transpose() * Y);
  // Back to original units: y = ((x - mean) / scale) Ws_top + Ws_bias.
  Eigen::MatrixXd W(X.cols() + 1, Y.cols());
  W.topRows(X.cols()) = Ws.topRows(X.cols()).array().colwise() / scale.transpose().array();
  W.row(X.cols()) = Ws.row(X.cols()) - mean * W.topRows(X.cols());
  return W;
}

/// A layer's inputs: its half width and depth and those of two chain neighbours on each side,
/// relative, and the stature.
Eigen::VectorXd layer_inputs(const LayeredRepresentation& rep, const std::vector<LayerExtent>& e, size_t i, double stature) {
  auto hd = [&](size_t k) { return e[k].half_depth > 0 ? e[k].half_depth : e[k].half_width; };
  auto along = [&](size_t k, int step) {  // k moved by step within its chain (clamped)
    for (int s = 0; s < std::abs(step); ++s) {
      const size_t n = step < 0 ? (k > 0 ? k - 1 : k) : k + 1;
      if (n >= rep.layers.size() || rep.layers[n].chain != rep.layers[k].chain) break;
      k = n;
    }
    return k;
  };
  const double w = std::max(e[i].half_width, 1e-3), d = std::max(hd(i), 1e-3);
  Eigen::VectorXd x(kLayerInputs);
  int k = 0;
  x[k++] = w / stature, x[k++] = d / stature, x[k++] = d / w, x[k++] = stature;
  for (int step : {-2, -1, 1, 2}) {
    const size_t n = along(i, step);
    x[k++] = e[n].half_width / w;
    x[k++] = hd(n) / d;
  }
  return x;
}

/// A layer's section as outputs: its points and centroid relative to the box centre, along the
/// layer's front axis in half depths and along its side axis in half widths.
Eigen::VectorXd layer_outputs(const LayeredRepresentation& rep, size_t i, const LayerExtent& e) {
  const int n = rep.points_per_layer;
  const RepresentationLayer& L = rep.layers[i];
  const double w = std::max(e.half_width, 1e-3), d = e.half_depth > 0 ? e.half_depth : w;
  Eigen::VectorXd y(2 * n + 2);
  for (int k = 0; k <= n; ++k) {
    const Eigen::Vector3d p = k < n ? Eigen::Vector3d(rep.mesh.V.row(static_cast<Eigen::Index>(i) * n + k).transpose()) : L.centre;
    y[2 * k] = (p - e.box_centre).dot(L.front) / d;
    y[2 * k + 1] = (p - e.box_centre).dot(L.side) / w;
  }
  return y;
}

/// Fills layer i of a planned representation from outputs (inverse of layer_outputs).
void apply_layer_outputs(LayeredRepresentation* rep, size_t i, const LayerExtent& e, const Eigen::VectorXd& y) {
  const int n = rep->points_per_layer;
  RepresentationLayer& L = rep->layers[i];
  const double w = std::max(e.half_width, 1e-3), d = e.half_depth > 0 ? e.half_depth : w;
  for (int k = 0; k <= n; ++k) {
    const Eigen::Vector3d p = e.box_centre + y[2 * k] * d * L.front + y[2 * k + 1] * w * L.side;
    if (k < n) rep->mesh.V.row(static_cast<Eigen::Index>(i) * n + k) = p.transpose();
    else L.centre = p;
  }
}

double point_error_mm(const Eigen::VectorXd& a, const Eigen::VectorXd& b, double w, double d, int n) {
  double sum = 0;
  for (int k = 0; k < n; ++k) sum += std::hypot((a[2 * k] - b[2 * k]) * d, (a[2 * k + 1] - b[2 * k + 1]) * w);
  return 1000 * sum / n;
}

Eigen::VectorXd predict_layer(const CustomizationModel& model, size_t i, const Eigen::VectorXd& x) {
  const CustomizationModel::Layer& L = model.layers[i];
  const Eigen::VectorXd z = (x - L.in_mean).cwiseQuotient(L.in_scale);
  if (L.use_mlp && model.runtime && i < model.runtime->mlps.size() && model.runtime->mlps[i]) {
    const Eigen::VectorXd y = opencv_calls::predict_mlp(model.runtime->mlps[i], z);
    return L.out_mean + y.cwiseProduct(L.out_scale);
  }
  const Eigen::VectorXd y = L.linear.transpose() * with_bias(z);
  return L.out_mean + y.cwiseProduct(L.out_scale);
}

struct Sample {
  bool ok = false;
  std::string why;
  double bmi = 0, gender = 0;
  PhotoLandmarks landmarks;
  Eigen::VectorXd targets;
  PhotoCameras cameras;
  double turn = 0;  // radians about the vertical
  std::vector<std::uint8_t> front_png, side_png;
  std::vector<Eigen::VectorXd> inputs, outputs;  // per layer
  std::vector<double> w, d;                      // per layer half extents (m), for errors
};

/// The mesh turned by `angle` (radians) about the vertical through its centroid.
TriangleMesh turned_about_vertical(TriangleMesh mesh, double angle) {
  if (angle == 0) return mesh;
  const Eigen::RowVector3d c = mesh.V.colwise().mean();
  const Eigen::Matrix3d R = Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitY()).toRotationMatrix();
  mesh.V = ((mesh.V.rowwise() - c) * R.transpose()).rowwise() + c;
  return mesh;
}

std::vector<std::uint8_t> encode(const std::vector<std::uint8_t>& mask, int w, int h) { return encode_png(Image8{w, h, 1, mask}); }

Silhouette decode(const std::vector<std::uint8_t>& png) {
  Image8 m = decode_image(std::string(png.begin(), png.end()), ImageColor::kGray, "a customization model's silhouette");
  Silhouette s;
  s.width = m.width, s.height = m.height;
  s.mask = std::move(m.pixels);
  return s;
}

}  // namespace

BodyFeatures predict_body_features(const CustomizationModel& model, const PhotoLandmarks& L) {
  if (model.feature_weights.rows() != L.descriptor.size() + 1)
    throw InvalidInput("customization model: made for another feature descriptor (" + std::to_string(model.feature_weights.rows() - 1) +
                       " values, the photos give " + std::to_string(L.descriptor.size()) + ")");
  return features_from_targets(model.feature_weights.transpose() * with_bias(L.descriptor), L);
}

double photo_agreement(const TriangleMesh& mesh, const Silhouette& silhouette, const PinholeCamera& camera) {
  const int k = std::max(1, (camera.height + 599) / 600);
  PinholeCamera small = camera;
  small.width = camera.width / k, small.height = camera.height / k;
  small.fx /= k, small.fy /= k, small.cx /= k, small.cy /= k;
  const RenderBuffers r = render_mesh(mesh, small);
  long both = 0, either = 0;
  for (int v = 0; v < small.height; ++v)
    for (int u = 0; u < small.width; ++u) {
      const bool seen = silhouette.inside(u * k + k / 2, v * k + k / 2), made = r.face[static_cast<size_t>(v) * small.width + u] >= 0;
      both += seen && made, either += seen || made;
    }
  return either ? static_cast<double>(both) / either : 0;
}

BodyFeatures within_photos(BodyFeatures f, const PhotoLandmarks& L, std::vector<std::string>* notes) {
  auto mm = [](double m) { return std::to_string(static_cast<int>(std::lround(1000 * m))); };
  // Said only past a centimetre: the representation's end layers sit 1 cm inside the crown and the
  // hand tips, so a smaller correction changes nothing the photos can show.
  constexpr double kSaid = 0.01;
  if (f.top_y > L.crown_y) {
    if (notes && f.top_y - L.crown_y > kSaid)
      notes->push_back("photos: the crown predicted " + mm(f.top_y - L.crown_y) + " mm above the photos' crown: taken from the photos");
    f.top_y = f.crown_y = L.crown_y;
    f.stature = f.crown_y - f.floor_y;
  }
  for (int side : {kLeft, kRight}) {
    Eigen::Vector3d& tip = f.hand_tip[side];
    const Eigen::Vector3d& wrist = f.wrist[side];
    const double seen = L.hand_tip[side].y();
    if (tip.allFinite() && wrist.allFinite() && tip.y() < seen && wrist.y() > seen) {
      if (notes && seen - tip.y() > kSaid)
        notes->push_back(std::string("photos: the ") + (side == kLeft ? "left" : "right") + " hand tip predicted " + mm(seen - tip.y()) +
                         " mm below the lowest point of the arm seen: drawn back along the hand");
      tip = wrist + (tip - wrist) * ((wrist.y() - seen) / (wrist.y() - tip.y()));
    }
  }
  return f;
}

double population_distance(const CustomizationModel& model, const PhotoLandmarks& landmarks) {
  if (model.descriptor_precision.rows() == 0 || model.descriptor_mean.size() != landmarks.descriptor.size()) return 0;
  const Eigen::VectorXd z = (landmarks.descriptor - model.descriptor_mean).cwiseQuotient(model.descriptor_scale);
  return std::sqrt(std::max(0.0, z.dot(model.descriptor_precision * z)));
}

double population_range_excess(const CustomizationModel& model, const PhotoLandmarks& landmarks, int* axis) {
  if (model.descriptor_axes.rows() != landmarks.descriptor.size() || model.descriptor_axes.cols() == 0) return 0;
  const Eigen::VectorXd z = (landmarks.descriptor - model.descriptor_mean).cwiseQuotient(model.descriptor_scale);
  const Eigen::VectorXd p = model.descriptor_axes.transpose() * z;
  double worst = 0;
  for (Eigen::Index k = 0; k < std::min<Eigen::Index>(p.size(), kRangeAxes); ++k) {
    const double range = std::max(1e-9, model.axis_high[k] - model.axis_low[k]);
    const double excess = std::max(p[k] - model.axis_high[k], model.axis_low[k] - p[k]) / range;
    if (excess > worst) {
      worst = excess;
      if (axis) *axis = static_cast<int>(k);
    }
  }
  return worst;
}

void prepare_customization_model(CustomizationModel* model) {
  if (model->template_mesh.V.rows() == 0) throw InvalidInput("customization model: no template mesh");
  auto rt = std::make_shared<CustomizationModel::Runtime>();
  rt->template_features = find_body_features(model->template_mesh.V, model->template_mesh.F);
  rt->template_rep =
      build_layered_representation(model->template_mesh.V, model->template_mesh.F, rt->template_features, model->points_per_layer);
  if (rt->template_rep.layers.size() != model->layers.size())
    throw InvalidInput("customization model: " + std::to_string(model->layers.size()) + " layer models for a representation of " +
                       std::to_string(rt->template_rep.layers.size()) + " layers");
  rt->param = ctffd_parametrize(model->template_mesh.V, rt->template_rep);
  rt->mlps.resize(model->layers.size());
  for (size_t i = 0; i < model->layers.size(); ++i)
    if (model->layers[i].use_mlp) {
      rt->mlps[i] = opencv_calls::load_mlp(model->layers[i].mlp);
      if (!rt->mlps[i]) throw InvalidInput("customization model: layer " + std::to_string(i) + "'s MLP does not load");
    }
  model->runtime = rt;
}

namespace {

/// The photos' 2-D features with each arm read at its own depth (ArmChains): read at the torso's
/// depth first, then at the arms predicted from the last reading, until the prediction moves less
/// than a millimetre (a fixed point; 4-8 rounds). `moved`: the last round's move (m).
PhotoLandmarks landmarks_at_arm_depth(const Silhouette& front, const Silhouette& side, const PhotoCameras& cams,
                                      const CustomizationModel& model, double* moved) {
  PhotoLandmarks L = find_photo_landmarks(front, side, cams);
  ArmChains arms = arm_chains(predict_body_features(model, L));
  *moved = 1;
  for (int round = 0; round < 12 && *moved >= 1e-3; ++round) {
    L = find_photo_landmarks(front, side, cams, &arms);
    const ArmChains next = arm_chains(predict_body_features(model, L));
    *moved = 0;
    for (int k : {kLeft, kRight})
      for (size_t p = 0; p < next.chain[k].size(); ++p)
        *moved = std::max(*moved, p < arms.chain[k].size() ? (next.chain[k][p] - arms.chain[k][p]).norm() : 1.0);
    arms = next;
  }
  return L;
}

}  // namespace

void check_photo_agreement(CustomizedBody* body, bool accept_poor) {
  if (body->photo_agreement >= kMinPhotoAgreement) return;
  std::ostringstream why;
  why.precision(2);
  why << "the customized body does not look like the photos: seen by their cameras it overlaps the silhouettes by " << body->photo_agreement
      << " (intersection over union; " << kMinPhotoAgreement << " at least)";
  if (!accept_poor) throw BelowConfidence("customize: " + why.str() + "; nothing written (--accept-poor gives it anyway, marked as poor)");
  body->warnings.push_back("poor result: " + why.str());
}

void scale_to_stated_stature(CustomizedBody* out, const PhotoCameras& cams, double stated, const Eigen::Vector2d& axis_xz) {
  if (stated > 0) {
    // The customized body's own height (the photos' lowest rows lie a toe tip's height above the soles).
    const double soles = out->mesh.V.col(1).minCoeff(), photos = out->mesh.V.col(1).maxCoeff() - soles;
    if (cams.assumed.empty() && std::abs(photos - stated) > 0.02) {
      std::ostringstream w;
      w.precision(3);
      w << "the camera file gives a stature of " << photos << " m, the stated height is " << stated
        << " m: the body is scaled to the stated height (check the camera file)";
      out->warnings.push_back(w.str());
    }
    out->scale = stated / photos;
    out->scale_origin = Eigen::Vector3d(axis_xz.x(), soles, axis_xz.y());
    const Eigen::RowVector3d origin = out->scale_origin.transpose();
    out->mesh.V = ((out->mesh.V.rowwise() - origin) * out->scale).rowwise() + origin;
    if (out->representation.mesh.V.rows() > 0)
      out->representation.mesh.V = ((out->representation.mesh.V.rowwise() - origin) * out->scale).rowwise() + origin;
    for (auto& L : out->representation.layers) L.centre = (L.centre.transpose() - origin).transpose() * out->scale + origin.transpose();
  }
}

CustomizedBody customize_from_silhouettes(const Silhouette& front, const Silhouette& side, const PhotoCameras& cams,
                                          const CustomizationModel& model, double stated_stature, bool accept_poor) {
  if (!model.runtime) throw InvalidInput("customize: the model is not prepared (prepare_customization_model)");
  CustomizedBody out;
  double moved = 0;
  out.landmarks = landmarks_at_arm_depth(front, side, cams, model, &moved);
  out.warnings = out.landmarks.warnings;
  if (moved > 0.005)
    out.warnings.push_back("photos: the arms' distance from the camera did not settle (the predicted arms still move " +
                           std::to_string(static_cast<int>(1000 * moved)) + " mm): the arms' outline may be read at the wrong depth");
  out.population_distance = population_distance(model, out.landmarks);
  int axis = -1;
  out.population_range_excess = population_range_excess(model, out.landmarks, &axis);
  if (model.descriptor_limit > 0 && out.population_distance > model.descriptor_limit) {
    std::ostringstream w;
    w.precision(3);
    w << "this body lies outside the model's training population (distance " << out.population_distance
      << "; 99.5% of the population within " << model.descriptor_limit << "): its shape is extrapolated, check the result ("
      << model.population << ")";
    out.warnings.push_back(w.str());
  } else if (out.population_range_excess > kRangeMargin) {
    std::ostringstream w;
    w.precision(2);
    w << "this body lies beyond the model's training population along its principal axis " << axis + 1 << " (by "
      << 100 * out.population_range_excess << "% of the population's range): its shape is extrapolated, check the result ("
      << model.population << ")";
    out.warnings.push_back(w.str());
  }
  const BodyFeatures predicted = predict_body_features(model, out.landmarks);
  out.features = torso_levels_in_proportion(within_photos(predicted, out.landmarks, &out.warnings), model.runtime->template_features);
  LayeredRepresentation rep = plan_layered_representation(out.features, model.points_per_layer);
  if (rep.layers.size() != model.layers.size()) throw InvalidInput("customize: the model's layers do not match the representation");
  const std::vector<LayerExtent> extents = measure_layers(rep, front, side, cams, out.features.axis_x, out.landmarks.side_arm_occlusion);
  for (size_t i = 0; i < rep.layers.size(); ++i)
    apply_layer_outputs(&rep, i, extents[i], predict_layer(model, i, layer_inputs(rep, extents, i, out.landmarks.stature)));
  out.mesh.V = ctffd_evaluate(model.runtime->param, rep);
  out.mesh.F = model.template_mesh.F;
  out.photo_agreement = std::min(photo_agreement(out.mesh, front, cams.front), photo_agreement(out.mesh, side, cams.side));
  check_photo_agreement(&out, accept_poor);
  out.representation = std::move(rep);
  scale_to_stated_stature(&out, cams, stated_stature, Eigen::Vector2d(out.features.axis_x, out.landmarks.axis_z));
  return out;
}

namespace {

/// What the stages of train_customization_model share: the population and each body's sample.
struct TrainingRun {
  const CustomizationTrainingOptions& options;
  std::shared_ptr<const MakeHumanModel> makehuman;
  BodyFeatures template_features;
  std::vector<BodySpec> specs;
  std::vector<Sample> samples;
  std::atomic<int> done{0};

  void report(const std::string& what) {
    const int d = ++done;
    if (options.progress) options.progress(d, 2 * static_cast<int>(samples.size()), what);
  }
  Sample& sample(int i) { return samples[static_cast<size_t>(i)]; }
};

/// Stage 1: one body of the population, turned a little, photographed by the training cameras; its
/// 2-D landmarks and the 3-D features they are to predict.
void photograph_training_body(TrainingRun& run, int i) {
  const CustomizationTrainingOptions& o = run.options;
  Sample& s = run.sample(i);
  const Body body = build_body(*run.makehuman, run.specs[static_cast<size_t>(i)]);
  s.bmi = body_stats(body.mesh).bmi;
  s.gender = run.specs[static_cast<size_t>(i)].gender;
  if (o.keep && !o.keep(i, s.bmi, s.gender)) {
    s.why = "left out";
    return;
  }
  std::mt19937 rng(o.seed * 31u + static_cast<unsigned>(i));
  std::uniform_real_distribution<double> u(0, 1);
  const double soles = body.mesh.V.col(1).minCoeff(), mid_height = 0.5 * (body.mesh.V.col(1).maxCoeff() + soles);
  const bool phone = o.cameras == CustomizationTrainingOptions::Cameras::kPhone;
  const double distance = phone ? 2.2 + 0.3 * u(rng) : 2.6 + 0.8 * u(rng);
  const double mid = mid_height + 0.1 * (u(rng) - 0.5);
  const double eye_height = phone ? soles + 1.0 + 0.5 * u(rng) : mid;
  const double focal = phone ? (2800 + 400 * u(rng)) * 1200.0 / 4000.0 : 1400;
  const int columns = phone ? 900 : 800;
  // A person never stands exactly square to the camera: each body turned by up to the population's
  // turn about the vertical, so that the left and right arms' readings are not always equal (the
  // regression then learns each side from its own arm, not from their mean).
  const double turn = o.max_turn_degrees * (2 * u(rng) - 1) * M_PI / 180;
  const TriangleMesh mesh = turned_about_vertical(body.mesh, turn);
  const BodyFeatures f = find_body_features(mesh.V, mesh.F);
  s.cameras.front = PinholeCamera::look_at(Eigen::Vector3d(0, eye_height, distance), Eigen::Vector3d(0, mid, 0), Eigen::Vector3d::UnitY(),
                                           columns, 1200, focal);
  s.cameras.side = PinholeCamera::look_at(Eigen::Vector3d(distance, eye_height, 0), Eigen::Vector3d(0, mid, 0), Eigen::Vector3d::UnitY(),
                                          columns, 1200, focal);
  const Silhouette sil[2] = {silhouette_from_render(render_mesh(mesh, s.cameras.front)),
                             silhouette_from_render(render_mesh(mesh, s.cameras.side))};
  s.turn = turn;
  const ArmChains arms = arm_chains(f);
  s.landmarks = find_photo_landmarks(sil[0], sil[1], s.cameras, &arms);
  s.targets = feature_targets(f, s.landmarks);
  s.front_png = encode(sil[0].mask, sil[0].width, sil[0].height);
  s.side_png = encode(sil[1].mask, sil[1].width, sil[1].height);
  s.ok = true;
}

/// The samples stage 1 could use; throws when under 20, with the first reason a body was not.
std::vector<int> usable_samples(const std::vector<Sample>& samples) {
  std::vector<int> kept;
  for (size_t i = 0; i < samples.size(); ++i)
    if (samples[i].ok) kept.push_back(static_cast<int>(i));
  if (kept.size() >= 20) return kept;
  std::string why;
  for (const Sample& s : samples)
    if (!s.ok && s.why != "left out") {
      why = s.why;
      break;
    }
  throw InvalidInput("customize train: only " + std::to_string(kept.size()) + " usable bodies (e.g.: " + why + ")");
}

/// Stage 2: the 3-D features by ridge regression on the 2-D landmarks; each arm's joints from its own
/// arm's readings and the rest of the body, not the other arm's (a population of symmetric bodies
/// makes the two arms' readings collinear, and a joint fit would predict each arm from their mean:
/// wrong for a person turned a little, or with uneven arms).
void fit_feature_regression(const Eigen::MatrixXd& X, const Eigen::MatrixXd& Y, CustomizationModel* model) {
  const Eigen::Index descriptor_size = X.cols();
  model->feature_weights = ridge(X, Y, 1e-4);
  for (int side : {kLeft, kRight}) {
    std::vector<bool> other(static_cast<size_t>(descriptor_size), false);
    for (int c : descriptor_arm_entries(side == kLeft ? kRight : kLeft)) other[static_cast<size_t>(c)] = true;
    std::vector<Eigen::Index> kept_columns, targets;
    for (Eigen::Index c = 0; c < descriptor_size; ++c)
      if (!other[static_cast<size_t>(c)]) kept_columns.push_back(c);
    for (int point = kFirstArmPoint + side; point <= kLastArmPoint; point += 2)
      for (int a = 0; a < 3; ++a) targets.push_back(kFeatureScalars + 3 * point + a);
    const Eigen::MatrixXd W = ridge(X(Eigen::all, kept_columns), Y(Eigen::all, targets), 1e-4);
    model->feature_weights(Eigen::all, targets).setZero();
    for (size_t r = 0; r < kept_columns.size(); ++r) model->feature_weights(kept_columns[r], targets) = W.row(static_cast<Eigen::Index>(r));
    model->feature_weights(descriptor_size, targets) = W.row(W.rows() - 1);
  }
}

/// Stage 3: the population's spread of 2-D landmarks (mean, scale, precision, principal axes and
/// their ranges over the training bodies), and the distance 99.5% of the validation bodies stay under.
void describe_population(const Eigen::MatrixXd& X, const std::vector<const Sample*>& validation, CustomizationModel* model) {
  model->descriptor_mean = X.colwise().mean().transpose();
  model->descriptor_scale = ((X.rowwise() - model->descriptor_mean.transpose()).array().square().colwise().mean()).sqrt().transpose();
  for (Eigen::Index c = 0; c < model->descriptor_scale.size(); ++c)
    if (model->descriptor_scale[c] < 1e-9) model->descriptor_scale[c] = 1;
  const Eigen::MatrixXd Z =
      (X.rowwise() - model->descriptor_mean.transpose()).array().rowwise() / model->descriptor_scale.transpose().array();
  Eigen::MatrixXd correlation = Z.transpose() * Z / static_cast<double>(Z.rows());
  correlation.diagonal().array() += 0.01;
  model->descriptor_precision = correlation.ldlt().solve(Eigen::MatrixXd::Identity(correlation.rows(), correlation.cols()));
  const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(correlation);
  const int axes = std::min<int>(10, static_cast<int>(correlation.rows()));
  model->descriptor_axes = eig.eigenvectors().rightCols(axes).rowwise().reverse();  // largest first
  const Eigen::MatrixXd along = Z * model->descriptor_axes;
  model->axis_low = along.colwise().minCoeff().transpose();
  model->axis_high = along.colwise().maxCoeff().transpose();
  std::vector<double> distances;
  PhotoLandmarks probe;
  for (const Sample* s : validation) {
    probe.descriptor = s->landmarks.descriptor;
    distances.push_back(population_distance(*model, probe));
  }
  std::sort(distances.begin(), distances.end());
  if (!distances.empty())
    model->descriptor_limit = distances[std::min(distances.size() - 1, static_cast<size_t>(std::ceil(0.995 * distances.size())) - 1)];
}

/// Stages 2 and 3 on the training bodies, and the features' validation error (mm per point).
void learn_features(const std::vector<Sample>& samples, const std::vector<int>& train, const std::vector<int>& valid,
                    CustomizationModel* model) {
  const Eigen::Index descriptor_size = samples[static_cast<size_t>(train[0])].landmarks.descriptor.size();
  Eigen::MatrixXd X(static_cast<Eigen::Index>(train.size()), descriptor_size), Y(static_cast<Eigen::Index>(train.size()), kFeatureTargets);
  for (size_t r = 0; r < train.size(); ++r) {
    X.row(static_cast<Eigen::Index>(r)) = samples[static_cast<size_t>(train[r])].landmarks.descriptor.transpose();
    Y.row(static_cast<Eigen::Index>(r)) = samples[static_cast<size_t>(train[r])].targets.transpose();
  }
  fit_feature_regression(X, Y, model);
  double sum = 0;
  long count = 0;
  std::vector<const Sample*> validation;
  for (int i : valid) {
    const Sample& s = samples[static_cast<size_t>(i)];
    const Eigen::VectorXd p = model->feature_weights.transpose() * with_bias(s.landmarks.descriptor);
    for (int k = kFeatureScalars; k < kFeatureTargets; k += 3) sum += 1000 * (p.segment<3>(k) - s.targets.segment<3>(k)).norm(), ++count;
    validation.push_back(&s);
  }
  model->feature_error_mm = count ? sum / count : 0;
  describe_population(X, validation, model);
}

/// Stage 4: a body's representation planned at its predicted features; per layer, the inputs its
/// silhouettes give and the true section's outputs.
void measure_training_sections(TrainingRun& run, const CustomizationModel& model, int i) {
  Sample& s = run.sample(i);
  const BodyFeatures f =
      torso_levels_in_proportion(within_photos(predict_body_features(model, s.landmarks), s.landmarks, nullptr), run.template_features);
  const LayeredRepresentation planned = plan_layered_representation(f, model.points_per_layer);
  const Silhouette front = decode(s.front_png), side = decode(s.side_png);
  const std::vector<LayerExtent> e = measure_layers(planned, front, side, s.cameras, f.axis_x, s.landmarks.side_arm_occlusion);
  const TriangleMesh mesh = turned_about_vertical(build_body(*run.makehuman, run.specs[static_cast<size_t>(i)]).mesh, s.turn);
  const LayeredRepresentation truth = build_layered_representation(mesh.V, mesh.F, f, model.points_per_layer);
  for (size_t k = 0; k < truth.layers.size(); ++k) {
    s.inputs.push_back(layer_inputs(planned, e, k, s.landmarks.stature));
    s.outputs.push_back(layer_outputs(truth, k, e[k]));
    s.w.push_back(e[k].half_width);
    s.d.push_back(e[k].half_depth > 0 ? e[k].half_depth : e[k].half_width);
  }
}

/// Stage 5: layer i's regression, linear (ridge on standardised inputs) and, when asked and better on
/// the validation bodies, an MLP.
void fit_layer(const std::vector<Sample>& samples, const std::vector<int>& train, const std::vector<int>& valid,
               const CustomizationTrainingOptions& o, size_t i, CustomizationModel* model) {
  CustomizationModel::Layer& L = model->layers[i];
  const int n_out = 2 * model->points_per_layer + 2;
  auto gather = [&](const std::vector<int>& ids, Eigen::MatrixXd* X, Eigen::MatrixXd* Y) {
    X->resize(static_cast<Eigen::Index>(ids.size()), kLayerInputs);
    Y->resize(static_cast<Eigen::Index>(ids.size()), n_out);
    for (size_t r = 0; r < ids.size(); ++r) {
      X->row(static_cast<Eigen::Index>(r)) = samples[static_cast<size_t>(ids[r])].inputs[i].transpose();
      Y->row(static_cast<Eigen::Index>(r)) = samples[static_cast<size_t>(ids[r])].outputs[i].transpose();
    }
  };
  Eigen::MatrixXd X, Y, Xv, Yv;
  gather(train, &X, &Y);
  gather(valid, &Xv, &Yv);
  L.in_mean = X.colwise().mean().transpose();
  L.in_scale = ((X.rowwise() - L.in_mean.transpose()).array().square().colwise().mean()).sqrt().transpose();
  L.out_mean = Y.colwise().mean().transpose();
  L.out_scale = ((Y.rowwise() - L.out_mean.transpose()).array().square().colwise().mean()).sqrt().transpose();
  for (auto* s : {&L.in_scale, &L.out_scale})
    for (Eigen::Index c = 0; c < s->size(); ++c)
      if ((*s)[c] < 1e-9) (*s)[c] = 1;
  const Eigen::MatrixXd Z = (X.rowwise() - L.in_mean.transpose()).array().rowwise() / L.in_scale.transpose().array();
  const Eigen::MatrixXd T = (Y.rowwise() - L.out_mean.transpose()).array().rowwise() / L.out_scale.transpose().array();
  L.linear = ridge(Z, T, 1e-4);  // Z is standardised already: the weights in its units
  L.use_mlp = false;
  auto validation_error = [&](const std::function<Eigen::VectorXd(const Eigen::VectorXd&)>& predict) {
    double sum = 0;
    for (Eigen::Index r = 0; r < Xv.rows(); ++r) {
      const Sample& s = samples[static_cast<size_t>(valid[static_cast<size_t>(r)])];
      sum += point_error_mm(predict(Xv.row(r).transpose()), Yv.row(r).transpose(), s.w[i], s.d[i], model->points_per_layer);
    }
    return sum / static_cast<double>(Xv.rows());
  };
  L.linear_error_mm = validation_error([&](const Eigen::VectorXd& x) { return predict_layer(*model, i, x); });
  L.mlp_error_mm = -1;
  if (!o.mlp) return;
  const opencv_calls::Mlp mlp = opencv_calls::train_mlp(Z, T, o.mlp_hidden, o.mlp_iterations, static_cast<int>(o.seed + i));
  L.mlp_error_mm = validation_error([&](const Eigen::VectorXd& x) {
    const Eigen::VectorXd z = (x - L.in_mean).cwiseQuotient(L.in_scale);
    return Eigen::VectorXd(L.out_mean + opencv_calls::predict_mlp(mlp, z).cwiseProduct(L.out_scale));
  });
  if (L.mlp_error_mm < L.linear_error_mm) {
    L.use_mlp = true;
    L.mlp = opencv_calls::mlp_text(mlp);
  }
}

/// The population a model was trained on, as its file records it.
std::string describe_training_population(const CustomizationTrainingOptions& o, const std::vector<Sample>& samples, size_t train,
                                         size_t valid) {
  std::ostringstream pop;
  if (o.specs.empty()) pop << "make_calibration_specs(" << o.seed << ", " << o.bodies << ")";
  else pop << (o.specs_note.empty() ? "given bodies" : o.specs_note) << " (" << o.specs.size() << ")";
  pop << ": " << train << " training and " << valid << " validation bodies, turned up to " << o.max_turn_degrees << " degrees";
  if (o.cameras == CustomizationTrainingOptions::Cameras::kPhone)
    pop << ", photographed by phone cameras (2.2-2.5 m away, 1.0-1.5 m above the soles, f 2800-3200 px at 4000 rows)";
  int failed = 0, left_out = 0;
  for (const Sample& s : samples) (s.why == "left out" ? left_out : failed) += !s.ok;
  if (left_out) pop << ", " << left_out << " left out (" << (o.population_note.empty() ? "keep" : o.population_note) << ")";
  if (failed) {
    std::map<std::string, int> reasons;
    for (const Sample& s : samples)
      if (!s.ok && s.why != "left out") ++reasons[s.why.substr(0, s.why.find(':', s.why.find(':') + 1))];
    pop << ", " << failed << " unusable:";
    for (const auto& [why, count] : reasons) pop << " " << count << " x '" << why << "';";
  }
  return pop.str();
}

}  // namespace

CustomizationModel train_customization_model(const CustomizationTrainingOptions& o) {
  const Stopwatch t0;
  if (o.bodies < 20) throw InvalidInput("customize train: at least 20 bodies");
  TrainingRun run{o, load_makehuman_model(o.data_root), {}, o.specs.empty() ? make_calibration_specs(o.seed, o.bodies) : o.specs, {}};
  run.samples.resize(run.specs.size());
  CustomizationModel model;
  model.seed = o.seed;
  model.template_mesh = build_body(*run.makehuman, BodySpec{}).mesh;
  run.template_features = find_body_features(model.template_mesh.V, model.template_mesh.F);
  const int n = static_cast<int>(run.specs.size());
  auto each_sample = [&](long count, const std::function<int(long)>& index, const std::string& what,
                         const std::function<void(int)>& stage) {
    parallel_for_each(count, o.threads, [&](long j) {
      const int i = index(j);
      try {
        stage(i);
      } catch (const Error& e) {
        run.sample(i).ok = false;
        run.sample(i).why = e.what();
      }
      run.report(what + " " + std::to_string(j));
    });
  };
  each_sample(
      n, [](long j) { return static_cast<int>(j); }, "body", [&](int i) { photograph_training_body(run, i); });
  const std::vector<int> kept = usable_samples(run.samples);
  // Validation: every fifth body (by index, so the split does not depend on threads).
  const int stride = std::max(2, static_cast<int>(std::lround(1.0 / std::max(0.05, o.validation_fraction))));
  std::vector<int> train, valid;
  for (int i : kept) (i % stride == stride - 1 ? valid : train).push_back(i);
  learn_features(run.samples, train, valid, &model);
  each_sample(
      static_cast<long>(kept.size()), [&](long j) { return kept[static_cast<size_t>(j)]; }, "sections",
      [&](int i) { measure_training_sections(run, model, i); });
  auto usable = [&](std::vector<int> v) {
    v.erase(std::remove_if(v.begin(), v.end(), [&](int i) { return !run.sample(i).ok; }), v.end());
    return v;
  };
  train = usable(train), valid = usable(valid);
  if (train.size() < 15 || valid.empty()) throw InvalidInput("customize train: too few bodies gave sections");
  model.layers.resize(run.sample(train[0]).inputs.size());
  parallel_for_each(static_cast<long>(model.layers.size()), o.threads,
                    [&](long i) { fit_layer(run.samples, train, valid, o, static_cast<size_t>(i), &model); });
  model.bodies = static_cast<int>(train.size());
  model.validation_bodies = static_cast<int>(valid.size());
  model.population = describe_training_population(o, run.samples, train.size(), valid.size());
  prepare_customization_model(&model);
  model.training_seconds = t0.seconds();
  return model;
}

void write_photo_features_png(const std::string& path, const Silhouette& sil, const PinholeCamera& cam, const CustomizedBody& body) {
  using Write = void(const std::string&, const Silhouette&, const PinholeCamera&, const CustomizedBody&);
  plugin_function<Write>("photo", "posekit_write_photo_features_png")(path, sil, cam, body);
}

void save_customization_model(const std::string& path, const CustomizationModel& m) {
  nlohmann::json j;
  auto mat = [](const Eigen::MatrixXd& M) {
    nlohmann::json a = nlohmann::json::array();
    for (Eigen::Index r = 0; r < M.rows(); ++r) {
      std::vector<double> row(static_cast<size_t>(M.cols()));
      for (Eigen::Index c = 0; c < M.cols(); ++c) row[static_cast<size_t>(c)] = M(r, c);
      a.push_back(row);
    }
    return a;
  };
  auto vec = [](const Eigen::VectorXd& v) { return std::vector<double>(v.data(), v.data() + v.size()); };
  j["format"] = "posekit customization model";
  j["version"] = 1;
  j["posekit"] = POSEKIT_VERSION_STRING;
  j["points_per_layer"] = m.points_per_layer;
  j["bodies"] = m.bodies;
  j["validation_bodies"] = m.validation_bodies;
  j["seed"] = m.seed;
  j["training_seconds"] = m.training_seconds;
  j["population"] = m.population;
  j["feature_error_mm"] = m.feature_error_mm;
  j["feature_weights"] = mat(m.feature_weights);
  if (m.descriptor_precision.rows() > 0) {
    j["descriptor_mean"] = vec(m.descriptor_mean);
    j["descriptor_scale"] = vec(m.descriptor_scale);
    j["descriptor_precision"] = mat(m.descriptor_precision);
    j["descriptor_limit"] = m.descriptor_limit;
    j["descriptor_axes"] = mat(m.descriptor_axes);
    j["axis_low"] = vec(m.axis_low);
    j["axis_high"] = vec(m.axis_high);
  }
  for (const auto& L : m.layers)
    j["layers"].push_back({{"model", L.use_mlp ? "mlp" : "linear"},
                           {"linear", mat(L.linear)},
                           {"mlp", L.mlp},
                           {"in_mean", vec(L.in_mean)},
                           {"in_scale", vec(L.in_scale)},
                           {"out_mean", vec(L.out_mean)},
                           {"out_scale", vec(L.out_scale)},
                           {"linear_error_mm", L.linear_error_mm},
                           {"mlp_error_mm", L.mlp_error_mm}});
  j["template"]["V"] = mat(m.template_mesh.V);
  j["template"]["F"] = mat(m.template_mesh.F.cast<double>());
  const std::string text = j.dump();
  write_file_atomically(path, [&](std::ostream& os) { os << text; });
}

CustomizationModel load_customization_model(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw IoError("cannot open customization model '" + path + "' (make one with: posekit customize train --out " + path + ")");
  nlohmann::json j;
  try {
    in >> j;
  } catch (const std::exception& e) {
    throw InvalidInput("customization model '" + path + "': not JSON (" + e.what() + ")");
  }
  if (j.value("format", "") != "posekit customization model")
    throw InvalidInput("'" + path + "' is not a posekit customization model (make one with: posekit customize train --out FILE)");
  CustomizationModel m;
  auto mat = [&](const nlohmann::json& a, const std::string& what) {
    if (!a.is_array() || a.empty()) throw InvalidInput("customization model '" + path + "': " + what + " is not a matrix");
    Eigen::MatrixXd M(static_cast<Eigen::Index>(a.size()), static_cast<Eigen::Index>(a[0].size()));
    for (size_t r = 0; r < a.size(); ++r) {
      if (a[r].size() != static_cast<size_t>(M.cols())) throw InvalidInput("customization model '" + path + "': ragged " + what);
      for (size_t c = 0; c < a[r].size(); ++c) M(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(c)) = a[r][c].get<double>();
    }
    return M;
  };
  auto vec = [&](const nlohmann::json& a) {
    const auto v = a.get<std::vector<double>>();
    return Eigen::VectorXd(Eigen::Map<const Eigen::VectorXd>(v.data(), static_cast<Eigen::Index>(v.size())));
  };
  try {
    m.points_per_layer = j.at("points_per_layer").get<int>();
    m.bodies = j.at("bodies").get<int>();
    m.validation_bodies = j.at("validation_bodies").get<int>();
    m.seed = j.at("seed").get<unsigned>();
    m.training_seconds = j.at("training_seconds").get<double>();
    m.population = j.at("population").get<std::string>();
    m.feature_error_mm = j.at("feature_error_mm").get<double>();
    m.feature_weights = mat(j.at("feature_weights"), "feature_weights");
    if (j.contains("descriptor_precision")) {
      m.descriptor_mean = vec(j.at("descriptor_mean"));
      m.descriptor_scale = vec(j.at("descriptor_scale"));
      m.descriptor_precision = mat(j.at("descriptor_precision"), "descriptor_precision");
      m.descriptor_limit = j.at("descriptor_limit").get<double>();
      m.descriptor_axes = mat(j.at("descriptor_axes"), "descriptor_axes");
      m.axis_low = vec(j.at("axis_low"));
      m.axis_high = vec(j.at("axis_high"));
      const Eigen::Index n = m.feature_weights.rows() - 1;
      if (m.descriptor_mean.size() != n || m.descriptor_scale.size() != n || m.descriptor_precision.rows() != n ||
          m.descriptor_precision.cols() != n || m.descriptor_axes.rows() != n || m.axis_low.size() != m.descriptor_axes.cols() ||
          m.axis_high.size() != m.descriptor_axes.cols())
        throw InvalidInput("customization model '" + path + "': population statistics of the wrong size");
    }
    for (const auto& l : j.at("layers")) {
      CustomizationModel::Layer L;
      L.use_mlp = l.at("model").get<std::string>() == "mlp";
      L.linear = mat(l.at("linear"), "a layer's linear model");
      L.mlp = l.at("mlp").get<std::string>();
      L.in_mean = vec(l.at("in_mean")), L.in_scale = vec(l.at("in_scale"));
      L.out_mean = vec(l.at("out_mean")), L.out_scale = vec(l.at("out_scale"));
      L.linear_error_mm = l.at("linear_error_mm").get<double>();
      L.mlp_error_mm = l.at("mlp_error_mm").get<double>();
      if (L.in_mean.size() != kLayerInputs || L.linear.rows() != kLayerInputs + 1 || L.out_mean.size() != L.linear.cols())
        throw InvalidInput("customization model '" + path + "': a layer model of the wrong size");
      m.layers.push_back(std::move(L));
    }
    m.template_mesh.V = mat(j.at("template").at("V"), "template vertices");
    m.template_mesh.F = mat(j.at("template").at("F"), "template faces").cast<int>();
  } catch (const nlohmann::json::exception& e) {
    throw InvalidInput("customization model '" + path + "': " + e.what());
  }
  if (m.feature_weights.cols() != kFeatureTargets)
    throw InvalidInput("customization model '" + path + "': its feature model predicts " + std::to_string(m.feature_weights.cols()) +
                       " numbers, this posekit " + std::to_string(kFeatureTargets) +
                       " (made by another version: train it again with posekit customize train)");
  prepare_customization_model(&m);
  return m;
}

}  // namespace posekit
