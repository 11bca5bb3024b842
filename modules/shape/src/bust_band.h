#pragma once
// Internal to posekit_shape: the bust band, the same for the features and the measurements.

namespace posekit {
namespace shape_detail {

constexpr double kBustBelowArmpits = 0.01;  ///< m: the bust band ends this far below the arms' separation
constexpr double kBustPlateau = 0.003;      ///< m of girth: levels this close to the fullest count as the bust

}  // namespace shape_detail
}  // namespace posekit
