#include "posekit/io/image_io.h"

#include <png.h>

#include <csetjmp>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <utility>

// jpeglib.h needs size_t and FILE declared first.
#include <jerror.h>
#include <jpeglib.h>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit {
namespace {

bool is_png(const std::string& b) { return b.size() >= 8 && std::memcmp(b.data(), "\x89PNG\r\n\x1a\n", 8) == 0; }
bool is_jpeg(const std::string& b) {
  return b.size() >= 3 && static_cast<unsigned char>(b[0]) == 0xFF && static_cast<unsigned char>(b[1]) == 0xD8;
}

// Gray from blue, green, red as OpenCV's cvtColor does it (weights 0.114, 0.587, 0.299 in 14-bit fixed point).
std::uint8_t gray_of(const std::uint8_t* bgr) {
  return static_cast<std::uint8_t>((bgr[0] * 1868 + bgr[1] * 9617 + bgr[2] * 4899 + 8192) >> 14);
}

Image8 decode_png(const std::string& bytes, ImageColor color, const std::string& what) {
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  if (!png_image_begin_read_from_memory(&png, bytes.data(), bytes.size()))
    throw IoError(what + ": not a readable PNG (" + png.message + ")");
  // Always as 8-bit BGRA: the alpha is then dropped, not composited, as OpenCV does.
  png.format = PNG_FORMAT_BGRA;
  const size_t w = png.width, h = png.height;
  if (w == 0 || h == 0 || w * h > (size_t{1} << 28)) {
    png_image_free(&png);
    throw IoError(what + ": PNG of " + std::to_string(w) + " x " + std::to_string(h) + " pixels (at most 2^28 read)");
  }
  std::vector<std::uint8_t> bgra(w * h * 4);
  if (!png_image_finish_read(&png, nullptr, bgra.data(), 0, nullptr)) throw IoError(what + ": corrupt PNG (" + png.message + ")");
  Image8 out;
  out.width = static_cast<int>(w), out.height = static_cast<int>(h);
  out.channels = color == ImageColor::kGray ? 1 : 3;
  out.pixels.resize(w * h * static_cast<size_t>(out.channels));
  for (size_t p = 0; p < w * h; ++p) {
    const std::uint8_t* q = &bgra[4 * p];
    if (out.channels == 1) out.pixels[p] = gray_of(q);
    else std::memcpy(&out.pixels[3 * p], q, 3);
  }
  return out;
}

struct JpegError {
  jpeg_error_mgr manager;
  std::jmp_buf jump;
  char message[JMSG_LENGTH_MAX];
};

void jpeg_error_exit(j_common_ptr info) {
  auto* e = reinterpret_cast<JpegError*>(info->err);
  (*info->err->format_message)(info, e->message);
  std::longjmp(e->jump, 1);
}

// Warnings (extraneous bytes, say) are not errors, but a file that ends early is: libjpeg would fill
// the missing rows with gray.
void jpeg_warning(j_common_ptr info, int level) {
  if (level < 0 && info->err->msg_code == JWRN_JPEG_EOF) info->err->error_exit(info);
}

/// The EXIF orientation (1-8, 1 when absent) of a JPEG's APP1 marker.
int exif_orientation(const jpeg_decompress_struct& info) {
  for (jpeg_saved_marker_ptr m = info.marker_list; m; m = m->next) {
    if (m->marker != JPEG_APP0 + 1 || m->data_length < 14 || std::memcmp(m->data, "Exif\0\0", 6) != 0) continue;
    const unsigned char* t = m->data + 6;
    const size_t n = m->data_length - 6;
    const bool little = t[0] == 'I' && t[1] == 'I';
    if (!little && !(t[0] == 'M' && t[1] == 'M')) return 1;
    auto u16 = [&](size_t at) -> unsigned { return at + 2 > n ? 0 : little ? t[at] | t[at + 1] << 8 : t[at] << 8 | t[at + 1]; };
    auto u32 = [&](size_t at) -> size_t {
      return at + 4 > n ? n : static_cast<size_t>(u16(little ? at : at + 2)) | static_cast<size_t>(u16(little ? at + 2 : at)) << 16;
    };
    const size_t ifd = u32(4);
    const unsigned entries = u16(ifd);
    for (unsigned k = 0; k < entries; ++k) {
      const size_t e = ifd + 2 + 12 * static_cast<size_t>(k);
      if (e + 12 > n) break;
      if (u16(e) == 0x0112) {
        const unsigned v = u16(e + 8);
        return v >= 1 && v <= 8 ? static_cast<int>(v) : 1;
      }
    }
  }
  return 1;
}

/// The image as shown: `orientation` is the EXIF tag (2-8 mirror and/or turn the stored pixels).
Image8 oriented(const Image8& in, int orientation) {
  if (orientation <= 1) return in;
  const int W = in.width, H = in.height, c = in.channels;
  const bool swap = orientation >= 5;
  Image8 out;
  out.width = swap ? H : W, out.height = swap ? W : H, out.channels = c;
  out.pixels.resize(in.pixels.size());
  for (int y = 0; y < out.height; ++y)
    for (int x = 0; x < out.width; ++x) {
      int sx = x, sy = y;
      switch (orientation) {
        case 2:
          sx = W - 1 - x;
          break;
        case 3:
          sx = W - 1 - x, sy = H - 1 - y;
          break;
        case 4:
          sy = H - 1 - y;
          break;
        case 5:
          sx = y, sy = x;
          break;
        case 6:
          sx = y, sy = H - 1 - x;
          break;
        case 7:
          sx = W - 1 - y, sy = H - 1 - x;
          break;
        case 8:
          sx = W - 1 - y, sy = x;
          break;
        default:
          break;
      }
      std::memcpy(&out.pixels[(static_cast<size_t>(y) * out.width + x) * c], &in.pixels[(static_cast<size_t>(sy) * W + sx) * c],
                  static_cast<size_t>(c));
    }
  return out;
}

/// libjpeg's part of decode_jpeg: no C++ object with a destructor lives in this frame across setjmp.
bool decode_jpeg_raw(const std::string& bytes, bool gray, ReductionChooser choose, Image8* out, std::vector<std::uint8_t>* cmyk_row,
                     int* orientation, int full_size[2], int* reduction, char* message) {
  jpeg_decompress_struct info;
  JpegError error;
  info.err = jpeg_std_error(&error.manager);
  error.manager.error_exit = jpeg_error_exit;
  error.manager.emit_message = jpeg_warning;
  if (setjmp(error.jump)) {
    std::memcpy(message, error.message, JMSG_LENGTH_MAX);
    jpeg_destroy_decompress(&info);
    return false;
  }
  jpeg_create_decompress(&info);
  jpeg_mem_src(&info, reinterpret_cast<const unsigned char*>(bytes.data()), static_cast<unsigned long>(bytes.size()));
  jpeg_save_markers(&info, JPEG_APP0 + 1, 0xFFFF);
  jpeg_read_header(&info, TRUE);
  *orientation = exif_orientation(info);
  full_size[0] = static_cast<int>(info.image_width), full_size[1] = static_cast<int>(info.image_height);
  if (*orientation >= 5) std::swap(full_size[0], full_size[1]);
  *reduction = choose ? choose(full_size[0], full_size[1]) : 1;
  if (*reduction != 2 && *reduction != 4 && *reduction != 8) *reduction = 1;
  info.scale_num = 1, info.scale_denom = static_cast<unsigned>(*reduction);  // the IDCT's own scaling
  const bool cmyk = info.jpeg_color_space == JCS_CMYK || info.jpeg_color_space == JCS_YCCK;
  info.out_color_space = cmyk ? JCS_CMYK : gray ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_start_decompress(&info);
  const size_t w = info.output_width, h = info.output_height, in_channels = static_cast<size_t>(info.output_components);
  if (w * h > (size_t{1} << 28)) {
    std::snprintf(message, JMSG_LENGTH_MAX, "JPEG of %zu x %zu pixels (at most 2^28 read)", w, h);
    jpeg_destroy_decompress(&info);
    return false;
  }
  out->width = static_cast<int>(w), out->height = static_cast<int>(h), out->channels = gray ? 1 : 3;
  out->pixels.resize(w * h * static_cast<size_t>(out->channels));
  std::vector<std::uint8_t>& row = out->pixels;  // decoded in place unless CMYK
  cmyk_row->resize(cmyk ? w * 4 : 0);
  while (info.output_scanline < info.output_height) {
    const size_t y = info.output_scanline;
    JSAMPROW target = cmyk ? cmyk_row->data() : &row[y * w * in_channels];
    jpeg_read_scanlines(&info, &target, 1);
    if (!cmyk) continue;
    for (size_t x = 0; x < w; ++x) {
      // Adobe's inverted CMYK: each ink's value times black's is the colour.
      const std::uint8_t* q = &(*cmyk_row)[4 * x];
      const std::uint8_t bgr[3] = {static_cast<std::uint8_t>(q[2] * q[3] / 255), static_cast<std::uint8_t>(q[1] * q[3] / 255),
                                   static_cast<std::uint8_t>(q[0] * q[3] / 255)};
      if (gray) row[y * w + x] = gray_of(bgr);
      else std::memcpy(&row[3 * (y * w + x)], bgr, 3);
    }
  }
  jpeg_finish_decompress(&info);
  jpeg_destroy_decompress(&info);
  return true;
}

ReducedImage decode_jpeg(const std::string& bytes, ImageColor color, const std::string& what, ReductionChooser choose) {
  ReducedImage out;
  std::vector<std::uint8_t> cmyk_row;
  int orientation = 1, size[2] = {0, 0};
  char message[JMSG_LENGTH_MAX] = {0};
  if (!decode_jpeg_raw(bytes, color == ImageColor::kGray, choose, &out.image, &cmyk_row, &orientation, size, &out.reduction, message))
    throw IoError(what + ": corrupt JPEG (" + message + ")");
  out.image = oriented(out.image, orientation);
  out.full_width = size[0], out.full_height = size[1];
  return out;
}

void check_pixels(const Image8& image) {
  if (image.width <= 0 || image.height <= 0 || (image.channels != 1 && image.channels != 3) ||
      image.pixels.size() != static_cast<size_t>(image.width) * static_cast<size_t>(image.height) * static_cast<size_t>(image.channels))
    throw InvalidInput("image: " + std::to_string(image.pixels.size()) + " bytes for " + std::to_string(image.width) + " x " +
                       std::to_string(image.height) + " pixels of " + std::to_string(image.channels) + " channels (1 or 3 expected)");
}

bool encode_jpeg_raw(const Image8& image, int quality, std::vector<std::uint8_t>* out, char* message) {
  jpeg_compress_struct info;
  JpegError error;
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  info.err = jpeg_std_error(&error.manager);
  error.manager.error_exit = jpeg_error_exit;
  if (setjmp(error.jump)) {
    std::memcpy(message, error.message, JMSG_LENGTH_MAX);
    jpeg_destroy_compress(&info);
    std::free(buffer);
    return false;
  }
  jpeg_create_compress(&info);
  jpeg_mem_dest(&info, &buffer, &size);
  info.image_width = static_cast<JDIMENSION>(image.width), info.image_height = static_cast<JDIMENSION>(image.height);
  info.input_components = image.channels;
  info.in_color_space = image.channels == 1 ? JCS_GRAYSCALE : JCS_EXT_BGR;
  jpeg_set_defaults(&info);
  jpeg_set_quality(&info, quality, TRUE);
  jpeg_start_compress(&info, TRUE);
  const size_t stride = static_cast<size_t>(image.width) * static_cast<size_t>(image.channels);
  while (info.next_scanline < info.image_height) {
    JSAMPROW row = const_cast<JSAMPROW>(&image.pixels[info.next_scanline * stride]);
    jpeg_write_scanlines(&info, &row, 1);
  }
  jpeg_finish_compress(&info);
  out->assign(buffer, buffer + size);
  jpeg_destroy_compress(&info);
  std::free(buffer);
  return true;
}

}  // namespace

