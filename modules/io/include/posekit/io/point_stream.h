#pragma once
// A large binary point cloud read piece by piece, for scans too large to hold whole (a 10M-point scan
// compared within twice its file's size).
#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

namespace posekit {

/// The coordinates of a binary PLY point cloud (its first element 'vertex', fixed-size properties)
/// or a PCD with DATA binary, read from the file by ranges of points, in file order. Points with a
/// NaN or infinite coordinate are left out, as read_point_cloud leaves them out, so index i is the
/// i-th point read_point_cloud would return, with the same coordinates to the bit.
class PointStream {
 public:
  /// Null when `path` is not such a file (ascii, compressed, a mesh, a header this reader does not
  /// take, a truncated file): read it whole with read_point_cloud, which explains what is wrong.
  /// `scale` multiplies every coordinate (file unit -> metres). One pass counts the finite points;
  /// `warnings` receives read_point_cloud's note when some are left out.
  static std::unique_ptr<PointStream> open(const std::string& path, double scale, std::vector<std::string>* warnings);
  ~PointStream();
  PointStream(const PointStream&) = delete;
  PointStream& operator=(const PointStream&) = delete;

  Eigen::Index size() const;  ///< finite points
  /// Points [first, first + count) into P (count x 3). Thread-safe.
  void read(Eigen::Index first, Eigen::Index count, Eigen::MatrixXd* P) const;
  /// Lets the system drop the file's pages up to point `end` from this process's memory (they stay
  /// in the page cache); read() still works on them.
  void release(Eigen::Index end) const;

 private:
  struct Impl;
  explicit PointStream(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

}  // namespace posekit
