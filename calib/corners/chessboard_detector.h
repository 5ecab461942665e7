// Which chessboard detector finds the corners: camlab's saddle-point detector
// (calib/corners/saddle_corners.h), OpenCV's (calib/corners/chessboard_corners.h) or mrgingham
// (calib/corners/mrgingham_corners.h), by name, as `camlab calibrate --detector` and
// CalibrateOptions::detector choose it.
//
//   "saddle"     saddle points at reduced resolution, a grid grown from them, cornerSubPix
//                at full resolution; any cols x rows board, a few ms per megapixel.
//   "opencv"     findChessboardCornersSB with its exhaustive search + cornerSubPix, any
//                cols x rows board; 20-40x slower than "saddle".
//   "mrgingham"  mrgingham only; mrgingham 1.22 finds square boards only (cols == rows).
//   "auto"       a cascade, cheapest first, each stage tried where the ones before found
//                no board: "saddle"; mrgingham on a square board; OpenCV's classic
//                findChessboardCorners ("opencv_classic"); findChessboardCornersSB without
//                its exhaustive search ("opencv_sb"). OpenCV's detectors come last, so auto
//                finds every board they find; a grid they return that goes on past its
//                edge (part of a bigger board: calib/corners/board_ring.h) is refused.
//                Where no stage finds the board, it says why (why_no_board()).
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

// Why an image holds no whole cols x rows board, from the largest lattice of chessboard
// corners in it (saddle_corners.h's find_saddle_lattice). `reason` is one of
//   "no_corners"            no lattice of 4 corners: no board, or one too blurred or too
//                           dark to show its corners;
//   "partial_board"         a smaller grid: the board cut by the frame, covered, or
//                           another, smaller board;
//   "bigger_grid"           a bigger grid of which no one window is ringed by edge squares:
//                           another board, or junctions along the board's frame;
//   "part_of_bigger_board"  (find_chessboard() only) OpenCV found the corners as a window
//                           of a bigger chessboard;
// `detail` says it for a person, with the grid seen.
struct BoardMiss {
  std::string reason;
  std::string detail;
};
BoardMiss why_no_board(const cv::Mat& image, int cols, int rows);

// Finds a cols x rows inner-corner board with the named detector (checked as above).
// ChessboardCorners::detector names the detector that found it. Errors: those of
// check_chessboard_detector(); "bad_image"; "board_not_found". Under auto, a board not
// found also fills *miss (when given) with why.
Result<ChessboardCorners> find_chessboard(const cv::Mat& image, int cols, int rows,
                                          const std::string& detector, BoardMiss* miss = nullptr);

}  // namespace camlab::calib
