#pragma once
#include <Eigen/Core>
#include <string>

namespace posekit {

/// Length units found in body files. Inside the library everything is metres.
enum class Unit { kMetre, kDecimetre, kCentimetre, kMillimetre };

/// Metres per one `unit` (e.g. 0.001 for mm).
double metres_per_unit(Unit unit);

/// Parses "m", "dm", "cm", "mm" (also "metre(s)", "meter(s)", "millimetre(s)", ...).
/// Throws InvalidInput naming the accepted spellings.
Unit parse_unit(const std::string& text);

/// Short name: "m", "dm", "cm", "mm".
std::string unit_name(Unit unit);

/// Guess of the unit a human body file was written in from its largest bounding-box extent
/// (a standing adult is 1.4-2.1 m). Returns false when the extent fits no unit.
bool guess_body_unit(double largest_extent, Unit* unit);

/// A body's largest extent, robust to a scanner's stray points: the largest 0.5th-to-99.5th
/// percentile range of the coordinates (#P x 3) along an axis. 0 for no points. Over 200,000 points
/// it looks at 200,000 of them, evenly spread through the rows (a 10M-point scan in milliseconds).
double robust_largest_extent(const Eigen::MatrixXd& P);

}  // namespace posekit
