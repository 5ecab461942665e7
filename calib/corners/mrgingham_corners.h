// Chessboard corner detection with mrgingham (Debian's libmrgingham 1.22), the detector
// mrcal's own tools use: ChESS corner responses on an image pyramid, a grid search over
// them, and each corner refined at the finest pyramid level where it is still clean.
//
// mrgingham 1.22 finds square boards only: gridn x gridn inner corners.
//
// Corner order. mrgingham reports the corners row-major: each row runs along the grid
// direction nearest the image's +x, and the rows follow one another along +y, so the
// first corner is the board's top-left one in the image. For a board held upright (its
// +x to the right in the image, +y down) that is exactly mrcal's order, which
// calib/calibration_data.h uses: corner (i, j) at board point (i, j) x spacing. mrgingham
// looks at corners, not at the colours of the squares, so for a board turned by about q
// quarter turns in the image the labelling is mrcal's order turned by q quarter turns: a
// rotation of the board's frame, never its mirror image. A monocular calibration does not
// mind (each view has its own pose); the labelling of one physical board is only
// consistent across cameras that see it the same way up. OpenCV's detector labels by its
// own rule and may differ from mrgingham by a quarter turn on the same image
// (docs/calibration.md, "Corner detectors"; tests/unit/calib/chessboard_detector_test.cpp
// checks both against the virtual camera's truth).
//
// Reentrant: mrgingham keeps no global state (its own tool runs it on many threads).
#pragma once

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/corners/chessboard_corners.h"

namespace camlab::calib {

// Finds a gridn x gridn inner-corner chessboard in a single-channel 8- or 16-bit image.
// 16-bit input is stretched to 8 bits as for the OpenCV detector (calib/corners/image_8bit.h),
// then box-blurred over 3x3 px as mrgingham's own tool does. Weights are mrcal's
// 0.5^level per corner; detector is "mrgingham". Errors: "bad_image" for empty,
// multi-channel or other-depth input, or a side over 32767 px; "invalid_argument" for
// gridn < 2; "board_not_found" when mrgingham finds no complete board (including in
// images too small to hold one).
Result<ChessboardCorners> find_chessboard_corners_mrgingham(const cv::Mat& image, int gridn);

}  // namespace camlab::calib
