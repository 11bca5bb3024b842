#include "posekit/core/units.h"

#include <algorithm>
#include <cctype>
#include <vector>

#include "posekit/core/error.h"

namespace posekit {

double metres_per_unit(Unit unit) {
  switch (unit) {
    case Unit::kMetre:
      return 1.0;
    case Unit::kDecimetre:
      return 0.1;
    case Unit::kCentimetre:
      return 0.01;
    case Unit::kMillimetre:
      return 0.001;
  }
  return 1.0;
}

Unit parse_unit(const std::string& text) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "m" || t == "metre" || t == "metres" || t == "meter" || t == "meters") return Unit::kMetre;
  if (t == "dm" || t == "decimetre" || t == "decimetres" || t == "decimeter" || t == "decimeters") return Unit::kDecimetre;
  if (t == "cm" || t == "centimetre" || t == "centimetres" || t == "centimeter" || t == "centimeters") return Unit::kCentimetre;
  if (t == "mm" || t == "millimetre" || t == "millimetres" || t == "millimeter" || t == "millimeters") return Unit::kMillimetre;
  throw InvalidInput("unknown unit '" + text + "': expected one of m, dm, cm, mm");
}

std::string unit_name(Unit unit) {
  switch (unit) {
    case Unit::kMetre:
      return "m";
    case Unit::kDecimetre:
      return "dm";
    case Unit::kCentimetre:
      return "cm";
    case Unit::kMillimetre:
      return "mm";
  }
  return "m";
}

bool guess_body_unit(double largest_extent, Unit* unit) {
  for (Unit u : {Unit::kMetre, Unit::kDecimetre, Unit::kCentimetre, Unit::kMillimetre}) {
    const double metres = largest_extent * metres_per_unit(u);
    if (metres >= 0.5 && metres <= 3.0) {
      *unit = u;
      return true;
    }
  }
  return false;
}

double robust_largest_extent(const Eigen::MatrixXd& P) {
  double extent = 0;
  constexpr Eigen::Index kSample = 200000;
  const Eigen::Index stride = (P.rows() + kSample - 1) / kSample;
  for (Eigen::Index axis = 0; axis < P.cols() && P.rows() > 0; ++axis) {
    std::vector<double> values;
    values.reserve(static_cast<size_t>(P.rows() / stride + 1));
    for (Eigen::Index i = 0; i < P.rows(); i += stride) values.push_back(P(i, axis));
    const auto at = [&](double fraction) {
      auto nth = values.begin() + static_cast<long>(fraction * static_cast<double>(values.size() - 1));
      std::nth_element(values.begin(), nth, values.end());
      return *nth;
    };
    extent = std::max(extent, at(0.995) - at(0.005));
  }
  return extent;
}

}  // namespace posekit
