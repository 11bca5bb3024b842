#pragma once
// The model files' binary encoding (.pkm, .pks): values as they lie in memory (little-endian on
// every platform posekit builds for), written to a stream and read back with bounds checks whose
// errors name the file, the element and the kind of file. Implementation detail of the readers
// and writers; not part of the public API.
#include <Eigen/Core>
#include <cstring>
#include <ostream>
#include <string>
#include <utility>

#include "posekit/core/error.h"

namespace posekit::io_detail {

template <typename T>
void put(std::ostream& os, const T& value) {
  os.write(reinterpret_cast<const char*>(&value), sizeof(T));
}

/// A matrix row by row.
template <typename Matrix>
void put_matrix(std::ostream& os, const Matrix& M) {
  for (Eigen::Index r = 0; r < M.rows(); ++r)
    for (Eigen::Index c = 0; c < M.cols(); ++c) put(os, M(r, c));
}

/// Reads the values of a file's bytes in order; `kind` (".pkm model", ".pks") ends the errors'
/// question "(truncated <kind>?)".
class BinaryReader {
 public:
  BinaryReader(std::string bytes, std::string path, std::string kind)
      : bytes_(std::move(bytes)), path_(std::move(path)), kind_(std::move(kind)) {}

  template <typename T>
  T get(const char* what) {
    if (pos_ + sizeof(T) > bytes_.size()) throw IoError(path_ + ": the file ends inside " + what + " (truncated " + kind_ + "?)");
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  /// `count` values of T, checked against the bytes left before anything is written.
  template <typename T>
  void values(T* out, size_t count, const char* what) {
    if (count == 0) return;  // (an empty vector's data() may be null, which memcpy must not get)
    check_left(static_cast<double>(count) * sizeof(T), std::to_string(count) + " values", what);
    std::memcpy(out, bytes_.data() + pos_, count * sizeof(T));
    pos_ += count * sizeof(T);
  }
  /// A rows x cols matrix written by put_matrix, checked before it is allocated (a corrupt count
  /// costs no memory).
  template <typename Scalar>
  Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> matrix(Eigen::Index rows, Eigen::Index cols, const char* what) {
    check_left(static_cast<double>(sizeof(Scalar)) * static_cast<double>(rows) * static_cast<double>(cols),
               std::to_string(rows) + " x " + std::to_string(cols) + " values", what);
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic> M(rows, cols);
    for (Eigen::Index r = 0; r < rows; ++r)
      for (Eigen::Index c = 0; c < cols; ++c) M(r, c) = get<Scalar>(what);
    return M;
  }
  size_t left() const { return bytes_.size() - pos_; }
  bool at_end() const { return pos_ == bytes_.size(); }

 private:
  void check_left(double bytes, const std::string& declared, const char* what) const {
    if (bytes > static_cast<double>(bytes_.size() - pos_))
      throw IoError(path_ + ": the file ends inside " + what + " (" + declared + " declared; truncated or corrupt " + kind_ + "?)");
  }

  std::string bytes_, path_, kind_;
  size_t pos_ = 0;
};

}  // namespace posekit::io_detail
