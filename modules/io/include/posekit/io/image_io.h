#pragma once
// PNG and JPEG images in memory and on disk (libpng, libjpeg), without OpenCV's codecs and the
// hundred-odd libraries they load at start-up.
#include <cstdint>
#include <string>
#include <vector>

namespace posekit {

/// An 8-bit image: rows top to bottom, channels interleaved: 1 (gray) or 3 (blue, green, red,
/// OpenCV's order, so that a cv::Mat can wrap the pixels as they are).
struct Image8 {
  int width = 0, height = 0, channels = 0;
  std::vector<std::uint8_t> pixels;
};

enum class ImageColor { kGray, kBgr };

/// Decodes a PNG or JPEG (told apart by their signatures) to gray or BGR, as OpenCV's imread does:
/// alpha dropped, 16-bit samples scaled to 8, colour to gray as 0.299 R + 0.587 G + 0.114 B, a
/// JPEG's EXIF orientation applied (phone photos stored sideways come out upright). `what` names the
/// source in errors. Throws IoError for any other format or a corrupt image.
Image8 decode_image(const std::string& bytes, ImageColor color, const std::string& what);

/// Reads and decodes an image file (decode_image); errors name the file.
Image8 read_image(const std::string& path, ImageColor color);

/// An image decoded smaller than it is stored: pixel (u, v) covers the stored pixels
/// [u * reduction, (u + 1) * reduction) x [v * reduction, (v + 1) * reduction).
struct ReducedImage {
  Image8 image;
  int reduction = 1;                    ///< 1: decoded at full size
  int full_width = 0, full_height = 0;  ///< the stored size (EXIF orientation applied)
};

/// Picks the reduction (1, 2, 4 or 8) for an image of the given stored size (EXIF orientation applied).
using ReductionChooser = int (*)(int width, int height);

/// Decodes an image reduced where the format does so while decoding: a JPEG by its inverse DCT at
/// 1/2, 1/4 or 1/8 scale as `choose` says (each pixel about its block's mean; a 12-MP photo at 1/4
/// decodes in a fraction of the time and memory). Other formats come at full size (reduction 1).
ReducedImage decode_image_reduced(const std::string& bytes, ImageColor color, const std::string& what, ReductionChooser choose);
/// Reads and decodes an image file so (decode_image_reduced); errors name the file.
ReducedImage read_image_reduced(const std::string& path, ImageColor color, ReductionChooser choose);

/// PNG (lossless) and JPEG (`quality` 1-100) encodings of an image. Throws InvalidInput when the
/// pixels do not match the size and channels.
std::vector<std::uint8_t> encode_png(const Image8& image);
std::vector<std::uint8_t> encode_jpeg(const Image8& image, int quality);

/// Writes a PNG atomically (write_file_atomically).
void write_png(const std::string& path, const Image8& image);

/// Writes an 8-bit single-channel image as PNG (atomically). Throws IoError.
void write_gray_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& pixels);
/// Reads an 8-bit PNG as gray. Throws IoError naming the file.
std::vector<std::uint8_t> read_gray_png(const std::string& path, int* width, int* height);

}  // namespace posekit
