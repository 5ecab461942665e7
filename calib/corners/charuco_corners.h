// ChArUco corner detection: OpenCV 4.6's aruco module finds the markers and names the
// corners; camlab refines each corner on the image as a saddle point.
//
//   1. markers    cv::aruco::detectMarkers on the 8-bit view of the image
//                 (calib/corners/image_8bit.h), marker corners refined by cornerSubPix;
//   2. corners    cv::aruco::interpolateCornersCharuco: each inner corner next to a
//                 decoded marker gets its ChArUco id and a first position (the homography
//                 of its nearest markers, then OpenCV's cornerSubPix);
//   3. refinement each corner becomes the saddle point of the image
//                 (calib/corners/saddle_point.h) in a window that stays clear of the two
//                 markers beside it (a share of the distance to their nearest detected
//                 corners); a corner whose window is too small, leaves the image, holds
//                 no saddle or moves too far is dropped, not kept at its first position.
//
// Why refine: a homography maps a plane through a pinhole; through a wide lens the markers'
// homographies are bent by the distortion and place the corners off by tenths of a pixel
// (docs/calibration.md, "ChArUco boards", has the figures), while the saddle point of the
// image is where the corner is, whatever the lens.
//
// Partial boards are kept: a board cut by the frame's edge, or with markers that did not
// decode, gives the corners next to the markers found, each with its id. Corner id
// j * cols + i is inner corner (i, j), i < cols = squares_cols - 1: mrcal's row-major order
// from the same corner (the board's top-left inner corner, next to its dark top-left
// square), so a view's corners go into calib/calibration_data.h's BoardView by id, the
// others missing.
//
// Reentrant (OpenCV may use its own threads inside).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"

namespace camlab::calib {

// A ChArUco board as OpenCV's cv::aruco::CharucoBoard::create takes it.
struct CharucoBoardSpec {
  int squares_cols = 0;    // squares across (inner corners + 1)
  int squares_rows = 0;    // squares down
  double square_m = 0;     // a square's side
  double marker_m = 0;     // a marker's side, black border included
  std::string dictionary;  // cv::aruco's name, e.g. DICT_4X4_50 (image/aruco_dictionary.h)
};

// Checks a board: at least 3 x 3 squares, 0 < marker < square, a known dictionary with a
// marker for every light square. Error "invalid_argument" or "out_of_range", saying which.
Status check_charuco_board(const CharucoBoardSpec& board);

// One corner OpenCV named, and each stage's position of it (pixel centres at integers).
struct CharucoCornerStages {
  int id = 0;                 // j * cols + i
  cv::Point2d homography_px;  // the mean of its nearest decoded markers' homographies
  // interpolateCornersCharuco's, as it returns it: the homography + cornerSubPix, shifted
  // by (+0.5, +0.5) px in OpenCV 4.6 (charuco_corners.cpp)
  cv::Point2d opencv_px;
  double window_px = 0;                  // the saddle window's radius
  std::optional<cv::Point2d> saddle_px;  // the saddle point; empty when dropped
  std::string dropped_because;           // why, when dropped
};

struct CharucoDetection {
  int cols = 0, rows = 0;                    // inner corners
  int markers = 0;                           // markers decoded (ids on this board)
  std::vector<CharucoCornerStages> corners;  // ascending id
};

// Every stage of the detection, for measuring them (tests/bench/calib_detect_bench.cpp).
// Errors: "bad_image" (empty, multi-channel, not 8- or 16-bit), those of
// check_charuco_board(). No marker is not an error: an empty detection.
Result<CharucoDetection> detect_charuco(const cv::Mat& image, const CharucoBoardSpec& board);

// The refined corners of one view.
struct CharucoCorners {
  int cols = 0, rows = 0;               // inner corners
  std::vector<int> ids;                 // ascending ChArUco ids
  std::vector<cv::Point2d> corners_px;  // the saddle points, one per id
  int markers = 0;                      // markers decoded
  int dropped = 0;                      // corners OpenCV named whose refinement failed
};

// detect_charuco()'s saddle points. Errors: those of detect_charuco(); "board_not_found"
// when no corner is left.
Result<CharucoCorners> find_charuco_corners(const cv::Mat& image, const CharucoBoardSpec& board);

}  // namespace camlab::calib
