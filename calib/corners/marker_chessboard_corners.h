// Partial chessboard views: a chessboard with OpenCV's three circle markers near its
// middle (gen_pattern.py's radon_checkerboard with -m; findChessboardCornersSB's
// CALIB_CB_MARKER; docs/calibration.md, "Chessboards with markers"). The markers fix the
// board's origin, so a board cut off by the frame still names its corners.
//
// 1. The grid: the saddle detector's lattice of X-junctions (find_saddle_lattice,
//    calib/corners/saddle_corners.h), whole board or not, 7-14 ms an image. Where its
//    grid is not named (steps 2-4), OpenCV 4.6's findChessboardCornersSB with
//    CALIB_CB_LARGER | CALIB_CB_MARKER is a second chance (about 0.2 s an image): its grid
//    (not its naming: the grid comes back transposed or flipped from view to view) goes
//    through the same steps. Not CALIB_CB_LARGER alone: its grids stop short of the
//    markers and take the board's outer L-corners (against the quiet zone) for inner
//    corners (tests/bench/marker_chessboard_bench.cpp).
// 2. The markers: each grid cell's centre (where its diagonals cross) is compared with its
//    body (four points halfway to its corners, outside the disc of 0.17 squares); a cell
//    whose centre is the other colour holds a marker. The one light marker cell with a
//    dark marker cell beside it along each grid axis is the board's light marker square
//    (marker_square() below, the renderer's rule); no such cell, or more than one, is no
//    board. Which neighbour is +x and which -y follows from the board being seen from its
//    front (x turned by +90 deg is y, in the image, y down).
// 3. Every lattice corner gets its id from its lattice offset to the marker cell; a corner
//    whose id falls outside the board is dropped (a junction of the background). Each
//    corner is refined as a saddle point (calib/corners/saddle_point.h) in a window of 0.4
//    x the distance to its nearest lattice neighbour (a marker disc's edge is 0.54 squares
//    from the nearest corner), at most 12 px and inside the image; a corner whose window
//    the image's border halves, or whose refinement fails or moves more than half the
//    window, is dropped.
// 4. The named corners are checked against each other by id: each must lie where its named
//    neighbours along the board's rows and columns put it (their midpoint, or a straight
//    step) within 0.2 of a step; the worst offender is dropped until none is left, and so
//    is a corner no neighbour predicts. A lattice that skipped a column at the imager's
//    edge (where distortion squeezes the squares) names the corners beyond it one over;
//    this check drops them (marker_chessboard_bench: view 14 of the example set).
//
// Reentrant.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::calib {

// The light marker square (a, b) of a board of cols x rows inner corners: squares are
// a = 0 .. cols across, b = 0 .. rows down, square (a, b) dark when a + b is even; the dark
// marker squares are (a, b - 1) and (a + 1, b). The board's middle square, moved one left
// when that one is dark (mock_device/spec/scene_spec.h draws the same).
inline std::array<int, 2> marker_square(int cols, int rows) {
  int a = (cols + 1) / 2;
  const int b = (rows + 1) / 2;
  if ((a + b) % 2 == 0) --a;
  return {a, b};
}

struct MarkerChessboardCorners {
  int cols = 0, rows = 0;
  std::vector<int> ids;                 // row-major inner-corner index j * cols + i
  std::vector<cv::Point2d> corners_px;  // refined, pixel centres at integer coordinates
  int grid_corners = 0;                 // corners the grid held
  int off_board = 0;                    // of those, with an id outside the board
  int dropped = 0;                      // of those, not refined
  int inconsistent = 0;                 // refined, then dropped by the id check (step 4)
};

// Names the corners of a grid by the markers it holds: grid corner k at lattice cell
// ij[k] (integer grid indices, axes in any direction), at px[k] (unrefined). `image`:
// CV_8UC1 or CV_16UC1. Errors: "invalid_argument", "board_not_found" with the reason.
Result<MarkerChessboardCorners> name_by_markers(const cv::Mat& image,
                                                const std::vector<cv::Point2i>& ij,
                                                const std::vector<cv::Point2d>& px, int cols,
                                                int rows);

// The board of cols x rows inner corners (each >= 3) in `image`: the saddle lattice named
// by its markers, else OpenCV's marker grid named the same way. Errors:
// "invalid_argument", "bad_image", "board_not_found" (the lattice's reason).
Result<MarkerChessboardCorners> find_marker_chessboard(const cv::Mat& image, int cols, int rows);

}  // namespace camlab::calib
