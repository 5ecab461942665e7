#include "calib/chessboard_corners.h"

#include <algorithm>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace camlab::calib {

namespace {

// Stretches raw DN to 8 bits between robust percentiles: the detector needs contrast,
// and a 12-bit frame's DN may occupy only a fraction of the 16-bit range.
cv::Mat to_8bit(const cv::Mat& image) {
  if (image.depth() == CV_8U) return image;
  cv::Mat values;
  image.reshape(1, 1).convertTo(values, CV_32F);
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

}  // namespace

Result<ChessboardCorners> find_chessboard_corners(const cv::Mat& image, int cols, int rows) {
  if (image.empty() || image.channels() != 1 ||
      (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image", "chessboard detection needs a single-channel 8- or 16-bit image");
  if (cols < 2 || rows < 2)
    return make_error("invalid_argument", "a chessboard needs at least 2 x 2 inner corners");
  std::vector<cv::Point2f> found;
  const int flags = cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY;
  if (!cv::findChessboardCornersSB(to_8bit(image), cv::Size(cols, rows), found, flags))
    return make_error("board_not_found", "no complete " + std::to_string(cols) + "x" +
                                             std::to_string(rows) +
                                             " inner-corner chessboard found in the image");
  // The sector-based detector's corners scatter by 0.1-0.2 px on tilted, noisy boards;
  // a gradient-orthogonality refinement (cornerSubPix) over a window as large as the
  // squares allow halves that. The window must stay inside one square's neighbourhood,
  // so it follows the smallest corner spacing in this view.
  double min_spacing_px = 1e9;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const cv::Point2f& p = found[j * cols + i];
      if (i + 1 < cols) min_spacing_px = std::min<double>(min_spacing_px, cv::norm(found[j * cols + i + 1] - p));
      if (j + 1 < rows) min_spacing_px = std::min<double>(min_spacing_px, cv::norm(found[(j + 1) * cols + i] - p));
    }
  const int half_window = std::clamp(static_cast<int>(0.45 * min_spacing_px), 2, 7);
  cv::Mat gray;
  image.convertTo(gray, CV_32F);
  cv::cornerSubPix(gray, found, cv::Size(half_window, half_window), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));

  ChessboardCorners out;
  out.cols = cols;
  out.rows = rows;
  out.corners_px.reserve(found.size());
  for (const auto& p : found) out.corners_px.emplace_back(p.x, p.y);
  return out;
}

}  // namespace camlab::calib
