#include "arscout/util/geodesy.h"

#include <algorithm>
#include <cmath>
#include <numbers>

namespace arscout::util {

double great_circle_m(double lat1, double lon1, double lat2, double lon2) {
  constexpr double kRad = std::numbers::pi / 180;
  const double dlat = (lat2 - lat1) * kRad, dlon = (lon2 - lon1) * kRad;
  const double a = std::sin(dlat / 2) * std::sin(dlat / 2) +
                   std::cos(lat1 * kRad) * std::cos(lat2 * kRad) *
                       std::sin(dlon / 2) * std::sin(dlon / 2);
  return 2 * kEarthMeanRadiusM * std::asin(std::min(1.0, std::sqrt(a)));
}

}  // namespace arscout::util
