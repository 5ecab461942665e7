#include "calib/corners/chessboard_detector.h"

#include "calib/corners/mrgingham_corners.h"
#include "calib/corners/saddle_corners.h"

namespace camlab::calib {

Status check_chessboard_detector(const std::string& detector, int cols, int rows) {
  if (detector != "auto" && detector != "saddle" && detector != "opencv" &&
      detector != "mrgingham" && detector != "markers")
    return make_error("invalid_argument", "unknown chessboard detector '" + detector +
                                              "': use auto, saddle, opencv or mrgingham, markers "
                                              "for a chessboard with OpenCV's three circle "
                                              "markers (or charuco for a ChArUco board)");
  if (detector == "markers" && (cols < 3 || rows < 3))
    return make_error("unsupported",
                      "the markers detector needs a board of at least 3x3 inner corners, not " +
                          std::to_string(cols) + "x" + std::to_string(rows));
  if (detector == "mrgingham" && cols != rows)
    return make_error("unsupported",
                      "the mrgingham detector needs a square board (mrgingham 1.22 finds N x N "
                      "inner corners only), not " +
                          std::to_string(cols) + "x" + std::to_string(rows) +
                          "; use the auto, saddle or opencv detector");
  return {};
}

Result<ChessboardCorners> find_chessboard(const cv::Mat& image, int cols, int rows,
                                          const std::string& detector) {
  if (Status s = check_chessboard_detector(detector, cols, rows); !s) return s.error();
  if (detector == "opencv") return find_chessboard_corners(image, cols, rows);
  if (detector == "mrgingham") return find_chessboard_corners_mrgingham(image, cols);
  auto found = find_chessboard_corners_saddle(image, cols, rows);
  if (found.ok() || detector == "saddle" || cols != rows) return found;
  // auto on a square board: mrgingham's own grid search is a second, independent chance
  // (58 ms an image), where OpenCV's would cost 0.7-0.9 s.
  if (auto m = find_chessboard_corners_mrgingham(image, cols); m.ok()) return m;
  return found;
}

}  // namespace camlab::calib
