#include "calib/corners/image_8bit.h"

#include <algorithm>
#include <cstdint>
#include <vector>

namespace camlab::calib {

cv::Mat stretch_to_8bit(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  // The percentiles from a histogram of the 16-bit values: one pass over the image, a
  // few ms for a megapixel, where sorting its values cost 25 ms; the same two values.
  std::vector<uint32_t> histogram(65536, 0);
  for (int y = 0; y < image.rows; ++y) {
    const uint16_t* row = image.ptr<uint16_t>(y);
    for (int x = 0; x < image.cols; ++x) ++histogram[row[x]];
  }
  const size_t n = image.total();
  const size_t lo_index = n / 1000, hi_index = n - 1 - n / 1000;
  // The value of rank r (0-based) in sorted order.
  auto value_at_rank = [&](size_t r) {
    size_t seen = 0;
    for (int v = 0; v < 65536; ++v) {
      seen += histogram[v];
      if (seen > r) return static_cast<float>(v);
    }
    return 65535.f;
  };
  const float lo = value_at_rank(lo_index);
  const float hi = std::max(value_at_rank(hi_index), lo + 1.f);
  cv::Mat out;
  image.convertTo(out, CV_8U, 255.0 / (hi - lo), -lo * 255.0 / (hi - lo));
  return out;
}

}  // namespace camlab::calib
