// Where to put the board next. A guided calibration asks, after each view, which pose of
// the board would most reduce the worst projection uncertainty over the imager, and tells
// the user (or a test that moves the virtual board) to place it there.
//
// The answer comes from the solve's own information: for a candidate pose, the board's
// corners are predicted through the current model, their Jacobian rows appended to those of
// the views so far at the current optimum, and the projection uncertainty (uncertainty.h,
// mrcal's definition) recomputed over a grid of the imager at the working distance. The
// candidate whose worst grid value is smallest wins. Candidates are board centres over the
// imager (its border and corners first among equals) at the working distance, facing the
// camera or tilted about the image axes, kept only when the detector could see them (the
// whole board for a chessboard, enough corners for a ChArUco board).
//
// Before the first solve there is no model to predict with: an opening sequence (facing the
// camera at the centre, then tilted) from a nominal field of view starts the session.
//
// Reentrant.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/solver.h"

namespace camlab::calib {

struct SuggestionOptions {
  // Grid over which the worst uncertainty is taken (pixel centres spanning the imager,
  // corners included).
  int grid_cols = 16, grid_rows = 10;
  // Distance at which uncertainty is evaluated and boards are placed; <= 0: the solve's
  // working distance (median distance of the boards' centres).
  double distance_m = 0;
  double max_tilt_deg = 40;          // largest tilt of a candidate off facing the camera
  bool whole_board_required = true;  // chessboards: every corner on the imager
  double min_corner_margin_px = 10;  // corners this close to the imager edge count as off
  // Used before the first solve: the nominal horizontal field of view (deg) and the
  // distance at which to open the session (m).
  double nominal_fov_x_deg = 90;
  double opening_distance_m = 0.6;
};

struct ViewSuggestion {
  // The pose to place the board at: rt_cam_board (rotation vector rad, translation m),
  // mapping board points (corner (i, j) at (i, j, 0) * spacing) into the camera frame.
  std::array<double, 6> rt_cam_board{};
  // Where the board appears, as the user sees it: its centre and bounding box (px), its
  // distance (m) and tilt (deg off facing the camera; about the image x axis, top away
  // from the camera positive, and about the image y axis, right side away positive).
  double centre_x_px = 0, centre_y_px = 0;
  std::array<double, 4> bounds_px{};  // x_min, y_min, x_max, y_max
  // The board's outermost corners (first, last of the first row; last, first of the last
  // row) as (x, y) px: the quadrilateral a live view draws to show where and how tilted.
  std::array<double, 8> outline_px{};
  int imager_width_px = 0, imager_height_px = 0;  // the imager these pixels are on
  double distance_m = 0;
  double tilt_about_x_deg = 0, tilt_about_y_deg = 0;
  std::string region;       // "centre", "top_left", "top", ... "bottom_right"
  std::string description;  // one line for a person: where and how to hold the board
  // Worst-direction stdev at the distance above: the worst over the grid now and as
  // predicted with this view added (px). Both 0 before the first solve.
  double worst_now_px = 0;
  double predicted_worst_px = 0;
  bool opening = false;  // from the opening sequence (no model yet)
};

// The next view for a session that has `data` and (when it has been solved) `solution`
// (null before the first successful solve; `data` may then hold 0 or more views).
// Errors: "invalid_argument" (options, a board or imager of zero size), "no_covariance"
// (a solution without a covariance), "no_candidate" (no candidate pose keeps the board
// visible: the board is too large for the imager at this distance).
Result<ViewSuggestion> suggest_next_view(const CalibrationData& data, const Solution* solution,
                                         const SuggestionOptions& options);

// Worst-direction stdev on the options' grid at the options' distance, and where it is
// worst (px). Error "no_covariance" as above.
struct UncertaintyCoverage {
  int cols = 0, rows = 0;
  double distance_m = 0;
  std::vector<double> worst_px;  // cols x rows, row-major; NaN where not unprojectable
  double worst_of_grid_px = 0;
  double worst_x_px = 0, worst_y_px = 0;
};
Result<UncertaintyCoverage> uncertainty_coverage(const Solution& solution,
                                                 const SuggestionOptions& options);

// The warm start for re-solving a session's data after views were appended: the
// solution's model, warp, poses and rejected corners for the views it used, a PnP pose
// through its model for the others (solver.h, WarmStart).
std::shared_ptr<const WarmStart> session_warm_start(const Solution& solution);

}  // namespace camlab::calib
