// PNG and JPEG through libpng and libjpeg: the pixels OpenCV's imread gives (OpenCV's codecs serve
// as the independent reference here), EXIF orientation, and clear errors.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "posekit/core/error.h"
#include "posekit/io/image_io.h"
#include "testing/temp_dir.h"

using namespace posekit;

namespace {

/// A smooth BGR test card with sharp edges (JPEG keeps it close) and every channel distinct.
Image8 test_card(int w, int h) {
  Image8 im{w, h, 3, std::vector<std::uint8_t>(static_cast<size_t>(w) * h * 3)};
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      std::uint8_t* p = &im.pixels[(static_cast<size_t>(y) * w + x) * 3];
      p[0] = static_cast<std::uint8_t>(255 * x / (w - 1));
      p[1] = static_cast<std::uint8_t>(255 * y / (h - 1));
      p[2] = static_cast<std::uint8_t>((x < w / 2) == (y < h / 2) ? 40 : 220);
    }
  return im;
}

std::string as_string(const std::vector<std::uint8_t>& b) { return std::string(b.begin(), b.end()); }

/// Same size and pixels as OpenCV's cv::imdecode of the same bytes.
void expect_as_opencv(const std::string& bytes, ImageColor color) {
  const Image8 mine = decode_image(bytes, color, "test");
  const cv::Mat theirs = cv::imdecode(std::vector<std::uint8_t>(bytes.begin(), bytes.end()),
                                      color == ImageColor::kGray ? cv::IMREAD_GRAYSCALE : cv::IMREAD_COLOR);
  ASSERT_EQ(mine.width, theirs.cols);
  ASSERT_EQ(mine.height, theirs.rows);
  ASSERT_EQ(mine.channels, theirs.channels());
  ASSERT_TRUE(theirs.isContinuous());
  int worst = 0;
  for (size_t k = 0; k < mine.pixels.size(); ++k) worst = std::max(worst, std::abs(mine.pixels[k] - theirs.data[k]));
  EXPECT_LE(worst, 1) << "largest difference from OpenCV's decoding";
}

}  // namespace

TEST(ImageIo, PngRoundTripsExactly) {
  const Image8 card = test_card(37, 23);
  const Image8 back = decode_image(as_string(encode_png(card)), ImageColor::kBgr, "card");
  EXPECT_EQ(back.width, 37);
  EXPECT_EQ(back.height, 23);
  EXPECT_EQ(back.pixels, card.pixels);
  Image8 gray{5, 3, 1, {0, 1, 2, 3, 4, 50, 60, 70, 80, 90, 200, 210, 220, 230, 255}};
  EXPECT_EQ(decode_image(as_string(encode_png(gray)), ImageColor::kGray, "gray").pixels, gray.pixels);
}

TEST(ImageIo, DecodesAsOpenCvDoes) {
  const Image8 card = test_card(64, 48);
  // PNG and JPEG written by OpenCV, read in colour and in gray.
  std::vector<std::uint8_t> png, jpg, gray_jpg;
  const cv::Mat m(card.height, card.width, CV_8UC3, const_cast<std::uint8_t*>(card.pixels.data()));
  ASSERT_TRUE(cv::imencode(".png", m, png));
  ASSERT_TRUE(cv::imencode(".jpg", m, jpg, {cv::IMWRITE_JPEG_QUALITY, 80}));
  cv::Mat g(card.height, card.width, CV_8UC1);
  for (int k = 0; k < card.width * card.height; ++k) g.data[k] = card.pixels[3 * static_cast<size_t>(k) + 1];
  ASSERT_TRUE(cv::imencode(".jpg", g, gray_jpg));
  for (const auto* bytes : {&png, &jpg, &gray_jpg})
    for (ImageColor c : {ImageColor::kBgr, ImageColor::kGray}) expect_as_opencv(as_string(*bytes), c);
  // posekit's own encodings read back by OpenCV.
  expect_as_opencv(as_string(encode_png(card)), ImageColor::kBgr);
  expect_as_opencv(as_string(encode_jpeg(card, 90)), ImageColor::kBgr);
}

TEST(ImageIo, JpegKeepsTheImageAtHighQuality) {
  const Image8 card = test_card(64, 64);
  const Image8 back = decode_image(as_string(encode_jpeg(card, 95)), ImageColor::kBgr, "card");
  ASSERT_EQ(back.pixels.size(), card.pixels.size());
  double sum = 0;
  for (size_t k = 0; k < card.pixels.size(); ++k) sum += std::abs(back.pixels[k] - card.pixels[k]);
  EXPECT_LT(sum / static_cast<double>(card.pixels.size()), 3.0);
}

