#include "calib/corners/mrgingham_corners.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <exception>
#include <string>
#include <vector>

#include <mrgingham/mrgingham.hh>
#include <opencv2/imgproc.hpp>

#include "calib/corners/image_8bit.h"

namespace camlab::calib {

namespace {

// mrgingham realloc()s the per-corner level buffer and leaves it to the caller to free();
// this owner frees it on every path, an exception from inside mrgingham included.
struct LevelBuffer {
  signed char* levels = nullptr;
  LevelBuffer() = default;
  LevelBuffer(const LevelBuffer&) = delete;
  LevelBuffer& operator=(const LevelBuffer&) = delete;
  ~LevelBuffer() { std::free(levels); }
};

// mrgingham keeps pixel coordinates in int16_t.
constexpr int kMaxSidePx = 32767;

}  // namespace

Result<ChessboardCorners> find_chessboard_corners_mrgingham(const cv::Mat& image, int gridn) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image",
                      "chessboard detection needs a single-channel 8- or 16-bit image");
  if (image.cols > kMaxSidePx || image.rows > kMaxSidePx)
    return make_error("bad_image", "mrgingham handles images up to " + std::to_string(kMaxSidePx) +
                                       " px a side, not " + std::to_string(image.cols) + "x" +
                                       std::to_string(image.rows));
  if (gridn < 2)
    return make_error("invalid_argument", "a chessboard needs at least 2 x 2 inner corners");
  const std::string grid = std::to_string(gridn) + "x" + std::to_string(gridn);
  const std::string not_found =
      "mrgingham found no complete " + grid + " inner-corner chessboard in the image";
  // A board spans gridn + 1 squares and ChESS needs some 4 px per square even at full
  // resolution; mrgingham's coarsest pyramid level (1/8) would also shrink a smaller
  // image to nothing, which OpenCV's resize() rejects.
  const int min_side_px = std::max(32, 4 * (gridn + 1));
  if (image.cols < min_side_px || image.rows < min_side_px)
    return make_error("board_not_found", not_found + " (a " + std::to_string(image.cols) + "x" +
                                             std::to_string(image.rows) +
                                             " image is too small to hold one)");

  // mrgingham reads CV_8U pixels as a dense array (it refuses strided data, such as a
  // region of interest; blur() writes a fresh dense image), and its ChESS response
  // samples a 5-px ring that assumes an image already blurred: its own tool
  // box-blurs with radius 1 by default. Without the blur, mrgingham missed 24 of the
  // virtual camera's 40 example views of a 10x10 board (2 with it) and its corner error
  // doubled (docs/calibration.md, "Corner detectors"). The tool's other default, CLAHE,
  // is left out: on these evenly lit boards it missed 5 and added 0.02-0.07 px RMS;
  // "auto" falls back to OpenCV where mrgingham misses.
  cv::Mat gray;
  cv::blur(stretch_to_8bit(image), gray, cv::Size(3, 3));

  std::vector<mrgingham::PointDouble> points;
  LevelBuffer refinement;
  int found_level = -1;
  try {
    // image_pyramid_level -1: search from the coarsest level (1/8) down to full
    // resolution, take the first level that gives a grid, then refine each corner at
    // finer levels for as long as it is still found there.
    found_level =
        mrgingham::find_chessboard_from_image_array(points, &refinement.levels, gridn, gray, -1);
  } catch (const std::exception& e) {
    return make_error("board_not_found", not_found + " (mrgingham: " + e.what() + ")");
  }
  if (found_level < 0 || points.size() != static_cast<size_t>(gridn) * gridn)
    return make_error("board_not_found", not_found);

  // mrgingham's corners on the virtual camera's boards are about half as accurate as
  // OpenCV's refined ones (0.136 against 0.068 px RMS); the same cornerSubPix refinement
  // on the unblurred image closes most of that gap at a few ms per image
  // (docs/calibration.md, "Corner detectors").
  std::vector<cv::Point2f> refined;
  refined.reserve(points.size());
  for (const auto& p : points)
    refined.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  refine_corners_subpix(image, gridn, gridn, &refined);

  ChessboardCorners out;
  out.cols = gridn;
  out.rows = gridn;
  out.detector = "mrgingham";
  out.corners_px.reserve(points.size());
  out.weights.reserve(points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    out.corners_px.emplace_back(refined[i].x, refined[i].y);
    // A board found at full resolution is never refined, and mrgingham then leaves the
    // level buffer unwritten (null): every corner is at found_level = 0. A corner located
    // at pyramid level L carries about 2^L times a full-resolution corner's error, hence
    // mrcal's weight 0.5^L.
    const int level = refinement.levels ? refinement.levels[i] : found_level;
    out.weights.push_back(std::ldexp(1.0, -std::max(level, 0)));
  }
  return out;
}

}  // namespace camlab::calib
