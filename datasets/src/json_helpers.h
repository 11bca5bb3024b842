#pragma once
// Internal to posekit_datasets: small helpers shared by the dataset writers.

#include <Eigen/Core>
#include <cmath>
#include <nlohmann/json.hpp>

namespace posekit {
namespace datasets_detail {

constexpr double kDeg = M_PI / 180.0;

/// A point as a JSON array [x, y, z].
inline nlohmann::ordered_json vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace datasets_detail
}  // namespace posekit
