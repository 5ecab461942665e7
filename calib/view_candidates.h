// Candidate board poses for the next-view suggestion (internal to calib/; see
// view_suggestion.h): a board centred on a pixel at a distance, facing the camera or
// tilted about the image axes, and whether a detector would see it through a lens model.
//
// Reentrant: plain functions of their arguments.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "calib/calibration_data.h"
#include "calib/lens_model.h"
#include "calib/view_suggestion.h"

namespace camlab::calib {

struct CandidateView {
  std::array<double, 6> rt_cam_board{};  // rotation vector (rad), translation (m)
  double centre_x_px = 0, centre_y_px = 0;
  double distance_m = 0;
  double tilt_about_x_deg = 0, tilt_about_y_deg = 0;  // signs as in ViewSuggestion
  std::vector<double> corners_cam;  // the corners in the camera frame (m), (x, y, z) each
  std::vector<double> corners_px;   // their pixels, (x, y) each; row-major as the board
  std::vector<char> visible;        // per corner: on the imager inside the margin
  std::array<double, 4> bounds_px{};
};

// The pose that puts the board's centre on the ray of pixel (x_px, y_px) at `distance_m`,
// its x axis along the image's x, facing the camera along that ray, then tilted (degrees,
// signs as in ViewSuggestion). Empty when the model cannot unproject the pixel.
std::optional<std::array<double, 6>> board_pose_at(const LensModel& model, const BoardSpec& board,
                                                   double x_px, double y_px, double distance_m,
                                                   double tilt_about_x_deg,
                                                   double tilt_about_y_deg);

// Projects the board at `rt` (with mrcal's warp) through `model` and marks the corners a
// detector sees: in front of the camera, inside the imager by `margin_px`, and projected
// by the model where it is one-to-one (the direction unprojects back onto the corner; a
// polynomial model folds over beyond its data). Empty when the projection fails.
std::optional<CandidateView> observe_candidate(const LensModel& model, const BoardSpec& board,
                                               const std::array<double, 6>& rt,
                                               const std::array<double, 2>& calobject_warp,
                                               double margin_px);

// Whether the detector would accept the view: every corner visible for a chessboard
// (whole_board_required), else half of them (a ChArUco board is found from part of it).
bool detectable(const CandidateView& view, bool whole_board_required);

// The board pushed as far towards region (gx, gy) of the imager (each -1, 0 or +1: left /
// centre / right, top / centre / bottom) as it stays detectable, at the distance and tilt
// given. Empty when no placement on the way to the centre keeps it detectable.
std::optional<CandidateView> place_towards(const LensModel& model, const BoardSpec& board,
                                           const std::array<double, 2>& calobject_warp, int gx,
                                           int gy, double distance_m, double tilt_about_x_deg,
                                           double tilt_about_y_deg,
                                           const SuggestionOptions& options);

// "top_left", "top", ... "centre" for a point of the imager (its thirds).
std::string region_name(double x_px, double y_px, int width_px, int height_px);

// One line for a person: where and how to hold the board.
std::string describe(const ViewSuggestion& s);

}  // namespace camlab::calib