Image8 decode_image(const std::string& bytes, ImageColor color, const std::string& what) {
  if (is_png(bytes)) return decode_png(bytes, color, what);
  if (is_jpeg(bytes)) return decode_jpeg(bytes, color, what, nullptr).image;
  throw IoError(what + ": not a PNG or JPEG image (posekit reads these two; convert other formats first)");
}

Image8 read_image(const std::string& path, ImageColor color) { return decode_image(read_file_bytes(path), color, path); }

ReducedImage decode_image_reduced(const std::string& bytes, ImageColor color, const std::string& what, ReductionChooser choose) {
  if (is_jpeg(bytes)) return decode_jpeg(bytes, color, what, choose);
  ReducedImage out;
  out.image = decode_image(bytes, color, what);
  out.full_width = out.image.width, out.full_height = out.image.height;
  return out;
}

ReducedImage read_image_reduced(const std::string& path, ImageColor color, ReductionChooser choose) {
  return decode_image_reduced(read_file_bytes(path), color, path, choose);
}

std::vector<std::uint8_t> encode_png(const Image8& image) {
  check_pixels(image);
  png_image png;
  std::memset(&png, 0, sizeof png);
  png.version = PNG_IMAGE_VERSION;
  png.width = static_cast<png_uint_32>(image.width), png.height = static_cast<png_uint_32>(image.height);
  png.format = image.channels == 1 ? PNG_FORMAT_GRAY : PNG_FORMAT_BGR;
  png_alloc_size_t size = 0;
  if (!png_image_write_to_memory(&png, nullptr, &size, 0, image.pixels.data(), 0, nullptr))
    throw IoError(std::string("PNG encoding failed (") + png.message + ")");
  std::vector<std::uint8_t> out(size);
  if (!png_image_write_to_memory(&png, out.data(), &size, 0, image.pixels.data(), 0, nullptr))
    throw IoError(std::string("PNG encoding failed (") + png.message + ")");
  out.resize(size);
  return out;
}

std::vector<std::uint8_t> encode_jpeg(const Image8& image, int quality) {
  check_pixels(image);
  if (quality < 1 || quality > 100) throw InvalidInput("JPEG quality " + std::to_string(quality) + " (1-100 expected)");
  std::vector<std::uint8_t> out;
  char message[JMSG_LENGTH_MAX] = {0};
  if (!encode_jpeg_raw(image, quality, &out, message)) throw IoError(std::string("JPEG encoding failed (") + message + ")");
  return out;
}

void write_png(const std::string& path, const Image8& image) {
  const std::vector<std::uint8_t> png = encode_png(image);
  write_file_atomically(
      path, [&](std::ostream& os) { os.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size())); });
}

void write_gray_png(const std::string& path, int width, int height, const std::vector<std::uint8_t>& pixels) {
  if (static_cast<size_t>(width) * height != pixels.size()) throw InvalidInput(path + ": image size does not match its pixels");
  write_png(path, Image8{width, height, 1, pixels});
}

std::vector<std::uint8_t> read_gray_png(const std::string& path, int* width, int* height) {
  Image8 image = read_image(path, ImageColor::kGray);
  *width = image.width;
  *height = image.height;
  return std::move(image.pixels);
}

}  // namespace posekit
