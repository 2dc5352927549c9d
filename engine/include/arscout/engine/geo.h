// Geography: WGS84 fixes and the site's local east-north-up (ENU) frame.
// A site's metric frame is ENU at an origin fixed when the site's first fix
// arrives (GeographicLib's LocalCartesian on the WGS84 ellipsoid), so every
// model coordinate is metres east, north and up of that origin.
#pragma once

#include <array>
#include <optional>

#include "arscout/documents/gps.h"

namespace arscout::engine {

// One GPS fix. Accuracies are 1-sigma metres; a missing altitude is treated
// as unknown (vertical weight zero).
struct GeoFix {
  double lat = 0;
  double lon = 0;
  std::optional<double> alt;  // ellipsoidal height, metres
  double h_acc = 5.0;         // horizontal, per axis
  double v_acc = 10.0;
};

// A stored fix (a capture's `gps`, a GPS file's row) as the engine weighs
// it: accuracies the receiver did not report get GeoFix's defaults (a
// consumer receiver's, docs/engine.md). The one conversion.
GeoFix geo_fix_of(const documents::GpsFix& gps);

struct Geodetic {
  double lat = 0;
  double lon = 0;
  double alt = 0;
};

class EnuFrame {
 public:
  EnuFrame() = default;
  explicit EnuFrame(const Geodetic& origin) : origin_(origin) {}
  const Geodetic& origin() const { return origin_; }
  std::array<double, 3> to_enu(const Geodetic& point) const;
  Geodetic to_geodetic(const std::array<double, 3>& enu) const;
  // Earth-centred, earth-fixed coordinates of a point given in this frame.
  std::array<double, 3> to_ecef(const std::array<double, 3>& enu) const;

 private:
  Geodetic origin_;
};

}  // namespace arscout::engine
