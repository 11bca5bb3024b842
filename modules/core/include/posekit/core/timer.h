#pragma once
// Wall-clock time of a piece of work and of its stages, on a steady clock.
#include <chrono>
#include <string>
#include <utility>
#include <vector>

namespace posekit {

/// Seconds since it was made (or restarted).
class Stopwatch {
 public:
  double seconds() const { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count(); }
  void restart() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

/// Seconds from `from` to `to` (time points of stages timed in a row).
inline double seconds_between(std::chrono::steady_clock::time_point from, std::chrono::steady_clock::time_point to) {
  return std::chrono::duration<double>(to - from).count();
}

/// Seconds per named stage, in the order the stages first ended: lap(stage) charges the time since
/// the last lap (or since it was made) to `stage`, added up over a stage's repeats.
class StageTimer {
 public:
  void lap(const std::string& stage) {
    const double s = since_lap_.seconds();
    since_lap_.restart();
    for (auto& [name, seconds] : stages_)
      if (name == stage) return void(seconds += s);
    stages_.emplace_back(stage, s);
  }
  const std::vector<std::pair<std::string, double>>& stages() const { return stages_; }

 private:
  Stopwatch since_lap_;
  std::vector<std::pair<std::string, double>> stages_;
};

}  // namespace posekit
