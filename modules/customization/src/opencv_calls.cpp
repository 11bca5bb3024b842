#include "opencv_calls.h"

#include "posekit/core/plugin.h"

namespace posekit::opencv_calls {
namespace {

/// The plugin's entry point `symbol`, resolved once.
template <class Function>
Function* entry(const char* symbol) {
  return plugin_function<Function>("photo", symbol);
}

}  // namespace

Mlp load_mlp(const std::string& text) {
  static auto* const load = entry<void(const std::string&, Mlp*)>("posekit_load_mlp");
  Mlp mlp;
  load(text, &mlp);
  return mlp;
}

Eigen::VectorXd predict_mlp(const Mlp& mlp, const Eigen::VectorXd& input) {
  static auto* const predict = entry<void(const Mlp&, const Eigen::VectorXd&, Eigen::VectorXd*)>("posekit_predict_mlp");
  Eigen::VectorXd out;
  predict(mlp, input, &out);
  return out;
}

Mlp train_mlp(const Eigen::MatrixXd& inputs, const Eigen::MatrixXd& targets, int hidden, int iterations, int seed) {
  using Train = void(const Eigen::MatrixXd&, const Eigen::MatrixXd&, int, int, int, Mlp*);
  static auto* const train = entry<Train>("posekit_train_mlp");
  Mlp mlp;
  train(inputs, targets, hidden, iterations, seed, &mlp);
  return mlp;
}

std::string mlp_text(const Mlp& mlp) {
  static auto* const text = entry<void(const Mlp&, std::string*)>("posekit_mlp_text");
  std::string out;
  text(mlp, &out);
  return out;
}

Silhouette morph_silhouette(const Silhouette& s, bool erode, int px) {
  static auto* const morph = entry<void(const Silhouette&, bool, int, Silhouette*)>("posekit_morph_silhouette");
  Silhouette out;
  morph(s, erode, px, &out);
  return out;
}

void add_gaussian_noise(Image8* photo, unsigned seed, double sigma) {
  static auto* const noise = entry<void(Image8*, unsigned, double)>("posekit_add_gaussian_noise");
  noise(photo, seed, sigma);
}

}  // namespace posekit::opencv_calls
