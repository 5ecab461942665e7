// Whether a grid of chessboard corners is the whole board: the rings of cells around it.
//
// A chessboard's outermost inner corners are ringed by its edge squares, which continue
// the board's alternation of tones; past them lies the board's margin, the frame it is
// held in, or the background: one tone along a side, or clutter at another scale. So
//   ring 1 (the cells just outside the corners) alternates on a whole board, and
//   ring 2 (the cells past those) alternates only where the grid is part of a bigger
//   board: the distractor a detector must not return as the board asked for.
// A cell "alternates" when it is one tone across (ring 2: five samples within a quarter
// of the board's contrast; ring 1, the edge squares: its centre) and that tone differs from
// the cell inward across the ring's line and from the previous cell along the side, by a
// quarter of the board's contrast each. The board's contrast is taken beside the cell,
// across the grid's outermost line (an edge square against the square inward of it), never
// at the cell's own border: there a white margin continues a light edge square's tone.
// Cells are placed by steps out from the grid's edge, each the last step
// scaled by the ratio of the grid's last two (perspective shrinks squares geometrically);
// distortion bends them by a fraction of a cell.
//
// Reentrant: reads only its arguments.
#pragma once

#include <array>
#include <functional>

#include <opencv2/core.hpp>

namespace camlab::calib {

// A blurred float view of a single-channel 8-bit image for ring_alternation(): values
// 0..1, Gaussian blur of sigma_px.
cv::Mat ring_tone_image(const cv::Mat& gray8, double sigma_px);

// For each side of a w x h grid (top j = 0, bottom j = h-1, left i = 0, right i = w-1),
// the share of ring `ring`'s cells (1 or 2) that alternate, 0..1. `corner(i, j)` gives
// grid corner (i, j) in `tone`'s pixels. A cell outside the image does not alternate.
std::array<double, 4> ring_alternation(const cv::Mat& tone,
                                       const std::function<cv::Point2f(int, int)>& corner, int w,
                                       int h, int ring);

// The two uses. A grid is ringed by squares when ring 1 alternates along every side (70%
// of its cells or more); it goes on past its edge when ring 2 alternates along any side.
bool ringed_by_squares(const std::array<double, 4>& ring1_shares);
bool board_goes_on(const std::array<double, 4>& ring2_shares);

}  // namespace camlab::calib
