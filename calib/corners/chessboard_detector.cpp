#include "calib/corners/chessboard_detector.h"

#include "calib/corners/mrgingham_corners.h"

namespace camlab::calib {

Status check_chessboard_detector(const std::string& detector, int cols, int rows) {
  if (detector != "auto" && detector != "opencv" && detector != "mrgingham")
    return make_error("invalid_argument", "unknown chessboard detector '" + detector +
                                              "': use auto, opencv or mrgingham");
  if (detector == "mrgingham" && cols != rows)
    return make_error("invalid_argument",
                      "the mrgingham detector needs a square board (mrgingham 1.22 finds N x N "
                      "inner corners only), not " +
                          std::to_string(cols) + "x" + std::to_string(rows) +
                          "; use the opencv or auto detector");
  return {};
}

Result<ChessboardCorners> find_chessboard(const cv::Mat& image, int cols, int rows,
                                          const std::string& detector) {
  if (Status s = check_chessboard_detector(detector, cols, rows); !s) return s.error();
  if (detector == "opencv" || cols != rows) return find_chessboard_corners(image, cols, rows);
  auto found = find_chessboard_corners_mrgingham(image, cols);
  if (found.ok() || detector == "mrgingham") return found;
  // auto: mrgingham misses some boards OpenCV still finds (docs/calibration.md, "Corner
  // detectors"); a view found by either is worth more to the solve than no view.
  return find_chessboard_corners(image, cols, rows);
}

}  // namespace camlab::calib
