// Chessboard corner detection for boards of any shape at a few milliseconds per image:
// the fast detector behind `--detector auto` (docs/calibration.md, "Corner detectors").
//
//   1. coarse pass  at reduced resolution (an image pyramid, half resolution first): the
//                   inner corners of a chessboard are saddle points of the blurred image,
//                   where the Hessian's determinant is strongly negative; its local
//                   maxima of -det(H) are the candidates;
//   2. grid         from the strongest candidates, a lattice is grown: each next corner is
//                   predicted from its grid neighbours (a straight step, or a
//                   parallelogram across a row) and taken when a candidate lies within a
//                   third of a spacing of the prediction and shows an X-junction (four
//                   alternating sectors on a circle around it); the board is the lattice
//                   when it is exactly cols x rows (or rows x cols) and complete;
//   3. refinement   cornerSubPix at the coarse level, then at full resolution
//                   (refine_corners_subpix, calib/corners/chessboard_corners.h);
//   4. re-check     each refined corner must still be an X-junction on a small circle
//                   around it (cornerSubPix can carry a corner along an edge); one that
//                   is not is refined again from its neighbours' prediction with a smaller
//                   window, or left out.
//
// A level that finds no board hands over to the next finer one, down to full resolution
// (small, far boards). Whole boards only: a board cut by the image's edge is not found.
//
// Corner order: mrcal's row-major order (corner (i, j) at board point (i, j) x spacing),
// labelled so the grid is never mirrored (the i axis turned onto the j axis by +90 deg in
// the image, as for a board seen from the front) and, among the labellings the board's
// shape allows (a half turn; quarter turns on a square board), the one whose i axis runs
// nearest the image's +x. Every corner is refined at full resolution: weight 1; a corner
// the re-check could not place has weight 0 (missing, as mrcal takes it).
//
// Reentrant.
#pragma once

#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "calib/corners/chessboard_corners.h"

namespace camlab::calib {

// Finds a cols x rows inner-corner chessboard in a single-channel 8- or 16-bit image.
// detector is "saddle". Errors: "bad_image" for empty, multi-channel or other-depth input;
// "invalid_argument" for fewer than 2 x 2 corners; "board_not_found" when no complete
// board is found at any pyramid level.
Result<ChessboardCorners> find_chessboard_corners_saddle(const cv::Mat& image, int cols, int rows);

// The largest lattice of X-junctions the grid step grows, whole board or not: for boards
// whose corners are named otherwise (calib/corners/marker_chessboard_corners.h). Lattice
// cell (i, j) is a grid index relative to the seed (its axes in no fixed direction);
// positions are the coarse pass's, at full resolution (not refined). Tried level by
// level from the coarsest, as above; the first level whose largest lattice holds
// `min_corners` or more wins. Errors as above ("board_not_found": no such lattice).
struct SaddleLattice {
  std::vector<cv::Point2i> ij;          // lattice cells
  std::vector<cv::Point2d> corners_px;  // their corners, full-resolution px
  int level = 0;                        // the pyramid level it was found at
};
Result<SaddleLattice> find_saddle_lattice(const cv::Mat& image, int max_span, int min_corners);

}  // namespace camlab::calib
