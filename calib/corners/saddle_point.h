// Sub-pixel refinement of one chessboard-like corner as the saddle point of the image:
// a quadratic surface I = c0 + c1 x + c2 y + c3 x^2 + c4 x y + c5 y^2 is fitted by weighted
// least squares to the pixels within `radius_px` of the current estimate, the estimate
// moves to the fitted surface's saddle point (where its gradient vanishes), and the fit is
// repeated there until the step is under `tolerance_px`.
//
// Why a saddle point: an X-junction (two straight edges crossing, at any angle, as a board
// corner is under any perspective) blurred by any point-symmetric blur is point-symmetric
// about the corner, so a window centred on the corner holds an even function, the fit's
// linear terms vanish and the saddle is the corner: the refinement is unbiased by the
// view's perspective, the lens's blur or where the corner was first guessed (a homography
// from nearby markers is bent by the lens's distortion; the image is not). Its one bias is
// what breaks the symmetry inside the window: another edge (a ChArUco marker, the board's
// side) or the image's border, so the caller sizes the window to stay clear of them, and
// the edges' curvature under distortion across the window (small: the window spans a few
// pixels). And the fit's own: a quadratic is not an X-junction, and a window's pixels do
// not sit symmetrically about a corner between them, so on junctions drawn exactly the
// saddle is off by up to 0.02 px at a 6 px window, 0.01 px at 9 px, by sub-pixel phase and
// skew (tests/unit/calib/saddle_point_test.cpp).
//
// The weights (1 - (r/R)^2)^2 fall smoothly to 0 at the window's rim, so a pixel entering
// or leaving the window as the estimate moves changes nothing abruptly.
//
// Reentrant: reads only its arguments.
#pragma once

#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::calib {

struct SaddleRefinement {
  cv::Point2d corner_px;  // pixel centres at integer coordinates
  int iterations = 0;
  // The balance of the fitted surface's two principal curvatures (opposite signs at a
  // saddle), 0..1: 1 for a square corner seen straight on, lower as perspective skews it,
  // near 0 where the window holds one edge.
  double saddle_strength = 0;
};

// Refines `start` on `image` (single channel, any depth; read as float) with a window of
// radius `radius_px` (>= 2), giving up after 30 iterations. Errors: "bad_image" (empty or
// multi-channel), "window_too_small" (radius under 2 px), "window_outside_image" (the
// window leaves the image at any iteration), "not_converged" (no saddle: the surface is a
// bowl or a ridge, or the iteration does not settle, or it moves the estimate by more than
// `max_move_px` from `start`).
Result<SaddleRefinement> refine_saddle_point(const cv::Mat& image, cv::Point2d start,
                                             double radius_px, double max_move_px);

}  // namespace camlab::calib
