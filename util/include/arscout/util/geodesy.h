// Distances on the Earth for deciding what is near what (site placement,
// the store's `near` queries). Not for geometry: the engine's frames use
// GeographicLib on the WGS84 ellipsoid (engine/geo.h).
#pragma once

namespace arscout::util {

// The WGS84 mean radius (IUGG R1), metres.
inline constexpr double kEarthMeanRadiusM = 6371008.8;

// Great-circle (haversine) distance in metres between two WGS84 positions
// in degrees, on the sphere of the mean radius: within 0.5 % of the
// ellipsoidal distance, exact for identical points, stable for small ones.
double great_circle_m(double lat1, double lon1, double lat2, double lon2);

}  // namespace arscout::util
