#include "calib/corners/chessboard_corners.h"

#include <algorithm>
#include <cmath>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/corners/image_8bit.h"

namespace camlab::calib {

void refine_corners_subpix(const cv::Mat& image, int cols, int rows,
                           std::vector<cv::Point2f>* corners, double max_move_px,
                           double window_share) {
  if (corners->size() != static_cast<size_t>(cols) * rows || corners->empty()) return;
  // A gradient-orthogonality refinement over a window as large as the squares allow. The
  // window must stay inside one square's neighbourhood, so it follows the smallest corner
  // spacing in this view.
  const auto& found = *corners;
  double min_spacing_px = 1e9;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const cv::Point2f& p = found[j * cols + i];
      if (i + 1 < cols)
        min_spacing_px = std::min<double>(min_spacing_px, cv::norm(found[j * cols + i + 1] - p));
      if (j + 1 < rows)
        min_spacing_px = std::min<double>(min_spacing_px, cv::norm(found[(j + 1) * cols + i] - p));
    }
  const int half_window = std::clamp(static_cast<int>(window_share * min_spacing_px), 2, 7);
  cv::Mat gray;
  image.convertTo(gray, CV_32F);
  std::vector<cv::Point2f> refined = found;
  cv::cornerSubPix(gray, refined, cv::Size(half_window, half_window), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  // A refinement that wandered off (a corner next to glare or the board's edge) keeps
  // the detector's own position: a corner moves by a fraction of a pixel, not by pixels.
  for (size_t k = 0; k < refined.size(); ++k)
    if (std::isfinite(refined[k].x) && std::isfinite(refined[k].y) &&
        cv::norm(refined[k] - found[k]) < max_move_px)
      (*corners)[k] = refined[k];
}

Result<ChessboardCorners> find_chessboard_corners(const cv::Mat& image, int cols, int rows) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image",
                      "chessboard detection needs a single-channel 8- or 16-bit image");
  if (cols < 2 || rows < 2)
    return make_error("invalid_argument", "a chessboard needs at least 2 x 2 inner corners");
  std::vector<cv::Point2f> found;
  const int flags = cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY;
  if (!cv::findChessboardCornersSB(stretch_to_8bit(image), cv::Size(cols, rows), found, flags))
    return make_error("board_not_found", "no complete " + std::to_string(cols) + "x" +
                                             std::to_string(rows) +
                                             " inner-corner chessboard found in the image");
  // The sector-based detector's corners scatter by 0.1-0.2 px on tilted, noisy boards;
  // refine_corners_subpix halves that.
  refine_corners_subpix(image, cols, rows, &found);

  ChessboardCorners out;
  out.cols = cols;
  out.rows = rows;
  out.corners_px.reserve(found.size());
  for (const auto& p : found) out.corners_px.emplace_back(p.x, p.y);
  // Every corner is refined at full resolution: mrcal's weight 0.5^0.
  out.weights.assign(found.size(), 1.0);
  out.detector = "opencv";
  return out;
}

}  // namespace camlab::calib
