// Which chessboard detector finds the corners: OpenCV's (calib/corners/chessboard_corners.h) or
// mrgingham (calib/corners/mrgingham_corners.h), by name, as `camlab calibrate --detector` and
// CalibrateOptions::detector choose it.
//
//   "opencv"     findChessboardCornersSB + cornerSubPix, any cols x rows board.
//   "mrgingham"  mrgingham only; mrgingham 1.22 finds square boards only (cols == rows).
//   "auto"       mrgingham on a square board, and OpenCV on an image where mrgingham
//                finds no board (and on every image of a non-square board).
//
// Reentrant.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/corners/chessboard_corners.h"

namespace camlab::calib {

// Checks a detector name against the board. Error "invalid_argument" for a name other
// than auto, opencv, mrgingham, and for "mrgingham" with cols != rows, saying why.
Status check_chessboard_detector(const std::string& detector, int cols, int rows);

// Finds a cols x rows inner-corner board with the named detector (checked as above).
// ChessboardCorners::detector names the detector that found it. Errors: those of
// check_chessboard_detector(); otherwise those of the detector that ran last ("bad_image",
// "board_not_found").
Result<ChessboardCorners> find_chessboard(const cv::Mat& image, int cols, int rows,
                                          const std::string& detector);

}  // namespace camlab::calib
