#pragma once
// Internal helpers shared by the readers: line scanning and number parsing with file:line errors.
#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <ostream>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "posekit/core/error.h"

namespace posekit::io_detail {

inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\v' || c == '\f'; }

inline std::string_view trim(std::string_view s) {
  while (!s.empty() && (is_space(s.front()) || s.front() == '\n')) s.remove_prefix(1);
  while (!s.empty() && (is_space(s.back()) || s.back() == '\n')) s.remove_suffix(1);
  return s;
}

/// Splits on blanks into `out` (cleared first).
inline void split(std::string_view s, std::vector<std::string_view>& out) {
  out.clear();
  size_t i = 0;
  while (i < s.size()) {
    while (i < s.size() && is_space(s[i])) ++i;
    size_t j = i;
    while (j < s.size() && !is_space(s[j])) ++j;
    if (j > i) out.push_back(s.substr(i, j - i));
    i = j;
  }
}

/// Parses a whole token as a number: decimal or scientific, a leading '+' allowed, nan/inf kept.
inline bool parse_double(std::string_view token, double& value) {
  if (token.size() > 1 && token.front() == '+' && token[1] != '+' && token[1] != '-') token.remove_prefix(1);
  const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
  return ec == std::errc() && ptr == token.data() + token.size();
}

/// Writes `value * scale` as text with as many significant digits as the shortest exact text of
/// `value` has: a change of unit by a power of ten adds no rounding noise (0.0453607 m is written
/// 45.3607 mm, not 45.360699999999994), and at scale 1 the text reads back to the same double.
inline void put_number(std::ostream& out, double value, double scale = 1.0) {
  char buf[64];
  if (scale == 1.0) {
    const auto r = std::to_chars(buf, buf + sizeof(buf), value);
    out.write(buf, r.ptr - buf);
    return;
  }
  const auto shortest = std::to_chars(buf, buf + sizeof(buf), value, std::chars_format::scientific);
  int digits = 0;
  for (const char* p = buf; p < shortest.ptr && *p != 'e'; ++p) digits += (*p >= '0' && *p <= '9');
  const double scaled = value * scale;
  const double magnitude = std::abs(scaled);
  const int exponent = magnitude > 0 ? static_cast<int>(std::floor(std::log10(magnitude))) : 0;
  const auto r = exponent >= -5 && exponent < 16
                     ? std::to_chars(buf, buf + sizeof(buf), scaled, std::chars_format::fixed, std::max(0, digits - 1 - exponent))
                     : std::to_chars(buf, buf + sizeof(buf), scaled, std::chars_format::general, digits);
  out.write(buf, r.ptr - buf);
}

/// Writes a float32 value (PCD fields stored as float) with the shortest text that reads back to it,
/// not the 17 digits of its double widening (0.1f is "0.1", not "0.10000000149011612").
inline void put_number(std::ostream& out, float value) {
  char buf[32];
  const auto r = std::to_chars(buf, buf + sizeof(buf), value);
  out.write(buf, r.ptr - buf);
}

/// True when float32 holds coordinates to `tolerance` (in the file's unit): none moves by more.
template <typename Values>
bool float_keeps_coordinates(const Values& values, double scale, double tolerance) {
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values(i) * scale;
    if (std::abs(v - static_cast<double>(static_cast<float>(v))) > tolerance) return false;
  }
  return true;
}

