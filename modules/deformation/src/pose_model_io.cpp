// The .pkm model file (format in the README): reading, writing, and the checks a reader needs.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

#include "posekit/core/error.h"
#include "posekit/deformation/pose_model.h"
#include "posekit/deformation/rigid_pose.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/checksum.h"
#include "posekit/io/detail/binary_stream.h"

namespace posekit {

// ---- .pkm files ----
namespace {

constexpr char kMagic[8] = {'P', 'O', 'S', 'E', 'K', 'P', 'K', 'M'};
/// 2 adds the segmentation prior, 3 a CRC-32 of everything before it at the end, 4 the learned joint
/// offsets after the prior, 5 the per-triangle training residuals after the offsets; 1 to 4 are still read.
constexpr std::uint32_t kVersion = 5;

using io_detail::put;
using io_detail::put_matrix;
using Reader = io_detail::BinaryReader;

SegmentationPrior read_segmentation_prior(Reader& in, const std::string& path) {
  SegmentationPrior prior;
  const auto count = in.get<std::uint32_t>("the segmentation prior");
  prior.neighbours = in.get<std::int32_t>("the segmentation prior");
  if (count > 100000u || prior.neighbours < 1 || prior.neighbours > 100000)
    throw IoError(path + ": implausible segmentation prior (" + std::to_string(count) + " bodies, " + std::to_string(prior.neighbours) +
                  " neighbours)");
  Eigen::Index label_count = -1;
  std::vector<Eigen::Index> region_sizes;
  for (std::uint32_t b = 0; b < count; ++b) {
    CalibrationBody body;
    const auto regions = in.get<std::uint32_t>("the segmentation prior");
    if (regions != kShapeRegions)
      throw IoError(path + ": calibration body " + std::to_string(b) + " has " + std::to_string(regions) + " shape regions, expected " +
                    std::to_string(kShapeRegions));
    for (std::uint32_t r = 0; r < regions; ++r) {
      const auto n = in.get<std::uint32_t>("the segmentation prior");
      if (n > 10000000u) throw IoError(path + ": implausible shape descriptor of " + std::to_string(n) + " values");
      body.shape.region.push_back(in.matrix<float>(n, 1, "a calibration body's shape"));
      if (!body.shape.region.back().allFinite())
        throw IoError(path + ": calibration body " + std::to_string(b) + " has a NaN or infinite shape value");
    }
    const auto labels = in.get<std::uint32_t>("the segmentation prior");
    if (labels > 10000000u) throw IoError(path + ": implausible count of " + std::to_string(labels) + " representation labels");
    body.labels = in.matrix<std::uint8_t>(labels, 1, "a calibration body's labels");
    if (labels > 0 && body.labels.maxCoeff() >= kNumParts)
      throw IoError(path + ": calibration body " + std::to_string(b) + " has a part label outside [0, 16)");
    // All bodies share one representation topology.
    std::vector<Eigen::Index> sizes;
    for (const auto& r : body.shape.region) sizes.push_back(r.size());
    if (label_count < 0) label_count = body.labels.size(), region_sizes = sizes;
    if (body.labels.size() != label_count || sizes != region_sizes)
      throw IoError(path + ": calibration body " + std::to_string(b) + " has another representation size than body 0");
    CtffdParametrization& j = body.skeleton.joints;
    j.triangle = in.matrix<std::int32_t>(kNumJoints, 1, "a calibration skeleton").cast<int>();
    j.bary = in.matrix<double>(kNumJoints, 3, "a calibration skeleton");
    j.offset = in.matrix<double>(kNumJoints, 3, "a calibration skeleton");
    body.skeleton.torso_fraction = in.matrix<double>(3, 1, "a calibration skeleton");
    if (j.triangle.minCoeff() < 0 || j.triangle.maxCoeff() >= label_count || !j.bary.allFinite() || !j.offset.allFinite() ||
        !body.skeleton.torso_fraction.allFinite())
      throw IoError(path + ": calibration body " + std::to_string(b) + " has an invalid skeleton");
    prior.bodies.push_back(std::move(body));
  }
  return prior;
}

}  // namespace

void write_pose_model(const std::string& path, const PoseModel& model) {
  std::string bytes = pose_model_bytes(model);
  bytes.resize(bytes.size() - 4);  // write_file_with_crc32 appends the same trailer
  write_file_with_crc32(path, bytes);
}

std::string pose_model_bytes(const PoseModel& model) {
  std::ostringstream os(std::ios::binary);
  {
    os.write(kMagic, sizeof(kMagic));
    put(os, kVersion);
    put(os, static_cast<std::uint32_t>(model.template_V.rows()));
    put(os, static_cast<std::uint32_t>(model.template_F.rows()));
    put(os, static_cast<std::uint32_t>(kNumJoints));
    put(os, static_cast<std::uint32_t>(kPoseCoefficients));
    put(os, static_cast<std::int32_t>(model.training_poses));
    put(os, model.fit_rms);
    put_matrix(os, model.template_V);
    put_matrix(os, Eigen::Matrix<std::int32_t, Eigen::Dynamic, Eigen::Dynamic>(model.template_F.cast<std::int32_t>()));
    put_matrix(os, Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1>(model.triangle_part.cast<std::int32_t>()));
    put_matrix(os, model.joint_centres);
    put_matrix(os, Eigen::Matrix<std::int32_t, Eigen::Dynamic, Eigen::Dynamic>(model.triangle_joints.cast<std::int32_t>()));
    put_matrix(os, model.coefficients);
    const SegmentationPrior& prior = model.segmentation_prior;
    put(os, static_cast<std::uint32_t>(prior.bodies.size()));
    put(os, static_cast<std::int32_t>(prior.neighbours));
    for (const CalibrationBody& body : prior.bodies) {
      put(os, static_cast<std::uint32_t>(body.shape.region.size()));
      for (const Eigen::VectorXf& r : body.shape.region) {
        put(os, static_cast<std::uint32_t>(r.size()));
        put_matrix(os, r);
      }
      put(os, static_cast<std::uint32_t>(body.labels.size()));
      put_matrix(os, body.labels);
      const CtffdParametrization& j = body.skeleton.joints;
      put_matrix(os, Eigen::Matrix<std::int32_t, Eigen::Dynamic, 1>(j.triangle.cast<std::int32_t>()));
      put_matrix(os, j.bary);
      put_matrix(os, j.offset);
      put_matrix(os, body.skeleton.torso_fraction);
    }
    put(os, static_cast<std::uint32_t>(model.joint_offsets.rows()));
    put_matrix(os, model.joint_offsets);
    put(os, static_cast<std::uint32_t>(model.triangle_rms.size()));
    put_matrix(os, model.triangle_rms);
  }
  std::string bytes = os.str();
  const std::uint32_t crc = crc32(bytes.data(), bytes.size());
  bytes.append(reinterpret_cast<const char*>(&crc), sizeof crc);
  return bytes;
}

PoseModel read_pose_model(const std::string& path) { return pose_model_from_bytes(read_file_bytes(path), path); }

PoseModel pose_model_from_bytes(std::string bytes, const std::string& path) {
  std::uint32_t version = 0;
  if (bytes.size() >= sizeof(kMagic) + 4) std::memcpy(&version, bytes.data() + sizeof(kMagic), 4);
  if (bytes.size() < sizeof(kMagic) + 4 || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    throw IoError(path + ": not a posekit pose model (expected the POSEKPKM header of a .pkm file)");
  if (version < 1 || version > kVersion)
    throw IoError(path + ": .pkm version " + std::to_string(version) + ", this posekit reads versions 1 to " + std::to_string(kVersion));
  if (version >= 3) {
    // The trailer covers every byte before it: a flipped bit anywhere is refused before it is used.
    std::uint32_t stored = 0;
    if (bytes.size() < sizeof(kMagic) + 8) throw IoError(path + ": the file ends inside the header (truncated .pkm model?)");
    std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
    if (stored != crc32(bytes.data(), bytes.size() - 4))
      throw IoError(path + ": .pkm checksum mismatch (the file is corrupt, truncated or was changed after it was written)");
    bytes.resize(bytes.size() - 4);
  }
  Reader in(std::move(bytes), path, ".pkm model");
  for (size_t k = 0; k < sizeof(kMagic); ++k) in.get<char>("the header");
  in.get<std::uint32_t>("the header");  // the version, read above
  const auto nv = in.get<std::uint32_t>("the header"), nf = in.get<std::uint32_t>("the header");
  const auto nj = in.get<std::uint32_t>("the header"), nc = in.get<std::uint32_t>("the header");
  if (nj != kNumJoints || nc != kPoseCoefficients || nv < 3 || nf < 1 || nv > 50000000u || nf > 100000000u)
    throw IoError(path + ": implausible .pkm header (" + std::to_string(nv) + " vertices, " + std::to_string(nf) + " triangles, " +
                  std::to_string(nj) + " joints, " + std::to_string(nc) + " coefficients)");
  PoseModel m;
  m.training_poses = in.get<std::int32_t>("the header");
  m.fit_rms = in.get<double>("the header");
  if (m.training_poses < 0 || !std::isfinite(m.fit_rms) || m.fit_rms < 0)
    throw IoError(path + ": implausible .pkm header (" + std::to_string(m.training_poses) + " training poses, fit RMS " +
                  std::to_string(m.fit_rms) + ")");
  m.template_V = in.matrix<double>(nv, 3, "the template vertices");
  m.template_F = in.matrix<std::int32_t>(nf, 3, "the template triangles").cast<int>();
  m.triangle_part = in.matrix<std::int32_t>(nf, 1, "the part labels").cast<int>();
  m.joint_centres = in.matrix<double>(nj, 3, "the joint centres");
  m.triangle_joints = in.matrix<std::int32_t>(nf, 2, "the triangle joints").cast<int>();
  m.coefficients = in.matrix<double>(nf, nc, "the coefficients");  // row-major copy
  if (version >= 2) m.segmentation_prior = read_segmentation_prior(in, path);
  if (version >= 4) {
    const auto rows = in.get<std::uint32_t>("the joint offsets");
    if (rows != 0 && rows != kNumJoints)
      throw IoError(path + ": " + std::to_string(rows) + " rows of joint offsets, expected 0 or " + std::to_string(kNumJoints));
    m.joint_offsets = in.matrix<double>(rows, rows ? 3 * kOffsetFeatures : 0, "the joint offsets");
  }
  if (version >= 5) {
    const auto count = in.get<std::uint32_t>("the triangle residuals");
    if (count != 0 && count != nf)
      throw IoError(path + ": " + std::to_string(count) + " triangle residuals, expected 0 or " + std::to_string(nf));
    m.triangle_rms = in.matrix<double>(count, 1, "the triangle residuals");
  }
  if (!in.at_end())
    throw IoError(path + ": unexpected bytes after the " +
                  (version >= 5   ? "triangle residuals"
                   : version >= 4 ? "joint offsets"
                   : version >= 2 ? "segmentation prior"
                                  : "coefficients"));
  if (!m.template_V.allFinite() || !m.joint_centres.allFinite() || !m.coefficients.allFinite() || !m.joint_offsets.allFinite() ||
      !m.triangle_rms.allFinite())
    throw IoError(path + ": the model holds a NaN or infinite value");
  if (m.triangle_rms.size() && m.triangle_rms.minCoeff() < 0) throw IoError(path + ": a triangle residual is negative");
  if (m.template_F.minCoeff() < 0 || m.template_F.maxCoeff() >= static_cast<int>(nv))
    throw IoError(path + ": a template triangle refers to a vertex outside [0, " + std::to_string(nv) + ")");
  if (m.triangle_part.minCoeff() < 0 || m.triangle_part.maxCoeff() >= kNumParts) throw IoError(path + ": a part label is outside [0, 16)");
  if (m.triangle_joints.minCoeff() < -1 || m.triangle_joints.maxCoeff() >= kNumJoints)
    throw IoError(path + ": a triangle joint is outside [-1, 15)");
  return m;
}

}  // namespace posekit
