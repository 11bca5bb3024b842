#pragma once
// A whole file's bytes, read-only, without copying them.
#include <string>
#include <string_view>

namespace posekit::io_detail {

/// The bytes of a file, memory-mapped (pages come straight from the page cache: no 24 MB buffer to
/// zero and copy into for a 1M-point scan), or read into memory where mapping fails (pipes, special
/// files). Throws IoError naming the file when it cannot be opened or read.
class MappedFile {
 public:
  explicit MappedFile(const std::string& path);
  ~MappedFile();
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::string_view bytes() const { return {data_, size_}; }

 private:
  const char* data_ = nullptr;
  size_t size_ = 0;
  void* mapping_ = nullptr;  ///< what munmap takes, or null when the bytes are in `copy_`
  std::string copy_;
};

}  // namespace posekit::io_detail
