// PNGs built for the decode-budget tests: valid files whose pixels are all
// zero (so they compress about 1000:1), optionally with a zTXt chunk that
// metadata parsers choke on.
#pragma once

#include <string>

namespace arscout::testing {

// A `width` x `height` PNG of colour type `colour_type` (2 RGB, 6 RGBA) and
// `bit_depth` (8 or 16), every pixel zero, its IDAT deflated in pieces (a
// 432 MB image costs a few MB of memory to make). With `bad_ztxt` a zTXt
// chunk with an unknown compression method comes before the IDAT.
std::string zero_png(int width, int height, int colour_type, int bit_depth,
                     bool bad_ztxt);

// The same header with a few bytes of IDAT: enough for a server that reads
// the header to refuse it; it does not decode.
std::string png_header_only(int width, int height, int colour_type,
                            int bit_depth);

}  // namespace arscout::testing
