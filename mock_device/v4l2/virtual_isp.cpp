#include "mock_device/v4l2/virtual_isp.h"

#include <algorithm>

namespace camlab::mock {

cv::Mat bin_bayer(const cv::Mat& mosaic) {
  cv::Mat out(mosaic.rows / 2, mosaic.cols / 2, CV_32F);
  for (int y = 0; y < out.rows; ++y) {
    const int y0 = 4 * (y / 2) + (y % 2);
    const int y1 = std::min(y0 + 2, mosaic.rows - 2 + (y % 2));
    for (int x = 0; x < out.cols; ++x) {
      const int x0 = 4 * (x / 2) + (x % 2);
      const int x1 = std::min(x0 + 2, mosaic.cols - 2 + (x % 2));
      out.at<float>(y, x) = 0.25f * (mosaic.at<float>(y0, x0) + mosaic.at<float>(y0, x1) +
                                     mosaic.at<float>(y1, x0) + mosaic.at<float>(y1, x1));
    }
  }
  return out;
}

cv::Mat demosaic_to_rgb(const cv::Mat& mosaic, const SensorSpec& sensor) {
  const double black = sensor.black_level_dn;
  const double scale = 255.0 / ((1 << sensor.bit_depth) - 1 - black);
  const int rows = mosaic.rows, cols = mosaic.cols;
  cv::Mat out(rows, cols, CV_32FC3);
  for (int y = 0; y < rows; ++y) {
    auto* row = out.ptr<cv::Vec3f>(y);
    for (int x = 0; x < cols; ++x) {
      double sum[3] = {0, 0, 0};
      int count[3] = {0, 0, 0};
      const int own = sensor.channel_at(x, y);
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = y + dy;
        if (yy < 0 || yy >= rows) continue;
        for (int dx = -1; dx <= 1; ++dx) {
          const int xx = x + dx;
          if (xx < 0 || xx >= cols) continue;
          const int c = sensor.channel_at(xx, yy);
          // The pixel's own colour is its own sample only; the others are the mean of
          // their nearest sites (the 2 or 4 in the 3x3 block).
          if (c == own && (dx != 0 || dy != 0)) continue;
          sum[c] += mosaic.at<float>(yy, xx);
          ++count[c];
        }
      }
      for (int c = 0; c < 3; ++c)
        row[x][c] = count[c] > 0 ? static_cast<float>((sum[c] / count[c] - black) * scale) : 0.f;
    }
  }
  return out;
}

}  // namespace camlab::mock
