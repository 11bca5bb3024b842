// The .pks shape space file: magic, version, sizes, population text, triangles, variance shares,
// mean and basis (little-endian doubles), and a CRC-32 of everything before it.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <sstream>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"
#include "posekit/io/checksum.h"
#include "posekit/io/detail/binary_stream.h"
#include "posekit/registration/shape_space.h"

namespace posekit {
namespace {

constexpr char kMagic[8] = {'P', 'O', 'S', 'E', 'K', 'P', 'K', 'S'};
// Version 2 adds the joints (a count, then their mean and basis), version 3 the poses (a count and a
// row width, then each pose's name length, name and row); older versions are still read.
constexpr std::uint32_t kVersion = 3;

using io_detail::put;
using Reader = io_detail::BinaryReader;

}  // namespace

void write_shape_space(const std::string& path, const ShapeSpace& s) {
  const Eigen::Index nv = s.mean.rows(), K = s.basis.cols();
  if (s.mean.cols() != 3 || s.basis.rows() != 3 * nv || static_cast<Eigen::Index>(s.variance_share.size()) != K ||
      (s.faces.size() > 0 && s.faces.cols() != 3) ||
      (s.has_joints() && (s.joint_mean.cols() != 3 || s.joint_basis.rows() != 3 * s.joint_mean.rows() || s.joint_basis.cols() != K)))
    throw InvalidInput("write_shape_space: inconsistent space (" + std::to_string(nv) + " vertices, basis " +
                       std::to_string(s.basis.rows()) + " x " + std::to_string(K) + ")");
  if (static_cast<size_t>(s.poses.rows()) != s.pose_names.size())
    throw InvalidInput("write_shape_space: " + std::to_string(s.poses.rows()) + " poses and " + std::to_string(s.pose_names.size()) +
                       " names");
  std::ostringstream os(std::ios::binary);
  os.write(kMagic, sizeof(kMagic));
  put(os, kVersion);
  put(os, static_cast<std::uint32_t>(nv));
  put(os, static_cast<std::uint32_t>(K));
  put(os, static_cast<std::uint32_t>(s.faces.rows()));
  put(os, static_cast<std::int32_t>(s.bodies));
  put(os, static_cast<std::uint32_t>(s.population.size()));
  os.write(s.population.data(), static_cast<std::streamsize>(s.population.size()));
  for (Eigen::Index f = 0; f < s.faces.rows(); ++f)
    for (int c = 0; c < 3; ++c) put(os, static_cast<std::int32_t>(s.faces(f, c)));
  for (double v : s.variance_share) put(os, v);
  for (Eigen::Index i = 0; i < nv; ++i)
    for (int c = 0; c < 3; ++c) put(os, s.mean(i, c));
  for (Eigen::Index k = 0; k < K; ++k)
    os.write(reinterpret_cast<const char*>(s.basis.col(k).data()), static_cast<std::streamsize>(3 * nv * sizeof(double)));
  put(os, static_cast<std::uint32_t>(s.joint_mean.rows()));
  for (Eigen::Index j = 0; j < s.joint_mean.rows(); ++j)
    for (int c = 0; c < 3; ++c) put(os, s.joint_mean(j, c));
  for (Eigen::Index k = 0; k < s.joint_basis.cols(); ++k)
    for (Eigen::Index r = 0; r < s.joint_basis.rows(); ++r) put(os, s.joint_basis(r, k));
  put(os, static_cast<std::uint32_t>(s.poses.rows()));
  put(os, static_cast<std::uint32_t>(s.poses.cols()));
  for (Eigen::Index p = 0; p < s.poses.rows(); ++p) {
    const std::string& name = s.pose_names[static_cast<size_t>(p)];
    put(os, static_cast<std::uint32_t>(name.size()));
    os.write(name.data(), static_cast<std::streamsize>(name.size()));
    for (Eigen::Index c = 0; c < s.poses.cols(); ++c) put(os, s.poses(p, c));
  }
  write_file_with_crc32(path, os.str());
}

ShapeSpace read_shape_space(const std::string& path) {
  std::string bytes = read_file_bytes(path);
  if (bytes.size() < sizeof(kMagic) + 8 || std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0)
    throw IoError(path + ": not a posekit shape space (expected the POSEKPKS header of a .pks file)");
  std::uint32_t stored = 0;
  std::memcpy(&stored, bytes.data() + bytes.size() - 4, 4);
  if (stored != crc32(bytes.data(), bytes.size() - 4))
    throw IoError(path + ": .pks checksum mismatch (the file is corrupt, truncated or was changed after it was written)");
  bytes.resize(bytes.size() - 4);
  Reader in(std::move(bytes), path, ".pks");
  for (size_t k = 0; k < sizeof(kMagic); ++k) in.get<char>("the header");
  const auto version = in.get<std::uint32_t>("the header");
  if (version < 1 || version > kVersion)
    throw IoError(path + ": .pks version " + std::to_string(version) + ", this posekit reads versions 1 to " + std::to_string(kVersion));
  const auto nv = in.get<std::uint32_t>("the header"), K = in.get<std::uint32_t>("the header");
  const auto nf = in.get<std::uint32_t>("the header");
  ShapeSpace s;
  s.bodies = in.get<std::int32_t>("the header");
  const auto text = in.get<std::uint32_t>("the header");
  // Every section's size against the bytes there are, before anything is allocated.
  const double left = static_cast<double>(in.left());
  if (nv < 3 || K < 1 || K > 100000u || s.bodies < 2 || text > in.left() || 12.0 * nf > left || 24.0 * nv * (1.0 + K) > left)
    throw IoError(path + ": implausible .pks header (" + std::to_string(nv) + " vertices, " + std::to_string(K) + " components, " +
                  std::to_string(s.bodies) + " bodies)");
  s.population.resize(text);
  in.values(s.population.data(), text, "the population");
  s.faces.resize(nf, 3);
  std::vector<std::int32_t> faces(static_cast<size_t>(nf) * 3);
  in.values(faces.data(), faces.size(), "the triangles");
  for (size_t i = 0; i < faces.size(); ++i) {
    if (faces[i] < 0 || faces[i] >= static_cast<std::int32_t>(nv))
      throw IoError(path + ": triangle " + std::to_string(i / 3) + " names vertex " + std::to_string(faces[i]) + ", the space has " +
                    std::to_string(nv));
    s.faces(static_cast<Eigen::Index>(i / 3), static_cast<Eigen::Index>(i % 3)) = faces[i];
  }
  s.variance_share.resize(K);
  in.values(s.variance_share.data(), K, "the variance shares");
  Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> mean(nv, 3);
  in.values(mean.data(), static_cast<size_t>(nv) * 3, "the mean body");
  s.mean = mean;
  const double basis_bytes = static_cast<double>(nv) * 3 * K * sizeof(double);
  if (version == 1 ? basis_bytes != static_cast<double>(in.left()) : basis_bytes + 4 > static_cast<double>(in.left()))
    throw IoError(path + ": the basis of " + std::to_string(K) + " components of " + std::to_string(nv) +
                  " vertices does not fit the rest of the file (" + std::to_string(in.left()) + " bytes)");
  s.basis.resize(3 * static_cast<Eigen::Index>(nv), K);
  in.values(s.basis.data(), static_cast<size_t>(nv) * 3 * K, "the basis");
  if (version >= 2) {
    const auto nj = in.get<std::uint32_t>("the joint count");
    const double joint_bytes = static_cast<double>(nj) * 24 * (1.0 + K);
    if (version == 2 ? joint_bytes != static_cast<double>(in.left()) : joint_bytes + 8 > static_cast<double>(in.left()))
      throw IoError(path + ": the joints (" + std::to_string(nj) + " of them, " + std::to_string(K) +
                    " components) do not fill the rest of the file (" + std::to_string(in.left()) + " bytes)");
    Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::RowMajor> joint_mean(nj, 3);
    in.values(joint_mean.data(), static_cast<size_t>(nj) * 3, "the joints' mean");
    s.joint_mean = joint_mean;
    s.joint_basis.resize(3 * static_cast<Eigen::Index>(nj), K);
    in.values(s.joint_basis.data(), static_cast<size_t>(nj) * 3 * K, "the joints' basis");
  }
  if (version >= 3) {
    const auto np = in.get<std::uint32_t>("the pose count"), width = in.get<std::uint32_t>("the pose count");
    // The width is the joints' (or 0 with no poses): a wild width with no poses made a 0 x 3.5e9
    // matrix that took a minute to check (found by fuzz_pks).
    if (static_cast<double>(np) * (4.0 + 8.0 * width) > static_cast<double>(in.left()) ||
        (width != 3 * (1 + s.joint_mean.rows()) && (np > 0 || width != 0)))
      throw IoError(path + ": implausible poses section (" + std::to_string(np) + " poses of " + std::to_string(width) + " values, " +
                    std::to_string(s.joint_mean.rows()) + " joints)");
    s.poses.resize(np, width);
    for (std::uint32_t p = 0; p < np; ++p) {
      const auto length = in.get<std::uint32_t>("a pose's name");
      if (length > in.left()) throw IoError(path + ": pose " + std::to_string(p) + "'s name runs past the end of the file");
      std::string name(length, '\0');
      in.values(name.data(), length, "a pose's name");
      s.pose_names.push_back(std::move(name));
      Eigen::RowVectorXd row(width);
      in.values(row.data(), width, "a pose");
      s.poses.row(p) = row;
    }
    if (in.left() != 0) throw IoError(path + ": " + std::to_string(in.left()) + " bytes after the poses (a newer .pks?)");
  }
  if (!s.mean.allFinite() || !s.basis.allFinite() || !s.joint_mean.allFinite() || !s.joint_basis.allFinite() || !s.poses.allFinite() ||
      !std::all_of(s.variance_share.begin(), s.variance_share.end(), [](double v) { return std::isfinite(v); }))
    throw IoError(path + ": the shape space holds a NaN or infinite value");
  return s;
}

}  // namespace posekit
