// Reading a blurred float image (CV_32FC1) between its pixels, as the saddle detector
// and the board's ring test do: bilinear samples, and the tone range on a circle.
//
// Reentrant: reads only its arguments.
#pragma once

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

namespace camlab::calib {

// The bilinear sample at (x, y), pixel centres at integers, clamped to the image.
inline float sample_bilinear(const cv::Mat& f, float x, float y) {
  x = std::clamp(x, 0.f, f.cols - 1.001f);
  y = std::clamp(y, 0.f, f.rows - 1.001f);
  const int x0 = static_cast<int>(x), y0 = static_cast<int>(y);
  const float ax = x - x0, ay = y - y0;
  const float* r0 = f.ptr<float>(y0);
  const float* r1 = f.ptr<float>(y0 + 1);
  return (1 - ay) * ((1 - ax) * r0[x0] + ax * r0[x0 + 1]) +
         ay * ((1 - ax) * r1[x0] + ax * r1[x0 + 1]);
}

inline float sample_bilinear(const cv::Mat& f, cv::Point2f p) {
  return sample_bilinear(f, p.x, p.y);
}

// The tone range (max - min) of 16 samples on a circle of `radius` px around p: the
// contrast of a corner there.
inline float contrast_around(const cv::Mat& f, cv::Point2f p, float radius) {
  float lo = 1e9f, hi = -1e9f;
  for (int k = 0; k < 16; ++k) {
    const float a = static_cast<float>(2 * M_PI * k / 16);
    const float v = sample_bilinear(f, p.x + radius * std::cos(a), p.y + radius * std::sin(a));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
  return hi - lo;
}

}  // namespace camlab::calib
