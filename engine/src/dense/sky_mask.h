// The open sky of a key view, masked before its depths are trusted: sky has
// no surface to measure, yet a window of faint cloud or JPEG noise passes
// the sweep's texture floor and finds a best plane somewhere, and those
// depths agree with each other often enough to be fused (docs/dense.md,
// "Sky").
#pragma once

#include <opencv2/core.hpp>

namespace arscout::engine {

// CV_8U, 255 on the sky of `bgr` (CV_8UC3): the pixels whose 5 x 5 grey
// levels vary by less than `max_texture` (standard deviation, 0-255) and
// that are joined through such pixels (8-connected) to the top of the
// picture. The top is each column's first rows of picture: an undistorted
// photo starts under a black border (pixels 0, 0, 0 from the top row
// down), and the textured edge of that border would otherwise cut the sky
// off. Smooth regions that do not reach the top (a plain wall under a
// roof, a patch of sky between leaves) are not sky by this rule. The mask
// then grows, up to 6 pixels, into the pixels beside it whose colour is
// within 8 grey levels (every channel) of the masked pixel next to them:
// the band along an edge that the 5 x 5 window left out, where the sweep's
// wider window would give the sky the edge's depth. All zero when
// max_texture is 0.
cv::Mat sky_mask(const cv::Mat& bgr, double max_texture);

}  // namespace arscout::engine
