#include "posekit/shape/feature_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "feature_constants.h"
#include "posekit/body/parts.h"
#include "posekit/core/error.h"

namespace posekit {
namespace {

using namespace shape_detail::fitted;

/// Rows of a least-squares fit: inputs and the value they predict.
struct Rows {
  std::vector<std::vector<double>> x;
  std::vector<double> y;
  void add(const double* inputs, int count, double value) {
    x.emplace_back(inputs, inputs + count);
    y.push_back(value);
  }
};

double rms_mm(const std::vector<double>& residuals) {
  double sum = 0;
  for (double r : residuals) sum += r * r;
  return residuals.empty() ? 0 : 1000 * std::sqrt(sum / static_cast<double>(residuals.size()));
}

RefitConstant least_squares(const std::string& name, const std::string& what, const double* shipped, int count, const Rows& rows) {
  RefitConstant c;
  c.name = name, c.what = what;
  c.shipped.assign(shipped, shipped + count);
  c.samples = static_cast<int>(rows.y.size());
  if (c.samples < count)
    throw InvalidInput("calibration: " + name + " needs at least " + std::to_string(count) + " samples, has " + std::to_string(c.samples));
  Eigen::MatrixXd A(c.samples, count);
  Eigen::VectorXd b(c.samples);
  for (int i = 0; i < c.samples; ++i) {
    for (int k = 0; k < count; ++k) A(i, k) = rows.x[static_cast<size_t>(i)][static_cast<size_t>(k)];
    b[i] = rows.y[static_cast<size_t>(i)];
  }
  const Eigen::VectorXd w = A.colPivHouseholderQr().solve(b);
  c.refit.assign(w.data(), w.data() + count);
  const Eigen::VectorXd old = Eigen::Map<const Eigen::VectorXd>(shipped, count);
  const Eigen::VectorXd r_old = A * old - b, r_new = A * w - b;
  c.shipped_rms_mm = rms_mm(std::vector<double>(r_old.data(), r_old.data() + r_old.size()));
  c.refit_rms_mm = rms_mm(std::vector<double>(r_new.data(), r_new.data() + r_new.size()));
  return c;
}

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

/// An offset (lateral, up, forward) from `points` to `truths`, the lateral component signed toward
/// each side's outside.
RefitConstant median_offset(const std::string& name, const std::string& what, const double (&shipped)[3],
                            const std::vector<Eigen::Vector3d>& offsets) {
  RefitConstant c;
  c.name = name, c.what = what, c.fit = "median";
  c.shipped.assign(shipped, shipped + 3);
  c.samples = static_cast<int>(offsets.size());
  if (offsets.empty()) throw InvalidInput("calibration: no samples for " + name);
  for (int k = 0; k < 3; ++k) {
    std::vector<double> component;
    for (const auto& o : offsets) component.push_back(o[k]);
    c.refit.push_back(median(component));
  }
  std::vector<double> r_old, r_new;
  for (const auto& o : offsets) {
    r_old.push_back((o - Eigen::Vector3d(shipped[0], shipped[1], shipped[2])).norm());
    r_new.push_back((o - Eigen::Vector3d(c.refit[0], c.refit[1], c.refit[2])).norm());
  }
  c.shipped_rms_mm = rms_mm(r_old), c.refit_rms_mm = rms_mm(r_new);
  return c;
}

/// A scalar's median, with the RMS error of what it places: (value - constant) * scale each.
RefitConstant scalar_median(const std::string& name, const std::string& what, double shipped, const std::vector<double>& values,
                            const std::vector<double>& scales) {
  RefitConstant c;
  c.name = name, c.what = what, c.fit = "median";
  c.shipped = {shipped};
  c.samples = static_cast<int>(values.size());
  if (values.empty()) throw InvalidInput("calibration: no samples for " + name);
  c.refit = {median(values)};
  std::vector<double> r_old, r_new;
  for (size_t i = 0; i < values.size(); ++i)
    r_old.push_back((values[i] - shipped) * scales[i]), r_new.push_back((values[i] - c.refit[0]) * scales[i]);
  c.shipped_rms_mm = rms_mm(r_old), c.refit_rms_mm = rms_mm(r_new);
  return c;
}

Eigen::Vector3d joint(const FeatureCalibrationSample& s, const std::string& name) {
  return s.joints.row(find_joint_index(name)).transpose();
}

}  // namespace

std::vector<RefitConstant> refit_feature_constants(const std::vector<FeatureCalibrationSample>& samples) {
  Rows neck, shoulder[3], knee, hip[3];
  std::vector<double> neck_forward, head_fraction, head_span, head_forward, beyond_narrowest, path_fraction, path_length;
  std::vector<Eigen::Vector3d> knee_offsets, ankle_offsets, elbow_offsets, wrist_offsets;
  for (const FeatureCalibrationSample& s : samples) {
    if (s.joints.rows() != kNumJoints || s.joints.cols() != 3)
      throw InvalidInput("calibration: a sample has " + std::to_string(s.joints.rows()) + " joints, expected " +
                         std::to_string(kNumJoints));
    const FeatureRegressors& r = s.regressors;
    if (r.neck) {
      const Eigen::Vector3d truth = joint(s, "neck");
      neck.add(r.neck_inputs.data(), 4, truth.y() - r.neck_widening_y);
      neck_forward.push_back(truth.z() - r.neck_base.z());
    }
    if (r.neck && r.head) {
      head_span.push_back(r.crown_y - r.neck_base.y());
      head_fraction.push_back((s.head.y() - r.neck_base.y()) / head_span.back());
      head_forward.push_back(s.head.z() - r.head_centre.z());
    }
    for (int side : {kLeft, kRight}) {
      const std::string prefix = side == kLeft ? "left_" : "right_";
      const double outward = side == kLeft ? 1.0 : -1.0;
      if (r.shoulder[side]) {
        const Eigen::Vector3d d = joint(s, prefix + "shoulder") - r.shoulder_origin[side];
        const double values[3] = {outward * d.x(), d.y(), d.z()};
        for (int k = 0; k < 3; ++k) shoulder[k].add(r.shoulder_inputs[side].data(), 6, values[k]);
      }
      if (r.arm[side]) {
        const Eigen::Vector3d de = joint(s, prefix + "elbow") - r.elbow_point[side], dw = joint(s, prefix + "wrist") - r.wrist_point[side];
        elbow_offsets.emplace_back(outward * de.x(), de.y(), de.z());
        wrist_offsets.emplace_back(outward * dw.x(), dw.y(), dw.z());
      }
      if (r.forearm[side])
        beyond_narrowest.push_back((joint(s, prefix + "wrist") - r.narrowest_forearm[side]).dot(r.forearm_direction[side]));
      {
        const Eigen::Vector3d sh = joint(s, prefix + "shoulder"), el = joint(s, prefix + "elbow"), wr = joint(s, prefix + "wrist");
        const double length = (el - sh).norm() + (wr - el).norm();
        if (length > 1e-6) path_length.push_back(length), path_fraction.push_back((el - sh).norm() / length);
      }
      if (r.leg[side]) {
        const Eigen::Vector3d knee_truth = joint(s, prefix + "knee"), ankle_truth = joint(s, prefix + "ankle");
        const double inputs[2] = {r.knee_hollow_y[side] - r.knee_fraction_y[side], r.leg_length[side]};
        knee.add(inputs, 2, knee_truth.y() - r.knee_fraction_y[side]);
        const Eigen::Vector3d dk = knee_truth - r.knee_point[side], da = ankle_truth - r.ankle_point[side];
        knee_offsets.emplace_back(outward * dk.x(), dk.y(), dk.z());
        ankle_offsets.emplace_back(outward * da.x(), da.y(), da.z());
      }
      if (r.hips) {
        const Eigen::Vector3d d = joint(s, prefix + "hip") - r.crotch;
        const double values[3] = {d.y(), outward * d.dot(r.hip_lateral), d.dot(r.hip_forward)};
        for (int k = 0; k < 3; ++k) hip[k].add(r.hip_inputs.data(), 4, values[k]);
      }
    }
  }
  std::vector<RefitConstant> out;
  out.push_back(least_squares("kNeckJointFromBase", "neck joint height above the neck's widening", kNeckJointFromBase, 4, neck));
  {
    const double shipped[3] = {0, 0, kNeckJointForward};
    std::vector<Eigen::Vector3d> offsets;
    for (double z : neck_forward) offsets.emplace_back(0, 0, z);
    RefitConstant c = median_offset("kNeckJointForward", "neck joint depth from the neck base's centroid", shipped, offsets);
    c.shipped = {kNeckJointForward}, c.refit = {c.refit[2]};
    out.push_back(c);
  }
  if (!head_fraction.empty()) {
    out.push_back(scalar_median("kHeadJointFraction", "head joint height, as a fraction of the neck base to the crown", kHeadJointFraction,
                                head_fraction, head_span));
    out.push_back(scalar_median("kHeadJointForward", "head joint depth from the head section's centroid", kHeadJointForward, head_forward,
                                std::vector<double>(head_forward.size(), 1.0)));
  }
  out.push_back(median_offset("kElbowOffset", "elbow joint from the arm axis's kink", kElbowOffset, elbow_offsets));
  out.push_back(
      median_offset("kWristOffset", "wrist joint from beyond the narrowest horizontal forearm section", kWristOffset, wrist_offsets));
  out.push_back(scalar_median("kWristBeyondNarrowestSection", "wrist joint beyond the narrowest perpendicular forearm section",
                              kWristBeyondNarrowestSection, beyond_narrowest, std::vector<double>(beyond_narrowest.size(), 1.0)));
  if (!path_fraction.empty()) {
    // The rig's own proportion, averaged (a prior, not a regression): the error is along the arm.
    RefitConstant c = scalar_median("kElbowPathFraction", "elbow's fraction of the shoulder-elbow-wrist path (the mean)",
                                    kElbowPathFraction, path_fraction, path_length);
    double mean = 0;
    for (double v : path_fraction) mean += v / static_cast<double>(path_fraction.size());
    std::vector<double> r_new;
    for (size_t i = 0; i < path_fraction.size(); ++i) r_new.push_back((path_fraction[i] - mean) * path_length[i]);
    c.refit = {mean}, c.refit_rms_mm = rms_mm(r_new), c.fit = "mean";
    out.push_back(c);
  }
  const char* axes[3] = {"lateral", "up", "forward"};
  const double* shoulder_shipped[3] = {kShoulderFromSection.lateral, kShoulderFromSection.up, kShoulderFromSection.forward};
  for (int k = 0; k < 3; ++k)
    out.push_back(least_squares(std::string("kShoulderFromSection.") + axes[k], std::string("shoulder joint, ") + axes[k],
                                shoulder_shipped[k], 6, shoulder[k]));
  const double knee_shipped[2] = {kKneeTowardHollow, kKneeShift};
  out.push_back(least_squares("kKneeTowardHollow, kKneeShift", "knee joint height above the fraction estimate", knee_shipped, 2, knee));
  out.push_back(median_offset("kKneeOffset", "knee joint from the leg axis at its level", kKneeOffset, knee_offsets));
  out.push_back(median_offset("kAnkleOffset", "ankle joint from the narrowest shank section", kAnkleOffset, ankle_offsets));
  const char* hip_names[3] = {"kHipUp", "kHipLateral", "kHipForward"};
  const double* hip_shipped[3] = {kHipUp, kHipLateral, kHipForward};
  for (int k = 0; k < 3; ++k)
    out.push_back(least_squares(hip_names[k],
                                std::string("hip joint from the crotch, ") + axes[k == 0   ? 1
                                                                                  : k == 1 ? 0
                                                                                           : 2],
                                hip_shipped[k], 4, hip[k]));
  return out;
}

std::string refit_constants_as_cpp(const std::vector<RefitConstant>& constants) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(4);
  for (const RefitConstant& c : constants) {
    out << "// " << c.name << ": " << c.what << " (" << c.samples << " samples; RMS " << std::setprecision(1) << c.refit_rms_mm
        << " mm, shipped " << c.shipped_rms_mm << " mm)\n"
        << std::setprecision(4);
    out << c.name << " = {";
    for (size_t k = 0; k < c.refit.size(); ++k) out << (k ? ", " : "") << c.refit[k];
    out << "};\n";
  }
  return out.str();
}

}  // namespace posekit
