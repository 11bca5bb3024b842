#include "posekit/io/atomic_file.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <streambuf>
#include <vector>

#include "posekit/core/error.h"

namespace posekit {
namespace fs = std::filesystem;
namespace {

/// A stream buffer over a file descriptor that keeps the errno of the first failed write.
class FdStreamBuffer : public std::streambuf {
 public:
  explicit FdStreamBuffer(int fd) : fd_(fd), buffer_(1 << 16) { setp(buffer_.data(), buffer_.data() + buffer_.size()); }
  int error() const { return error_; }

 protected:
  int_type overflow(int_type ch) override {
    if (!flush_buffer()) return traits_type::eof();
    if (!traits_type::eq_int_type(ch, traits_type::eof())) {
      *pptr() = traits_type::to_char_type(ch);
      pbump(1);
    }
    return traits_type::not_eof(ch);
  }
  int sync() override { return flush_buffer() ? 0 : -1; }

 private:
  bool flush_buffer() {
    const char* p = pbase();
    while (p < pptr() && error_ == 0) {
      const ssize_t n = ::write(fd_, p, static_cast<size_t>(pptr() - p));
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) error_ = n < 0 ? errno : EIO;
      else p += n;
    }
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    return error_ == 0;
  }

  int fd_;
  std::vector<char> buffer_;
  int error_ = 0;
};

std::string host_name() {
  char name[256] = {};
  if (::gethostname(name, sizeof(name) - 1) != 0 || name[0] == '\0') return "host";
  std::string out(name);
  for (char& c : out)
    if (c == '/' || c == '-' || c == ' ') c = '_';
  return out;
}

std::string reason(int error) { return std::strerror(error); }

/// Syncs a folder so that a rename into it survives a power cut (best effort: some filesystems
/// refuse fsync on folders, which changes nothing for the file itself).
void sync_folder(const fs::path& folder) {
  const int fd = ::open(folder.empty() ? "." : folder.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) return;
  ::fsync(fd);
  ::close(fd);
}

struct TemporaryName {
  std::string host;
  long pid = 0;
};

/// Parses "<anything>.tmp-<host>-<pid>-<n>" (or the older "<anything>.tmp-<pid>").
bool parse_temporary_name(const std::string& name, TemporaryName* out) {
  const size_t at = name.rfind(".tmp-");
  if (at == std::string::npos) return false;
  const std::string tail = name.substr(at + 5);
  auto all_digits = [](const std::string& s) {
    return !s.empty() && s.size() < 12 && s.find_first_not_of("0123456789") == std::string::npos;
  };
  if (all_digits(tail)) {
    out->host.clear();
    out->pid = std::stol(tail);
    return true;
  }
  const size_t last = tail.rfind('-');
  if (last == std::string::npos || last == 0) return false;
  const size_t second = tail.rfind('-', last - 1);
  if (second == std::string::npos || second == 0) return false;
  const std::string pid = tail.substr(second + 1, last - second - 1);
  if (!all_digits(pid) || !all_digits(tail.substr(last + 1))) return false;
  out->host = tail.substr(0, second);
  out->pid = std::stol(pid);
  return true;
}

}  // namespace

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write, bool) {
  static std::atomic<unsigned long> counter{0};
  static const std::string host = host_name();
  const std::string tmp = path + ".tmp-" + host + "-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) {
    const int e = errno;
    const fs::path folder = fs::path(path).parent_path();
    std::error_code ec;
    if (e == ENOENT && !folder.empty() && !fs::is_directory(folder, ec))
      throw WriteError(path + ": cannot write: the folder " + folder.string() + " does not exist");
    throw WriteError(path + ": cannot open for writing (" + reason(e) + ")");
  }
  auto discard = [&](int descriptor) {
    if (descriptor >= 0) ::close(descriptor);
    ::unlink(tmp.c_str());
  };
  FdStreamBuffer buffer(fd);
  std::ostream out(&buffer);
  try {
    write(out);
    out.flush();
  } catch (...) {
    discard(fd);
    throw;
  }
  if (!out || buffer.error() != 0) {
    const int e = buffer.error() != 0 ? buffer.error() : EIO;
    discard(fd);
    throw WriteError(path + ": write failed (" + reason(e) + ")");
  }
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) {
    const int e = errno;
    discard(fd);
    throw WriteError(path + ": write failed when syncing to disk (" + reason(e) + ")");
  }
  if (::close(fd) != 0) {
    const int e = errno;
    discard(-1);
    throw WriteError(path + ": write failed when closing (" + reason(e) + ")");
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    discard(-1);
    std::error_code ec;
    if (fs::is_directory(path, ec)) throw WriteError(path + ": is a folder, expected a file name to write");
    throw WriteError(path + ": cannot move the finished temporary file into place (" + reason(e) + ")");
  }
  sync_folder(fs::path(path).parent_path());
}

