// Which chessboard detector finds the corners: camlab's saddle-point detector
// (calib/corners/saddle_corners.h), OpenCV's (calib/corners/chessboard_corners.h) or mrgingham
// (calib/corners/mrgingham_corners.h), by name, as `camlab calibrate --detector` and
// CalibrateOptions::detector choose it.
//
//   "saddle"     saddle points at reduced resolution, a grid grown from them, cornerSubPix
//                at full resolution; any cols x rows board, a few ms per megapixel.
//   "opencv"     findChessboardCornersSB + cornerSubPix, any cols x rows board; 10-50x
//                slower than "saddle".
//   "mrgingham"  mrgingham only; mrgingham 1.22 finds square boards only (cols == rows).
//   "auto"       "saddle", and mrgingham on an image of a square board where it finds
//                none. OpenCV's detector is never tried: on the example views it found
//                no board the saddle detector missed, at 0.7-0.9 s per image.
//
// Reentrant.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/corners/chessboard_corners.h"

namespace camlab::calib {

// Checks a detector name against the board. Error "invalid_argument" for a name other
// than auto, saddle, opencv, mrgingham, markers; "unsupported", saying why, for
// "mrgingham" with cols != rows and "markers" on a board under 3 x 3.
Status check_chessboard_detector(const std::string& detector, int cols, int rows);

// Finds a cols x rows inner-corner board with the named detector (checked as above).
// ChessboardCorners::detector names the detector that found it. Errors: those of
// check_chessboard_detector(); otherwise those of the detector that ran last ("bad_image",
// "board_not_found").
Result<ChessboardCorners> find_chessboard(const cv::Mat& image, int cols, int rows,
                                          const std::string& detector);

}  // namespace camlab::calib
