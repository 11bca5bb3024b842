#include "posekit/deformation/dataset_training.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/units.h"
#include "posekit/deformation/pose_dataset.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/layered_representation.h"

namespace posekit {

TrainingPoses parse_training_poses(const std::string& name) {
  if (name == "auto") return TrainingPoses::kAuto;
  if (name == "json") return TrainingPoses::kJson;
  if (name == "estimate") return TrainingPoses::kEstimate;
  throw InvalidInput("training poses: expected auto, json or estimate, got '" + name + "'");
}

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

/// The rest example of a dataset and why it was chosen (-1 when a given name is unknown).
int choose_rest_example(const PoseDataset& data, std::string* reason) {
  const int known = find_rest_example(data);
  if (known >= 0) {
    *reason = !data.rest_name.empty() && data.names[static_cast<size_t>(known)] == data.rest_name ? "named as the rest pose"
                                                                                                  : "its pose JSON is all zero";
    return known;
  }
  if (!data.rest_name.empty()) return -1;
  for (size_t i = 0; i < data.names.size(); ++i) {
    const std::string n = lower(data.names[i]);
    if (n.find("rest") != std::string::npos || n.find("template") != std::string::npos) {
      *reason = "its name says rest or template";
      return static_cast<int>(i);
    }
  }
  *reason = "the first mesh in name order (give the rest example's name when it is another)";
  return 0;
}

/// Overrides the manifest's split with `held_out` names or every N-th example (the rest never).
void apply_split(const std::string& dir, const DatasetTrainingOptions& options, int rest, PoseDataset* data) {
  if (options.held_out.empty() && options.hold_out_every <= 0) return;
  if (!options.held_out.empty() && options.hold_out_every > 0)
    throw InvalidInput("give the held-out examples by name or every N-th, not both");
  std::fill(data->test.begin(), data->test.end(), false);
  for (const std::string& name : options.held_out) {
    const auto it = std::find(data->names.begin(), data->names.end(), name);
    if (it == data->names.end())
      throw InvalidInput(dir + ": no example named '" + name + "' to hold out (" + std::to_string(data->names.size()) +
                         " examples, e.g. '" + data->names.front() + "')");
    if (it - data->names.begin() == rest) throw InvalidInput(dir + ": '" + name + "' is the rest example; it cannot be held out");
    data->test[static_cast<size_t>(it - data->names.begin())] = true;
  }
  int k = 0;
  if (options.hold_out_every > 0)
    for (size_t i = 0; i < data->names.size(); ++i)
      if (static_cast<int>(i) != rest && ++k % options.hold_out_every == 0) data->test[i] = true;
}

/// Unit and axes, from the rest mesh; every example is read the same way and turned into posekit's
/// frame (metres, Y up, facing +Z).
void to_posekit_frame(const std::string& dir, const DatasetTrainingOptions& options, int rest, PoseDataset* dataset,
                      DatasetTrainingReport* report) {
  PoseDataset& data = *dataset;
  DatasetTrainingReport& rep = *report;
  const bool auto_unit = options.unit == "auto";
  std::string unit = options.unit;
  if (auto_unit) {
    // The rule every body is read by (the CLI's, Python's), on the rest mesh; the others follow it.
    BodyFrame frame;
    try {
      frame = scale_body_to_metres(&data.V[static_cast<size_t>(rest)], "auto");
    } catch (const InvalidInput& e) {
      throw InvalidInput(dir + ": the rest example '" + data.rest_name + "': " + e.what());
    }
    for (size_t i = 0; i < data.V.size(); ++i)
      if (static_cast<int>(i) != rest) data.V[i] *= frame.metres_per_unit;
    unit = frame.unit;
  }
  rep.unit = unit_name(parse_unit(unit)) + (auto_unit ? " (detected)" : "");
  OrientationOptions orient;
  if (options.up != "auto") orient.up = parse_axis(options.up);
  if (options.forward != "auto") orient.forward = parse_axis(options.forward);
  const BodyOrientation orientation = options.up == "auto" || options.forward == "auto"
                                          ? detect_mesh_orientation(data.V[static_cast<size_t>(rest)], data.F, orient)
                                          : orientation_from_axes(orient.up, orient.forward);
  rep.orientation = orientation.describe();
  for (const auto& w : orientation.warnings) rep.warnings.push_back(data.rest_name + ": " + w);
  if (!orientation.is_identity())
    for (auto& V : data.V) V = (V * orientation.rotation.transpose()).eval();
}

/// The template's labels and joints: the dataset's own, else the labeller's (a body model's fit),
/// else its segmentation (Eq. 2) and skeleton.
void label_template(const std::string& dir, const DatasetTrainingOptions& options, const PoseDataset& data, int rest,
                    TrainingOptions* training, DatasetTrainingReport* report) {
  TrainingOptions& o = *training;
  DatasetTrainingReport& rep = *report;
  bool found = false;
  const TemplateAnnotations ann = load_template_annotations(dir, &found);
  const Eigen::MatrixXd& V = data.V[static_cast<size_t>(rest)];
  if (found && ann.triangle_part.size() == data.F.rows()) {
    o.triangle_part = ann.triangle_part;
    o.joint_centres = ann.joint_centres;
    rep.labels_from_dataset = true;
  } else if (options.label_rest) {
    // No labels shipped: a body model's fit labels the rest example and places its joints.
    RestLabels labels = options.label_rest(V, data.F);
    if (!labels.poor_fit.empty()) {
      const std::string poor = "the body model's fit to the rest example '" + data.rest_name + "' is poor (" + labels.poor_fit + ")";
      if (!options.accept_poor_fit) throw BelowConfidence(dir + ": " + poor + "; --accept-poor trains on it anyway");
      rep.warnings.push_back(poor + ": its parts and joints taken as asked");
    }
    o.triangle_part = std::move(labels.triangle_part);
    o.joint_centres = std::move(labels.joint_centres);
    rep.labels_from_body_model = true;
  } else {
    // No labels shipped: the template's own segmentation (Eq. 2) and skeleton.
    try {
      const BodyFeatures features = find_body_features(V, data.F);
      const LayeredRepresentation layers = build_layered_representation(V, data.F, features);
      o.triangle_part = segment_body(V, data.F, layers).triangle_part;
      o.joint_centres = joint_centres_from_features(V, data.F, o.triangle_part, layers, features);
    } catch (const InvalidInput& e) {
      throw InvalidInput(dir + ": the rest example '" + data.rest_name + "' (" + rep.rest_reason + ") cannot be segmented: " + e.what() +
                         "; it must stand upright in the standard pose, arms away from the body");
    }
  }
}

/// Each example's pose estimated from its parts' rigid motions (PartPoseEstimator), checked against
/// its pose JSON where it has one; an example most of whose parts fit far worse than in the typical
/// one is left out of training.
void estimate_training_poses(const std::string& dir, const DatasetTrainingOptions& options, const TrainingOptions& o, int rest,
                             PoseDataset* dataset, DatasetTrainingReport* report) {
  PoseDataset& data = *dataset;
  DatasetTrainingReport& rep = *report;
  const Eigen::MatrixXd& V = data.V[static_cast<size_t>(rest)];
  PartPoseEstimator estimator(V, data.F, o.triangle_part, o.joint_centres, options.fit);
  // First the joint zones alone, then the rigid core each part shows over the training examples.
  std::vector<const Eigen::MatrixXd*> training;
  for (size_t i = 0; i < data.names.size(); ++i)
    if (!data.test[i]) training.push_back(&data.V[i]);
  try {
    estimator.learn_rigid_cores(training);
  } catch (const InvalidInput& err) {
    throw InvalidInput(dir + ": " + err.what());
  }
  std::vector<std::array<double, kNumParts>> core_rms;
  for (size_t i = 0; i < data.names.size(); ++i) {
    PartPoseEstimate e;
    try {
      e = estimator.estimate(data.V[i]);
    } catch (const InvalidInput& err) {
      throw InvalidInput(dir + ": example '" + data.names[i] + "': " + err.what());
    }
    ExamplePoseFit fit;
    fit.name = data.names[i];
    fit.test = data.test[i];
    fit.rms_mm = 1000 * e.rms;
    fit.worst_core_rms_mm = 1000 * e.core_rms[static_cast<size_t>(e.worst_part)];
    fit.worst_part = part_name(e.worst_part);
    fit.problems = pose_estimate_problems(e);
    if (data.has_pose[i]) {
      const PartPose& given = data.poses[i];
      double sum = rotation_difference(given.root_rotation, e.pose.root_rotation), worst = sum;
      fit.worst_joint = "root";
      for (int j = 0; j < kNumJoints; ++j) {
        const double d = rotation_difference(given.joint(j), e.pose.joint(j));
        sum += d;
        if (d > worst) worst = d, fit.worst_joint = joint_name(j);
      }
      fit.joint_error_mean_deg = sum / (kNumJoints + 1) * 180 / M_PI;
      fit.joint_error_max_deg = worst * 180 / M_PI;
    }
    for (const auto& p : fit.problems) rep.warnings.push_back("example '" + fit.name + "': " + p);
    if (static_cast<int>(i) == rest) e.pose = PartPose{};  // the template is the rest pose by definition
    fit.pose = e.pose;
    rep.examples.push_back(fit);
    core_rms.push_back(e.core_rms);
    data.poses[i] = e.pose;
    data.has_pose[i] = true;
  }
  // An example most of whose parts fit far worse than in the typical example is not the rest
  // body posed (another person, another scale, another registration): left out, and said so.
  std::array<double, kNumParts> typical{};
  for (int p = 0; p < kNumParts; ++p) {
    std::vector<double> v;
    for (const auto& c : core_rms) v.push_back(c[static_cast<size_t>(p)]);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    typical[static_cast<size_t>(p)] = v[v.size() / 2];
  }
  for (size_t i = 0; i < data.names.size(); ++i) {
    int worse = 0;
    for (int p = 0; p < kNumParts; ++p)
      worse += core_rms[i][static_cast<size_t>(p)] > 3 * typical[static_cast<size_t>(p)] + options.fit.min_robust_scale;
    if (worse <= kNumParts / 2 || static_cast<int>(i) == rest) continue;
    const std::string what = std::to_string(worse) +
                             " of its 16 parts fit over 3 times worse than in the typical example: not the rest body posed (another "
                             "person, scale or registration?); left out of training";
    rep.examples[i].problems.push_back(what);
    rep.examples[i].left_out = true;
    rep.warnings.push_back("example '" + data.names[i] + "': " + what);
    data.has_pose[i] = false;
  }
}

}  // namespace

