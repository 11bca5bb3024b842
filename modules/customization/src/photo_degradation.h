#pragma once
// Degradations the photo evaluations share (internal).
#include "posekit/io/image_io.h"

namespace posekit {

/// A separable Gaussian blur of every channel, sigma in pixels (lens blur).
void blur_image(Image8* image, double sigma);

}  // namespace posekit
