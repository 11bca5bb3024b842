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

/// PNG (lossless) and JPEG (`quality` 1-100) encodings of an image. Throws InvalidInput when the
/// pixels do not match the size and channels.
std::vector<std::uint8_t> encode_png(const Image8& image);
std::vector<std::uint8_t> encode_jpeg(const Image8& image, int quality);

/// Writes a PNG atomically (write_file_atomically).
void write_png(const std::string& path, const Image8& image);

}  // namespace posekit
