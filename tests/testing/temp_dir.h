#pragma once
#include <string>

namespace posekit::test {

/// A fresh folder under the system temp dir, removed with everything in it on destruction.
class TempDir {
 public:
  TempDir();
  ~TempDir();
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  const std::string& path() const { return path_; }
  std::string file(const std::string& name) const { return path_ + "/" + name; }
  /// Writes `bytes` to file(name) and returns its path.
  std::string write(const std::string& name, const std::string& bytes) const;
  /// Number of entries in the folder.
  int count() const;

 private:
  std::string path_;
};

/// The MakeHuman data root for tests (POSEKIT_DATA, set by CTest), or "" when absent.
std::string test_data_root();

}  // namespace posekit::test