/// True when float32 holds a scalar field: no finite value moves by more than a millionth of the
/// field's spread (max - min), none leaves float32's normal range, and a field of whole numbers
/// (labels, indices) keeps every value exactly. A distance in mm or a normal keeps all that matters;
/// a field of large values that vary little (a scanner's GPS time, 1.7e9 s give or take a minute)
/// stays float64.
template <typename Values>
bool float_keeps_field(const Values& values) {
  bool whole = true;
  double lo = std::numeric_limits<double>::infinity(), hi = -lo;
  for (Eigen::Index i = 0; i < values.size(); ++i) {
    const double v = values(i);
    if (!std::isfinite(v)) continue;
    const double a = std::abs(v);
    if (a > std::numeric_limits<float>::max() || (a > 0 && a < std::numeric_limits<float>::min())) return false;
    whole = whole && v == std::floor(v);
    lo = std::min(lo, v), hi = std::max(hi, v);
  }
  const double tolerance = whole || !(hi > lo) ? 0.0 : 1e-6 * (hi - lo);
  for (Eigen::Index i = 0; i < values.size(); ++i)
    if (std::isfinite(values(i)) && std::abs(static_cast<double>(static_cast<float>(values(i))) - values(i)) > tolerance) return false;
  return true;
}

/// Appends a reader's or writer's warning where the caller asked for them (nullptr: nowhere).
inline void warn(std::vector<std::string>* sink, std::string message) {
  if (sink) sink->push_back(std::move(message));
}

inline std::string printable(std::string_view s) {
  std::string out;
  for (char c : s.substr(0, 40)) out += (c >= 32 && c < 127) ? c : '?';
  if (s.size() > 40) out += "...";
  return out;
}

/// Walks a text buffer line by line and knows the current line number for error messages.
class LineScanner {
 public:
  LineScanner(std::string_view text, std::string file) : text_(text), file_(std::move(file)) {}

  /// Next line without its terminator; false at the end.
  bool next(std::string_view& line) {
    if (pos_ >= text_.size()) return false;
    const size_t end = text_.find('\n', pos_);
    const size_t stop = end == std::string_view::npos ? text_.size() : end;
    line = text_.substr(pos_, stop - pos_);
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    pos_ = stop + 1;
    ++line_;
    return true;
  }
  size_t offset() const { return pos_ > text_.size() ? text_.size() : pos_; }
  long line_number() const { return line_; }
  const std::string& file() const { return file_; }

  [[noreturn]] void fail(const std::string& what) const { throw IoError(file_ + ":" + std::to_string(line_) + ": " + what); }
  double to_double(std::string_view token, const char* what) const {
    double value = 0;
    if (!parse_double(token, value)) fail(std::string("expected a number for ") + what + ", got '" + printable(token) + "'");
    return value;
  }
  long long to_int(std::string_view token, const char* what) const {
    long long value = 0;
    if (!token.empty() && token.front() == '+') token.remove_prefix(1);
    const auto [ptr, ec] = std::from_chars(token.data(), token.data() + token.size(), value);
    if (ec != std::errc() || ptr != token.data() + token.size())
      fail(std::string("expected an integer for ") + what + ", got '" + printable(token) + "'");
    return value;
  }

 private:
  std::string_view text_;
  std::string file_;
  size_t pos_ = 0;
  long line_ = 0;
};

/// Bounds-checked reader of binary values, optionally byte-swapped.
class ByteReader {
 public:
  ByteReader(const char* begin, const char* end, bool swap) : p_(begin), end_(end), swap_(swap) {}
  template <typename T>
  bool read(T& value) {
    if (static_cast<size_t>(end_ - p_) < sizeof(T)) return false;
    char bytes[sizeof(T)];
    std::memcpy(bytes, p_, sizeof(T));
    if (swap_)
      for (size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(bytes[i], bytes[sizeof(T) - 1 - i]);
    std::memcpy(&value, bytes, sizeof(T));
    p_ += sizeof(T);
    return true;
  }
  bool skip(size_t n) {
    if (static_cast<size_t>(end_ - p_) < n) return false;
    p_ += n;
    return true;
  }
  size_t remaining() const { return static_cast<size_t>(end_ - p_); }
  const char* position() const { return p_; }

 private:
  const char* p_;
  const char* end_;
  bool swap_;
};

inline bool host_is_little_endian() {
  const std::uint16_t one = 1;
  char first;
  std::memcpy(&first, &one, 1);
  return first == 1;
}

/// Lower-cased extension with the dot, e.g. ".ply".
std::string lower_extension(const std::string& path);

}  // namespace posekit::io_detail
