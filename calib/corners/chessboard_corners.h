// Chessboard corner detection with OpenCV: findChessboardCornersSB (the sector-based
// detector) finds the board, cornerSubPix refines each corner.
//
// Corners are returned in mrcal's order: row-major over the inner corners, corner (i, j)
// being target point (i * spacing, j * spacing, 0). OpenCV may find the board rotated by
// 180 degrees (a chessboard with an even/odd layout is symmetric), and a square board by
// a quarter turn too; the caller that knows the truth or the previous view disambiguates.
//
// Reentrant.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::calib {

// One detected board, whichever detector found it (calib/corners/mrgingham_corners.h is the other).
struct ChessboardCorners {
  int cols = 0;  // inner corners per row
  int rows = 0;
  std::vector<cv::Point2d> corners_px;  // cols * rows, pixel centres at integers
  // cols * rows, mrcal's weight of each corner: 0.5^level for a corner refined at image
  // pyramid level `level` (mrgingham), 1 for a full-resolution corner (OpenCV); 0 for a
  // corner the detector could not place (missing: its position is only the grid's
  // prediction).
  std::vector<double> weights;
  std::string detector;  // "saddle", "mrgingham", "opencv", "opencv_classic", "opencv_sb"
};

// Finds a cols x rows inner-corner chessboard in a single-channel 8- or 16-bit image.
// 16-bit input is scaled to 8 bits using its own 0.1%..99.9% range (raw sensor DN of
// any bit depth works). Errors: "bad_image" for empty or multi-channel input,
// "board_not_found" when the whole board is not visible.
Result<ChessboardCorners> find_chessboard_corners(const cv::Mat& image, int cols, int rows);

// The same with OpenCV's classic detector, findChessboardCorners (adaptive threshold,
// quadrilaterals joined into a grid), then cornerSubPix as above: 1-40 ms on a 640x480
// photo, and it finds boards the others miss (a thin margin, strong JPEG blocking). The
// detector is "opencv_classic". With `exhaustive_sb` false, find_chessboard_corners()'s
// findChessboardCornersSB runs without its exhaustive search and accuracy pass (40-50 ms
// on a 640x480 photo instead of 170-350) and the detector is "opencv_sb".
Result<ChessboardCorners> find_chessboard_corners_classic(const cv::Mat& image, int cols, int rows);
Result<ChessboardCorners> find_chessboard_corners_sb(const cv::Mat& image, int cols, int rows,
                                                     bool exhaustive_sb);

// Refines a detected cols x rows board's corners in place with cv::cornerSubPix (single-
// channel 8- or 16-bit image), over a window that follows the view's smallest corner
// spacing (its half-width `window_share` x that spacing, 2-7 px); a corner the refinement
// moves by `max_move_px` or more keeps its position.
// Every detector uses it.
void refine_corners_subpix(const cv::Mat& image, int cols, int rows,
                           std::vector<cv::Point2f>* corners, double max_move_px = 1.5,
                           double window_share = 0.45);

}  // namespace camlab::calib
