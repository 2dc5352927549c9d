// Descriptor matching between two images: nearest neighbours by Euclidean
// distance of unit descriptors, Lowe's ratio test and a mutual check.
#pragma once

#include <utility>
#include <vector>

#include <opencv2/core.hpp>

namespace arscout::engine {

// `a` and `b` hold unit rows (CV_32F, 128 columns). Returns (row of a, row
// of b) for every a-row whose nearest b-row is closer than `ratio` times the
// second nearest and whose nearest a-row is that same a-row. The result does
// not depend on `threads` (ties go to the lower index).
std::vector<std::pair<int, int>> match_descriptors(const cv::Mat& a,
                                                   const cv::Mat& b,
                                                   double ratio, int threads);

}  // namespace arscout::engine
