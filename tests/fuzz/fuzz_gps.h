// Shared by the fuzz targets of the GPS readers.
#pragma once

#include "arscout/metadata/gps.h"

namespace arscout::fuzz {

// Field by field: GpsFix has no ==, and a fix read back from its JSON form
// must be the same in every field.
inline bool same_fix(const metadata::GpsFix& a, const metadata::GpsFix& b) {
  return a.lat == b.lat && a.lon == b.lon && a.alt == b.alt &&
         a.h_acc == b.h_acc && a.v_acc == b.v_acc &&
         a.satellites == b.satellites && a.time == b.time &&
         a.source == b.source;
}

}  // namespace arscout::fuzz
