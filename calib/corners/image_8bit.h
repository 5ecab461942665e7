// 8-bit grey views of raw frames for the chessboard detectors (OpenCV's and mrgingham's
// both work on 8-bit grey).
//
// Reentrant.
#pragma once

#include <opencv2/core.hpp>

namespace camlab::calib {

// `image` (CV_8UC1 or CV_16UC1, not empty) as CV_8UC1. 8-bit input is returned as is
// (shared, not copied). 16-bit input is stretched linearly so that its own 0.1% and
// 99.9% percentiles map to 0 and 255: raw DN of any bit depth (a 10- or 12-bit sensor
// fills only part of the 16-bit range) get full contrast, and a few hot or dead pixels
// cannot compress the rest.
cv::Mat stretch_to_8bit(const cv::Mat& image);

}  // namespace camlab::calib