PreparedTraining prepare_training(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                                  DatasetTrainingReport* report) {
  DatasetTrainingReport& rep = *report;
  rep = {};
  const bool auto_unit = options.unit == "auto";
  PoseDataset data = load_pose_dataset(dir, auto_unit ? Unit::kMetre : parse_unit(options.unit));
  if (!options.rest_name.empty()) data.rest_name = options.rest_name;
  const int rest = choose_rest_example(data, &rep.rest_reason);
  if (rest < 0) {
    std::string names;
    for (size_t i = 0; i < data.names.size() && i < 8; ++i) names += (i ? ", " : "") + data.names[i];
    throw InvalidInput(dir + ": no example named '" + data.rest_name + "' to be the rest pose (examples: " + names +
                       (data.names.size() > 8 ? ", ..." : "") + ")");
  }
  data.rest_name = data.names[static_cast<size_t>(rest)];
  rep.rest_name = data.rest_name;
  apply_split(dir, options, rest, &data);
  to_posekit_frame(dir, options, rest, &data, &rep);
  TrainingOptions o = base;
  label_template(dir, options, data, rest, &o, &rep);
  // Poses: the JSONs, or each part's rigid motion from the rest mesh.
  bool all_json = true;
  for (size_t i = 0; i < data.names.size(); ++i)
    if (!data.test[i] && static_cast<int>(i) != rest && !data.has_pose[i]) all_json = false;
  if (options.poses == TrainingPoses::kJson && !all_json)
    for (size_t i = 0; i < data.names.size(); ++i)
      if (!data.test[i] && !data.has_pose[i] && static_cast<int>(i) != rest)
        throw InvalidInput(dir + ": example '" + data.names[i] + "' has no pose JSON (" + data.names[i] +
                           ".json); estimate the poses from the meshes instead");
  rep.poses_estimated = options.poses == TrainingPoses::kEstimate || (options.poses == TrainingPoses::kAuto && !all_json);
  if (rep.poses_estimated) estimate_training_poses(dir, options, o, rest, &data, &rep);
  return {std::move(data), std::move(o), rest};
}

PoseModel train_on_dataset(const std::string& dir, const TrainingOptions& base, const DatasetTrainingOptions& options,
                           DatasetTrainingReport* report) {
  DatasetTrainingReport local;
  const PreparedTraining prepared = prepare_training(dir, base, options, report ? report : &local);
  return train_pose_model(prepared.data, prepared.options);
}

PoseModel train_on_dataset(const std::string& dir, const TrainingOptions& base) {
  return train_on_dataset(dir, base, DatasetTrainingOptions{});
}

}  // namespace posekit
