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
// not depend on `threads` (ties go to the lower index), nor on the CPU.
// Distances are sqrt(2 - 2 d) with d = quantized_dot(a-row, b-row) when no
// row of either has a negative component (descriptors such as RootSIFT's),
// else the exact dot product in float.
std::vector<std::pair<int, int>> match_descriptors(const cv::Mat& a,
                                                   const cv::Mat& b,
                                                   double ratio, int threads);

// The matcher's dot product of two non-negative rows of 128: each row
// scaled so that its largest component is 4095 and rounded to integers, the
// integer dot product times the two scales (largest component / 4095), as
// float(sum) * (scale_a * scale_b). For RootSIFT-like rows it is within
// about 1e-4 of the exact one.
float quantized_dot(const float* a, const float* b);

// The kernel match_descriptors runs on this CPU: "avx512vnni", "avx2" or
// "portable". The environment variable ARSCOUT_CPU_DISABLE (read once, a
// comma-separated list such as "avx512vnni,avx2") rules out the sets it
// names; every kernel gives the same matches.
const char* matcher_kernel();

// Descriptors of a photo that was turned clockwise by `quarter_turns` x 90
// degrees, as they would be had it been held upright: match a's descriptors
// against rotate_descriptors(b, t) when b is a's view turned t quarter turns.
// A SIFT descriptor is a 4 x 4 grid of 8-bin orientation histograms, so
// turning the patch permutes cells and bins.
// This lets upright descriptors match a photo held sideways or upside down
// without computing orientations.
cv::Mat rotate_descriptors(const cv::Mat& descriptors, int quarter_turns);

// How many of (at most) `samples` rows of `a`, spread evenly, find a
// ratio-test match in `b`: a cheap estimate of the overlap of two photos.
int overlap_score(const cv::Mat& a, const cv::Mat& b, double ratio,
                  int samples);

}  // namespace arscout::engine
