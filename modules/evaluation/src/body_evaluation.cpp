#include "posekit/evaluation/body_evaluation.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>

#include "posekit/body/parts.h"
#include "posekit/core/error.h"
#include "posekit/core/mesh_geometry.h"
#include "posekit/core/mesh_validation.h"
#include "posekit/core/timer.h"
#include "posekit/core/units.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/fitting/body_fit.h"
#include "posekit/fitting/fitted_measurements.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/json.h"
#include "posekit/io/mesh_io.h"
#include "posekit/io/point_cloud_io.h"
#include "posekit/segmentation/body_segmentation.h"
#include "posekit/segmentation/segmentation.h"
#include "posekit/segmentation/segmentation_prior.h"
#include "posekit/segmentation/skeleton_checks.h"
#include "posekit/segmentation/skeleton_embedding.h"
#include "posekit/shape/body_features.h"
#include "posekit/shape/body_orientation.h"
#include "posekit/shape/layered_representation.h"
#include "posekit/shape/measurements.h"

namespace posekit {
namespace fs = std::filesystem;

namespace {

/// Each limb segment's joint-to-joint length, ours (#joints x 3) minus the rig's, in one rigid frame.
void add_segment_length_errors(const Eigen::MatrixXd& ours, const Eigen::MatrixXd& rig, BodyResult* r) {
  for (const int part : {kLeftUpperArm, kLeftForearm, kRightUpperArm, kRightForearm, kLeftThigh, kLeftShank, kRightThigh, kRightShank}) {
    const int start = part - 1, end = part;  // joint j starts part j + 1
    r->segment_length_error[part_name(part)] = (ours.row(end) - ours.row(start)).norm() - (rig.row(end) - rig.row(start)).norm();
  }
}

constexpr double kSilentJoint = 0.05, kSilentAgreement = 0.80, kSilentGirth = 0.05;  // m, fraction, m

Eigen::Vector3d vec3(const nlohmann::json& j) { return Eigen::Vector3d(j[0].get<double>(), j[1].get<double>(), j[2].get<double>()); }

/// The body model's fit of a body in the file's frame (metres) against the truth: labels (meshes),
/// joints and, where the truth has its pose, joint angles.
void evaluate_fit(const BodyFit& fit, const nlohmann::json& truth, const TriangleMesh* mesh, const Eigen::Matrix3d& file_to_posekit,
                  BodyResult* r) {
  r->by_body_model = true;
  r->fit_start = fit.start;
  r->fit_seconds = fit.seconds;
  for (const auto& w : fit.warnings) r->warnings.push_back("fit: " + w);
  r->segmented = fit.confident;
  for (const auto& reason : fit.reasons) r->segment_error += (r->segment_error.empty() ? "below confidence: " : "; ") + reason;
  if (mesh && truth.at("triangle_part").size() == static_cast<size_t>(mesh->F.rows())) {
    const Eigen::VectorXi ours = triangle_part_labels(mesh->F, fit.target_part);
    const Eigen::VectorXd area = face_areas(mesh->V, mesh->F);
    double same = 0, all = 0;
    Eigen::VectorXi theirs(mesh->F.rows());
    for (Eigen::Index f = 0; f < mesh->F.rows(); ++f) {
      theirs[f] = truth.at("triangle_part")[static_cast<size_t>(f)].get<int>();
      if (theirs[f] < 0) continue;
      all += area[f];
      if (theirs[f] == ours[f]) same += area[f];
    }
    r->segmentation_agreement = all > 0 ? same / all : 0.0;
    r->border_roughness = border_roughness(mesh->V, mesh->F, ours);
    r->truth_border_roughness = border_roughness(mesh->V, mesh->F, theirs);
  }
  r->joint_error_max = r->joint_error_mean = 0;
  Eigen::MatrixXd rig_joints(kNumJoints, 3);
  for (int j = 0; j < kNumJoints; ++j) {
    const Eigen::Vector3d rig = file_to_posekit.transpose() * vec3(truth.at("joints").at(joint_name(j)));
    rig_joints.row(j) = rig.transpose();
    const double e = (fit.joints.row(j).transpose() - rig).norm();
    r->joint_error[joint_name(j)] = e;
    if (fit.joint_guessed[static_cast<size_t>(j)]) r->guessed_joints.push_back(joint_name(j));
    r->joint_error_mean += e / kNumJoints;
    if (e > r->joint_error_max) r->joint_error_max = e, r->worst_joint = joint_name(j);
  }
  add_segment_length_errors(fit.joints, rig_joints, r);
  if (truth.contains("done") && truth.at("done").contains("pose")) {
    const PartPose want = part_pose_from_json(truth.at("done").at("pose").dump(), "truth");
    double sum = 0;
    for (int j = 0; j < kNumJoints; ++j) {
      const double e =
          Eigen::AngleAxisd(rotation_from_axis_angle(fit.pose.joint(j)).transpose() * rotation_from_axis_angle(want.joint(j))).angle();
      r->joint_angle_error[joint_name(j)] = e;
      sum += e;
    }
    r->joint_angle_error_mean = sum / kNumJoints;
  }
}

/// Each girth the truth knows: measured minus truth, or the reason it was not measured.
void record_girths(const BodyMeasurements& m, const nlohmann::json& truth, BodyResult* r) {
  for (const auto& [name, value] : truth.at("girths").items()) {
    const Girth* g = m.find(name);
    if (!g) continue;
    if (g->measured) r->girth_error[name] = g->value - value.get<double>();
    else r->girth_not_measured[name] = g->note;
  }
}

BodyResult evaluate_body(const fs::path& dir, const nlohmann::json& entry, const SegmentationPrior* prior, const BodyModel* body_model) {
  const Stopwatch t0;
  BodyResult r;
  r.name = entry.at("name").get<std::string>();
  r.variation = entry.at("variation").get<std::string>();
  r.shape = entry.at("shape").get<std::string>();
  const std::string truth_path = (dir / entry.at("truth").get<std::string>()).string();
  const nlohmann::json truth = nlohmann::json::parse(read_file_bytes(truth_path));
  r.kind = truth.at("kind").get<std::string>();
  const std::string path = (dir / truth.at("file").at("path").get<std::string>()).string();
  const bool scan = r.kind == "scan";

  // Read as a user's file: unit from the extent, orientation from the shape.
  TriangleMesh mesh;
  PointCloud cloud;
  if (scan) cloud = read_point_cloud(path);
  else mesh = read_mesh(path);
  Eigen::MatrixXd& P = scan ? cloud.P : mesh.V;
  Unit unit = Unit::kMetre;
  if (!guess_body_unit(robust_largest_extent(P), &unit)) {
    r.measure_error = r.segment_error = "cannot tell the unit from the largest extent";
    return r;
  }
  r.unit_right = unit_name(unit) == truth.at("file").at("unit").get<std::string>();
  P *= metres_per_unit(unit);
  // The body model fits the file's points as they are: it finds the up direction itself.
  std::optional<BodyFit> fit;
  if (body_model) {
    try {
      fit = scan ? fit_body_model(*body_model, P) : fit_body_model_to_mesh(*body_model, P, mesh.F);
    } catch (const InvalidInput& e) {
      r.segment_error = std::string("body model fit: ") + e.what();
    }
  }
  // Measured as `posekit measure --body-model` does: girths on the file's surface in the fitted
  // body's planes. A poor fit measures nothing (the command exits 3).
  if (fit) {
    if (!fit->confident) {
      r.measure_error = "the body model's fit is poor";
    } else {
      try {
        const FittedMeasurements fm = measure_by_body_fit(*body_model, *fit, P, scan ? Eigen::MatrixXi() : mesh.F);
        r.measured = true;
        record_girths(fm.target, truth, &r);
      } catch (const InvalidInput& e) {
        r.measure_error = e.what();
      }
    }
  }
  const BodyOrientation expected = orientation_from_axes(parse_axis(truth.at("file").at("up").get<std::string>()),
                                                         parse_axis(truth.at("file").at("forward").get<std::string>()));
  if (body_model) {
    // The body model's path uses no orientation detector: the fit finds the up direction.
    if (fit) {
      const Eigen::Vector3d truth_up = expected.rotation.transpose() * Eigen::Vector3d::UnitY();
      char up[64];
      std::snprintf(up, sizeof up, "up (%.3f, %.3f, %.3f)", fit->up.x(), fit->up.y(), fit->up.z());
      r.orientation = std::string(up) + " (the body model's fit)";
      r.orientation_right = std::acos(std::clamp(fit->up.dot(truth_up), -1.0, 1.0)) < 15 * M_PI / 180;
      evaluate_fit(*fit, truth, scan ? nullptr : &mesh, expected.rotation, &r);
    }
    flag_silent_nonsense(true, &r);
    r.seconds = t0.seconds();
    return r;
  }
  BodyOrientation orientation;
  try {
    orientation = scan ? detect_body_orientation(P, {}) : detect_mesh_orientation(mesh.V, mesh.F);
  } catch (const InvalidInput& e) {
    r.measure_error = std::string("orientation: ") + e.what();
    r.segment_error = r.measure_error;
    flag_silent_nonsense(false, &r);
    r.seconds = t0.seconds();
    return r;
  }
  r.orientation = orientation.describe();
  for (const auto& w : orientation.warnings) r.warnings.push_back("orientation: " + w);
  // Right within 15 degrees: a twisted torso has no single facing direction to the degree.
  const double off = Eigen::AngleAxisd(orientation.rotation * expected.rotation.transpose()).angle();
  r.orientation_right = off < 15 * M_PI / 180;
  P = (P * orientation.rotation.transpose()).eval();

  // Measure.
  BodyMeasurements m;
  try {
    m = scan ? measure_point_cloud(P) : measure_body(mesh.V, mesh.F);
    r.measured = true;
    for (const auto& w : m.features.warnings) r.warnings.push_back(w);
    record_girths(m, truth, &r);
  } catch (const InvalidInput& e) {
    r.measure_error = e.what();
  }

  // Segment and embed the skeleton, as `posekit segment` does.
  if (!scan) {
    try {
      // As `posekit segment` does: floating bits are left out (and not counted in the agreement).
      std::vector<int> surface_face;
      const TriangleMesh whole = mesh;
      mesh = body_surface(whole.V, whole.F, nullptr, nullptr, &surface_face);
      const BodyFeatures features = find_body_features(whole.V, whole.F);  // sees the openings (cut hands, head)
      const LayeredRepresentation rep = build_layered_representation(mesh.V, mesh.F, features);
      const BodySegmentation result = segment_standing_body(mesh.V, mesh.F, rep, features, prior);
      const Segmentation& seg = result.segmentation;
      const Eigen::MatrixXd& joints = result.joints;
      const SkeletonCheck& check = result.check;
      r.segmented = check.ok();
      if (!check.ok()) r.segment_error = "fails its sanity checks: " + check.summary();
      // Accuracy, also of a result the checks refused (to see whether they refused rightly).
      const auto& labels = truth.at("triangle_part");
      if (labels.size() == static_cast<size_t>(whole.F.rows())) {
        const Eigen::VectorXd area = face_areas(whole.V, whole.F);
        double same = 0, all = 0;
        Eigen::VectorXi ours = Eigen::VectorXi::Constant(whole.F.rows(), -1);
        for (size_t k = 0; k < surface_face.size(); ++k)
          if (surface_face[k] >= 0) ours[surface_face[k]] = seg.triangle_part[static_cast<Eigen::Index>(k)];
        for (Eigen::Index f = 0; f < whole.F.rows(); ++f) {
          const int t = labels[static_cast<size_t>(f)].get<int>();
          if (t < 0) continue;
          all += area[f];
          if (t == ours[f]) same += area[f];
        }
        r.segmentation_agreement = all > 0 ? same / all : 0.0;
        Eigen::VectorXi theirs(whole.F.rows());
        for (Eigen::Index f = 0; f < whole.F.rows(); ++f) theirs[f] = labels[static_cast<size_t>(f)].get<int>();
        r.truth_border_roughness = border_roughness(whole.V, whole.F, theirs);
      }
      r.border_roughness = border_roughness(mesh.V, mesh.F, seg.triangle_part);
      // Joints compared where the user gets them, in the file's frame.
      r.joint_error_max = r.joint_error_mean = 0;
      Eigen::MatrixXd our_joints(kNumJoints, 3), rig_joints(kNumJoints, 3);
      for (int j = 0; j < kNumJoints; ++j) {
        const Eigen::Vector3d ours = orientation.rotation.transpose() * joints.row(j).transpose();
        const Eigen::Vector3d rig = expected.rotation.transpose() * vec3(truth.at("joints").at(joint_name(j)));
        our_joints.row(j) = ours.transpose(), rig_joints.row(j) = rig.transpose();
        const double e = (ours - rig).norm();
        r.joint_error[joint_name(j)] = e;
        r.joint_error_mean += e / kNumJoints;
        if (e > r.joint_error_max) r.joint_error_max = e, r.worst_joint = joint_name(j);
      }
      add_segment_length_errors(our_joints, rig_joints, &r);
    } catch (const InvalidInput& e) {
      r.segment_error = e.what();
    }
  }

  flag_silent_nonsense(orientation.warnings.empty(), &r);
  r.seconds = t0.seconds();
  return r;
}

}  // namespace

void flag_silent_nonsense(bool unwarned, BodyResult* result) {
  BodyResult& r = *result;
  if (!r.orientation_right && (r.measured || (r.segmented && !r.by_body_model)) && unwarned)
    r.silent_nonsense.push_back("orientation " + r.orientation + " is wrong, without a warning");
  const std::string passed = r.by_body_model ? "the body model's fit was confident" : "skeleton passed its checks";
  // A joint the fit says it guessed (its part cut off or hidden) is not returned as good.
  std::string worst;
  double worst_error = 0;
  for (const auto& [name, e] : r.joint_error)
    if (e > worst_error && std::find(r.guessed_joints.begin(), r.guessed_joints.end(), name) == r.guessed_joints.end())
      worst = name, worst_error = e;
  if (r.segmented && worst_error > kSilentJoint)
    r.silent_nonsense.push_back(passed + " with the " + worst + " " + std::to_string(static_cast<int>(std::lround(worst_error * 1000))) +
                                " mm off");
  if (r.segmented && r.segmentation_agreement < kSilentAgreement)
    r.silent_nonsense.push_back((r.by_body_model ? passed + "," : std::string("segmentation passed its checks")) +
                                " agreeing with the rig on only " +
                                std::to_string(static_cast<int>(std::lround(100 * r.segmentation_agreement))) + "% of the area");
  for (const auto& [name, e] : r.girth_error)
    if (std::abs(e) > kSilentGirth)
      r.silent_nonsense.push_back(name + " girth returned as measured " + std::to_string(static_cast<int>(std::lround(e * 1000))) +
                                  " mm off");
}

double iso_allowable_girth_error(const std::string& girth) {
  if (girth == "bust") return 0.015;
  if (girth == "waist" || girth == "hip") return 0.012;
  return std::numeric_limits<double>::quiet_NaN();
}

BodyEvaluation evaluate_bodies(const std::string& dir, const BodyEvaluationOptions& o) {
  const Stopwatch t0;
  const fs::path root(dir);
  const fs::path manifest_path = root / "manifest.json";
  if (!fs::is_regular_file(manifest_path))
    throw IoError(dir + ": no manifest.json: not a robustness set (make one with posekit dataset make --robustness)");
  const nlohmann::json manifest = read_json_file(manifest_path.string());
  if (manifest.value("format", "") != "posekit robustness set 1")
    throw IoError(manifest_path.string() + ": format is not 'posekit robustness set 1' (a pose dataset? use posekit eval pose)");
  std::unique_ptr<SegmentationPrior> prior;
  if (!o.model_path.empty()) prior = std::make_unique<SegmentationPrior>(segmentation_prior_of(read_pose_model(o.model_path)));
  BodyEvaluation ev;
  for (const auto& v : manifest.at("variations"))
    if (o.only.empty() || std::find(o.only.begin(), o.only.end(), v.at("name").get<std::string>()) != o.only.end())
      ev.variations.push_back(v.at("name").get<std::string>());
  std::vector<nlohmann::json> entries;
  for (const auto& b : manifest.at("bodies"))
    if (std::find(ev.variations.begin(), ev.variations.end(), b.at("variation").get<std::string>()) != ev.variations.end())
      entries.push_back(b);
  for (size_t k = 0; k < entries.size(); ++k) {
    try {
      ev.bodies.push_back(evaluate_body(root, entries[k], prior.get(), o.body_model));
    } catch (const nlohmann::json::exception& e) {
      throw IoError(dir + ": the truth of " + entries[k].value("name", "?") + " is malformed (" + e.what() + ")");
    }
    if (o.progress) o.progress(static_cast<int>(k + 1), static_cast<int>(entries.size()), ev.bodies.back().name);
  }
  ev.seconds = t0.seconds();
  return ev;
}

}  // namespace posekit
