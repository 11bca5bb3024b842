#pragma once
// The customization module's calls into its OpenCV half, the "photo" plugin (posekit/core/plugin.h):
// OpenCV is loaded only by what reads, trains on or degrades photos. Internal to the module.
#include <Eigen/Core>
#include <memory>
#include <string>

#include "posekit/customization/silhouette.h"
#include "posekit/io/image_io.h"

namespace posekit::opencv_calls {

/// An OpenCV ANN_MLP (a layer model of section 3.2), opaque outside the plugin.
using Mlp = std::shared_ptr<void>;

/// The MLP saved as `text` (OpenCV's YAML); null when the text holds no trained MLP.
Mlp load_mlp(const std::string& text);
/// One row of standardized inputs through the MLP (evaluated in single precision, as trained).
Eigen::VectorXd predict_mlp(const Mlp& mlp, const Eigen::VectorXd& input);
/// An MLP with one hidden layer (symmetric sigmoid, RPROP) trained on rows of `inputs` -> `targets`;
/// `seed` seeds OpenCV's generator first, so training is repeatable.
Mlp train_mlp(const Eigen::MatrixXd& inputs, const Eigen::MatrixXd& targets, int hidden, int iterations, int seed);
/// The MLP as OpenCV's YAML text (what load_mlp reads).
std::string mlp_text(const Mlp& mlp);

/// The mask eroded or dilated by a disc of radius `px`.
Silhouette morph_silhouette(const Silhouette& s, bool erode, int px);
/// Gaussian noise of deviation `sigma` grey levels on every channel (seeded), saturated to 0..255.
void add_gaussian_noise(Image8* photo, unsigned seed, double sigma);

}  // namespace posekit::opencv_calls