TEST(ImageIo, AppliesTheExifOrientation) {
  // 32 x 16: left half black, right half white; stored with orientation 6 (shown turned 90 degrees
  // clockwise) it reads 16 x 32, black on top.
  Image8 im{32, 16, 1, std::vector<std::uint8_t>(32 * 16)};
  for (int y = 0; y < 16; ++y)
    for (int x = 16; x < 32; ++x) im.pixels[static_cast<size_t>(y) * 32 + x] = 255;
  const std::vector<std::uint8_t> plain = encode_jpeg(im, 95);
  // An APP1 segment after SOI: "Exif\0\0", a little-endian TIFF header, IFD0 with one entry 0x0112 = 6.
  const std::string tiff = std::string("II*\0", 4) + std::string("\x08\0\0\0", 4) + std::string("\x01\0", 2) +
                           std::string("\x12\x01\x03\0\x01\0\0\0\x06\0\0\0", 12) + std::string("\0\0\0\0", 4);
  const std::string payload = std::string("Exif\0\0", 6) + tiff;
  const size_t length = payload.size() + 2;
  const std::string app1 = std::string("\xFF\xE1", 2) + static_cast<char>(length >> 8) + static_cast<char>(length & 0xFF) + payload;
  const std::string turned = as_string(plain).substr(0, 2) + app1 + as_string(plain).substr(2);
  const Image8 shown = decode_image(turned, ImageColor::kGray, "turned");
  ASSERT_EQ(shown.width, 16);
  ASSERT_EQ(shown.height, 32);
  EXPECT_LT(shown.pixels[static_cast<size_t>(4) * 16 + 8], 30);    // top: the stored left half
  EXPECT_GT(shown.pixels[static_cast<size_t>(28) * 16 + 8], 225);  // bottom: the stored right half
  expect_as_opencv(turned, ImageColor::kGray);
  // Decoded at half size: the stored size turned as well.
  const ReducedImage half = decode_image_reduced(turned, ImageColor::kGray, "turned", [](int w, int h) { return w < h ? 2 : 1; });
  EXPECT_EQ(half.reduction, 2);
  EXPECT_EQ(half.full_width, 16);
  EXPECT_EQ(half.full_height, 32);
  EXPECT_EQ(half.image.width, 8);
  EXPECT_EQ(half.image.height, 16);
}

TEST(ImageIo, AJpegDecodedAtHalfSizeIsItsBlocksMeansAndAPngComesWhole) {
  const Image8 card = test_card(96, 64);
  const std::string jpg = as_string(encode_jpeg(card, 95));
  const ReducedImage half = decode_image_reduced(jpg, ImageColor::kBgr, "card", [](int, int) { return 2; });
  ASSERT_EQ(half.reduction, 2);
  EXPECT_EQ(half.full_width, 96);
  EXPECT_EQ(half.full_height, 64);
  ASSERT_EQ(half.image.width, 48);
  ASSERT_EQ(half.image.height, 32);
  // Each pixel about the mean of its 2 x 2 block of the full decoding (away from the card's sharp
  // quadrant edges, where the IDCT's filter and a box differ most).
  const Image8 full = decode_image(jpg, ImageColor::kBgr, "card");
  double sum = 0;
  int n = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 48; ++x)
      for (int c = 0; c < 3; ++c) {
        if (c == 2 && (std::abs(2 * x - 48) < 4 || std::abs(2 * y - 32) < 4)) continue;
        double mean = 0;
        for (int dy = 0; dy < 2; ++dy)
          for (int dx = 0; dx < 2; ++dx) mean += full.pixels[(static_cast<size_t>(2 * y + dy) * 96 + 2 * x + dx) * 3 + c] / 4.0;
        sum += std::abs(half.image.pixels[(static_cast<size_t>(y) * 48 + x) * 3 + c] - mean), ++n;
      }
  EXPECT_LT(sum / n, 2.0);
  // A reduction the chooser cannot have (3) decodes at full size; a PNG is never reduced.
  EXPECT_EQ(decode_image_reduced(jpg, ImageColor::kBgr, "card", [](int, int) { return 3; }).reduction, 1);
  const ReducedImage png = decode_image_reduced(as_string(encode_png(card)), ImageColor::kBgr, "card", [](int, int) { return 2; });
  EXPECT_EQ(png.reduction, 1);
  EXPECT_EQ(png.image.pixels, card.pixels);
  EXPECT_EQ(png.full_width, 96);
}

TEST(ImageIo, RefusesWhatItCannotRead) {
  test::TempDir dir;
  const std::string bmp = dir.write("photo.bmp", std::string("BM\x36\0\0\0", 6));
  try {
    read_image(bmp, ImageColor::kBgr);
    FAIL() << "a BMP was read";
  } catch (const IoError& e) {
    EXPECT_NE(std::string(e.what()).find("photo.bmp: not a PNG or JPEG"), std::string::npos) << e.what();
  }
  const std::string png = as_string(encode_png(test_card(40, 30)));
  const std::string jpg = as_string(encode_jpeg(test_card(40, 30), 90));
  for (const std::string& cut : {png.substr(0, png.size() / 2), jpg.substr(0, jpg.size() / 2), jpg.substr(0, 20), png.substr(0, 8)})
    EXPECT_THROW(decode_image(cut, ImageColor::kBgr, "cut"), IoError);
  EXPECT_THROW(read_image(dir.file("missing.png"), ImageColor::kGray), IoError);
  EXPECT_THROW(encode_png(Image8{4, 4, 3, std::vector<std::uint8_t>(47)}), InvalidInput);
  EXPECT_THROW(encode_jpeg(Image8{4, 4, 2, std::vector<std::uint8_t>(32)}, 90), InvalidInput);
  EXPECT_THROW(encode_jpeg(test_card(8, 8), 0), InvalidInput);
}