bool is_atomic_temporary_name(const std::string& name) {
  TemporaryName t;
  return parse_temporary_name(name, &t);
}

int remove_stale_temporaries(const std::string& folder) {
  static const std::string host = host_name();
  std::error_code ec;
  int removed = 0;
  for (fs::directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    TemporaryName t;
    const std::string name = it->path().filename().string();
    if (!parse_temporary_name(name, &t) || !it->is_regular_file(ec)) continue;
    bool stale = false;
    if (t.host.empty() || t.host == host) {
      stale = t.pid != static_cast<long>(::getpid()) && ::kill(static_cast<pid_t>(t.pid), 0) != 0 && errno == ESRCH;
    } else {
      const auto age = fs::file_time_type::clock::now() - fs::last_write_time(it->path(), ec);
      stale = !ec && age > std::chrono::hours(24);
    }
    std::error_code remove_ec;
    if (stale && fs::remove(it->path(), remove_ec)) ++removed;
  }
  return removed;
}

std::string read_file_bytes(const std::string& path) {
  std::error_code ec;
  if (fs::is_directory(path, ec)) throw IoError(path + ": is a directory, expected a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw IoError(path + ": cannot open (" + std::strerror(errno) + ")");
  in.seekg(0, std::ios::end);
  const std::streamoff size = in.tellg();
  if (size < 0) throw IoError(path + ": cannot determine the file size");
  std::string bytes(static_cast<size_t>(size), '\0');
  in.seekg(0);
  if (size > 0 && !in.read(bytes.data(), size)) throw IoError(path + ": read failed");
  return bytes;
}

void create_folders(const std::string& folder) {
  if (folder.empty()) return;
  std::error_code ec;
  fs::create_directories(folder, ec);
  if (ec) throw WriteError(folder + ": cannot create the folder (" + ec.message() + ")");
  if (!fs::is_directory(folder, ec)) throw WriteError(folder + ": exists and is not a folder");
}

void require_output_folder(const std::string& path, bool make_folder) {
  const fs::path folder = fs::path(path).parent_path();
  if (folder.empty()) return;
  std::error_code ec;
  if (fs::is_directory(folder, ec)) return;
  if (fs::exists(folder, ec)) throw WriteError(path + ": " + folder.string() + " is not a folder");
  if (!make_folder) throw WriteError(path + ": the folder " + folder.string() + " does not exist (create it first, or pass --mkdir)");
  create_folders(folder.string());
}

void write_folder_atomically(const std::string& folder, bool replace, const std::function<void(const std::string&)>& build) {
  const fs::path out = fs::absolute(folder).lexically_normal();
  std::error_code ec;
  if (fs::exists(out, ec) && !replace) throw IoError(out.string() + ": already exists (choose another --out or pass --force)");
  const fs::path tmp = out.string() + ".tmp-" + std::to_string(::getpid());
  fs::remove_all(tmp, ec);
  if (!fs::create_directories(tmp, ec) || ec) throw IoError(tmp.string() + ": cannot create the output folder (" + ec.message() + ")");
  try {
    build(tmp.string());
    if (fs::exists(out, ec)) fs::remove_all(out);
    fs::rename(tmp, out);
  } catch (...) {
    fs::remove_all(tmp, ec);
    throw;
  }
}

}  // namespace posekit
