#include "mapped_file.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>

#include "posekit/core/error.h"
#include "posekit/io/atomic_file.h"

namespace posekit::io_detail {

MappedFile::MappedFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  struct stat st {};
  if (fd >= 0 && ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_size > 0) {
    // MAP_POPULATE: the pages mapped in one call, not faulted in one by one.
    void* m = ::mmap(nullptr, static_cast<size_t>(st.st_size), PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
    if (m != MAP_FAILED) {
      ::close(fd);
      mapping_ = m;
      data_ = static_cast<const char*>(m);
      size_ = static_cast<size_t>(st.st_size);
      return;
    }
  }
  if (fd >= 0) ::close(fd);
  copy_ = read_file_bytes(path);  // names the file and the reason when it cannot be read
  data_ = copy_.data();
  size_ = copy_.size();
}

MappedFile::~MappedFile() {
  if (mapping_) ::munmap(mapping_, size_);
}

}  // namespace posekit::io_detail
