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

namespace {

Status check_image(const cv::Mat& image, int cols, int rows) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image",
                      "chessboard detection needs a single-channel 8- or 16-bit image");
  if (cols < 2 || rows < 2)
    return make_error("invalid_argument", "a chessboard needs at least 2 x 2 inner corners");
  return {};
}

Error not_found(int cols, int rows) {
  return make_error("board_not_found", "no complete " + std::to_string(cols) + "x" +
                                           std::to_string(rows) +
                                           " inner-corner chessboard found in the image");
}

// OpenCV's corners, refined, as a board found by `detector`.
ChessboardCorners refined_board(const cv::Mat& image, int cols, int rows,
                                std::vector<cv::Point2f> found, const std::string& detector,
                                double max_move_px) {
  // OpenCV's corners scatter by 0.1-0.2 px on tilted, noisy boards; refine_corners_subpix
  // halves that, with a window that fits the view's squares.
  refine_corners_subpix(image, cols, rows, &found, max_move_px);
  ChessboardCorners out;
  out.cols = cols;
  out.rows = rows;
  out.corners_px.reserve(found.size());
  for (const auto& p : found) out.corners_px.emplace_back(p.x, p.y);
  // Every corner is refined at full resolution: mrcal's weight 0.5^0.
  out.weights.assign(found.size(), 1.0);
  out.detector = detector;
  return out;
}

}  // namespace

Result<ChessboardCorners> find_chessboard_corners_sb(const cv::Mat& image, int cols, int rows,
                                                     bool exhaustive_sb) {
  if (Status s = check_image(image, cols, rows); !s) return s.error();
  std::vector<cv::Point2f> found;
  const int flags = cv::CALIB_CB_NORMALIZE_IMAGE |
                    (exhaustive_sb ? cv::CALIB_CB_EXHAUSTIVE | cv::CALIB_CB_ACCURACY : 0);
  if (!cv::findChessboardCornersSB(stretch_to_8bit(image), cv::Size(cols, rows), found, flags))
    return not_found(cols, rows);
  return refined_board(image, cols, rows, std::move(found), exhaustive_sb ? "opencv" : "opencv_sb",
                       1.5);
}

Result<ChessboardCorners> find_chessboard_corners(const cv::Mat& image, int cols, int rows) {
  return find_chessboard_corners_sb(image, cols, rows, /*exhaustive_sb=*/true);
}

// The largest image side OpenCV's classic detector is given (see below).
constexpr int kClassicMaxSidePx = 640;

Result<ChessboardCorners> find_chessboard_corners_classic(const cv::Mat& image, int cols,
                                                          int rows) {
  if (Status s = check_image(image, cols, rows); !s) return s.error();
  std::vector<cv::Point2f> found;
  // CALIB_CB_FAST_CHECK: a quick look for a chessboard before the full search. It costs
  // 1-2 ms on a photo with the board and saves up to a second on one without (OpenCV's
  // sample photos with no board: 12-1200 ms without it, 1-15 ms with it on most); on
  // OpenCV's sample stereo pair it finds the same 26 boards.
  const int flags =
      cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE | cv::CALIB_CB_FAST_CHECK;
  // Its quadrilateral search can run away on a large image where the fast check passes but
  // the board is not found: 85 s on one rendered 1280x800 view of a steeply tilted 14x10
  // board, 9 ms on the same view at 640x400. It looks at most at VGA size (where it was
  // measured on real photos); the refinement below works at full resolution.
  const int long_side_px = std::max(image.cols, image.rows);
  const double scale = long_side_px > kClassicMaxSidePx
                           ? static_cast<double>(kClassicMaxSidePx) / long_side_px
                           : 1.0;
  cv::Mat looked_at = stretch_to_8bit(image);
  if (scale < 1.0) cv::resize(looked_at, looked_at, cv::Size(), scale, scale, cv::INTER_AREA);
  if (!cv::findChessboardCorners(looked_at, cv::Size(cols, rows), found, flags))
    return not_found(cols, rows);
  // Back to full-resolution pixel coordinates (pixel centres at integers in both).
  for (auto& p : found)
    p = (p + cv::Point2f(0.5f, 0.5f)) * static_cast<float>(1.0 / scale) - cv::Point2f(0.5f, 0.5f);
  // The classic detector places a corner where its quadrilaterals meet, which on a
  // blurred or tilted photo is 1-3 px off the junction (3 of OpenCV's sample stereo
  // photos): the refinement may move it by up to a quarter of the corner spacing.
  double spacing_px = 1e9;
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i + 1 < cols; ++i)
      spacing_px =
          std::min<double>(spacing_px, cv::norm(found[j * cols + i + 1] - found[j * cols + i]));
  return refined_board(image, cols, rows, std::move(found), "opencv_classic",
                       std::max(1.5, 0.25 * spacing_px));
}

}  // namespace camlab::calib
