#include "calib/corners/image_8bit.h"

#include <algorithm>
#include <vector>

namespace camlab::calib {

cv::Mat stretch_to_8bit(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  // reshape() needs continuous data; a region of interest is not.
  const cv::Mat continuous = image.isContinuous() ? image : image.clone();
  cv::Mat values;
  continuous.reshape(1, 1).convertTo(values, CV_32F);
  std::vector<float> sorted(values.begin<float>(), values.end<float>());
  const size_t lo_index = sorted.size() / 1000, hi_index = sorted.size() - 1 - sorted.size() / 1000;
  std::nth_element(sorted.begin(), sorted.begin() + lo_index, sorted.end());
  const float lo = sorted[lo_index];
  std::nth_element(sorted.begin(), sorted.begin() + hi_index, sorted.end());
  const float hi = std::max(sorted[hi_index], lo + 1.f);
  cv::Mat out;
  image.convertTo(out, CV_8U, 255.0 / (hi - lo), -lo * 255.0 / (hi - lo));
  return out;
}

}  // namespace camlab::calib
