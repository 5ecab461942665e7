#include "calib/corners/charuco_corners.h"

#include <algorithm>
#include <cmath>

#include <opencv2/aruco/charuco.hpp>
#include <opencv2/imgproc.hpp>

#include "base/format.h"
#include "calib/corners/image_8bit.h"
#include "calib/corners/saddle_point.h"
#include "image/aruco_dictionary.h"

namespace camlab::calib {

namespace {

// The saddle window's radius as a share of the distance from the corner to the nearest
// corner of the markers beside it. The markers' nearest points to a board corner are
// their corners (at (gap, gap) from it in the square, gap = (square - marker) / 2), so a
// disk of that radius holds the X-junction alone; the share leaves room for the blur
// and for perspective, which can bring a marker's side nearer than its corner.
constexpr double kWindowShare = 0.7;
// A window smaller than this holds too few pixels for a stable fit: the corner is dropped.
constexpr double kMinWindowPx = 2.5;
// And one larger than this gains nothing but sensitivity to the edges' curvature.
constexpr double kMaxWindowPx = 12;
// A saddle point further than this share of the window from OpenCV's estimate is a
// different junction or a fit gone astray.
constexpr double kMaxMoveShare = 0.5;
// OpenCV 4.6's interpolateCornersCharuco returns its cornerSubPix result shifted by
// (+0.5, +0.5) px (it converts to a pixel-corner origin around cornerSubPix but not back;
// opencv/opencv issue 25539, fixed upstream in 2026): the refinement starts from the
// position cornerSubPix found. On an OpenCV without the shift it starts 0.7 px off, which
// the iteration absorbs.
const cv::Point2d kOpenCvShift(0.5, 0.5);

Result<cv::Ptr<cv::aruco::CharucoBoard>> make_board(const CharucoBoardSpec& spec) {
  if (Status s = check_charuco_board(spec); !s) return s.error();
  image::ArucoDictionary d;
  CAMLAB_ASSIGN(d, image::find_aruco_dictionary(spec.dictionary));
  const auto dictionary = cv::aruco::getPredefinedDictionary(d.opencv_id);
  return cv::aruco::CharucoBoard::create(spec.squares_cols, spec.squares_rows,
                                         static_cast<float>(spec.square_m),
                                         static_cast<float>(spec.marker_m), dictionary);
}

}  // namespace

Status check_charuco_board(const CharucoBoardSpec& board) {
  if (board.squares_cols < 3 || board.squares_rows < 3 || board.squares_cols > 201 ||
      board.squares_rows > 201)
    return make_error("out_of_range", "a ChArUco board needs 3 to 201 squares each way, not " +
                                          std::to_string(board.squares_cols) + "x" +
                                          std::to_string(board.squares_rows));
  if (!(board.square_m >= 1e-6) || board.square_m > 10)
    return make_error("out_of_range", "the ChArUco square must be in [1e-06, 10] m");
  // OpenCV builds the board in float and asserts marker < square there: a marker that is
  // smaller in double but equal in float (0.03 against 0.0300000001) would pass here and
  // fail inside OpenCV. A marker under a tenth of its square is too small to decode
  // wherever the square is large enough to find.
  const float square_f = static_cast<float>(board.square_m);
  const float marker_f = static_cast<float>(board.marker_m);
  if (!(board.marker_m >= 0.1 * board.square_m) || !(marker_f < square_f))
    return make_error("out_of_range", "the ChArUco marker (" + format_significant(board.marker_m) +
                                          " m) must be smaller than the square (" +
                                          format_significant(board.square_m) +
                                          " m) and at least a tenth of it");
  image::ArucoDictionary d;
  CAMLAB_ASSIGN(d, image::find_aruco_dictionary(board.dictionary));
  const int markers = board.squares_cols * board.squares_rows / 2;
  if (markers > d.marker_count)
    return make_error("out_of_range", "a " + std::to_string(board.squares_cols) + "x" +
                                          std::to_string(board.squares_rows) +
                                          "-square ChArUco board needs " + std::to_string(markers) +
                                          " markers; " + d.name + " has " +
                                          std::to_string(d.marker_count));
  return {};
}

Result<CharucoDetection> detect_charuco(const cv::Mat& image, const CharucoBoardSpec& spec) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return make_error("bad_image", "ChArUco detection needs a single-channel 8- or 16-bit image");
  cv::Ptr<cv::aruco::CharucoBoard> board;
  CAMLAB_ASSIGN(board, make_board(spec));
  CharucoDetection out;
  out.cols = spec.squares_cols - 1;
  out.rows = spec.squares_rows - 1;

  const cv::Mat gray8 = stretch_to_8bit(image);
  std::vector<std::vector<cv::Point2f>> marker_corners;
  std::vector<int> marker_ids;
  auto params = cv::aruco::DetectorParameters::create();
  // Marker corners to a fraction of a pixel: they place the first estimates and size the
  // saddle windows.
  params->cornerRefinementMethod = cv::aruco::CORNER_REFINE_NONE;
  cv::aruco::detectMarkers(gray8, board->dictionary, marker_corners, marker_ids, params);
  // Ids beyond the board's are another board's markers, or misreadings.
  const int board_markers = static_cast<int>(board->ids.size());
  for (size_t k = marker_ids.size(); k-- > 0;)
    if (marker_ids[k] < 0 || marker_ids[k] >= board_markers) {
      marker_ids.erase(marker_ids.begin() + static_cast<long>(k));
      marker_corners.erase(marker_corners.begin() + static_cast<long>(k));
    }
  out.markers = static_cast<int>(marker_ids.size());
  if (marker_ids.empty()) return out;

  std::vector<cv::Point2f> opencv_corners;
  std::vector<int> ids;
  // One decoded marker beside a corner is enough: a board cut by the frame's edge keeps
  // the corners along the cut, and the saddle refinement checks each corner on the image.
  cv::aruco::interpolateCornersCharuco(marker_corners, marker_ids, gray8, board, opencv_corners,
                                       ids, cv::noArray(), cv::noArray(), 1);

  // Each decoded marker's homography from the board's plane (m) to the image.
  std::vector<int> slot_of_marker(static_cast<size_t>(board_markers), -1);
  std::vector<cv::Matx33d> homography(marker_ids.size());
  for (size_t k = 0; k < marker_ids.size(); ++k) {
    slot_of_marker[static_cast<size_t>(marker_ids[k])] = static_cast<int>(k);
    std::vector<cv::Point2f> plane(4);
    for (int c = 0; c < 4; ++c) {
      const cv::Point3f& p = board->objPoints[static_cast<size_t>(marker_ids[k])][c];
      plane[c] = cv::Point2f(p.x, p.y);
    }
    homography[k] = cv::getPerspectiveTransform(plane, marker_corners[k]);
  }

  cv::Mat gray;
  image.convertTo(gray, CV_32F);
  std::vector<size_t> order(ids.size());
  for (size_t k = 0; k < order.size(); ++k) order[k] = k;
  std::sort(order.begin(), order.end(), [&](size_t a, size_t b) { return ids[a] < ids[b]; });
  for (size_t k : order) {
    CharucoCornerStages c;
    c.id = ids[k];
    c.opencv_px = opencv_corners[k];
    const cv::Point3f& board_point = board->chessboardCorners[static_cast<size_t>(c.id)];
    // The homography estimate and the nearest decoded marker corner.
    cv::Point2d sum(0, 0);
    int n = 0;
    double nearest_px = 1e30;
    const auto& near_markers = board->nearestMarkerIdx[static_cast<size_t>(c.id)];
    const auto& near_corners = board->nearestMarkerCorners[static_cast<size_t>(c.id)];
    for (size_t m = 0; m < near_markers.size(); ++m) {
      const int slot = slot_of_marker[static_cast<size_t>(board->ids[near_markers[m]])];
      if (slot < 0) continue;
      const cv::Matx33d& h = homography[static_cast<size_t>(slot)];
      const cv::Vec3d q = h * cv::Vec3d(board_point.x, board_point.y, 1);
      sum += cv::Point2d(q[0] / q[2], q[1] / q[2]);
      ++n;
      const cv::Point2f& mc = marker_corners[static_cast<size_t>(slot)][near_corners[m]];
      nearest_px = std::min(nearest_px, cv::norm(cv::Point2d(mc) - (c.opencv_px - kOpenCvShift)));
    }
    if (n == 0) continue;  // OpenCV's minimum of one marker makes this unreachable
    c.homography_px = sum / n;
    // A window cut by the image's border would see half a junction: it shrinks to fit,
    // with a pixel to spare for the estimate's moves.
    const cv::Point2d start = c.opencv_px - kOpenCvShift;
    const double to_border_px =
        std::min({start.x, start.y, image.cols - 1 - start.x, image.rows - 1 - start.y}) - 1.0;
    c.window_px = std::min({kMaxWindowPx, kWindowShare * nearest_px, to_border_px});
    if (c.window_px < kMinWindowPx) {
      c.dropped_because = "the markers and the image's border leave a window of " +
                          std::to_string(std::max(0.0, c.window_px)) + " px";
    } else {
      auto refined = refine_saddle_point(gray, start, c.window_px, kMaxMoveShare * c.window_px);
      if (refined.ok())
        c.saddle_px = refined->corner_px;
      else
        c.dropped_because = refined.error().message;
    }
    out.corners.push_back(std::move(c));
  }
  return out;
}

Result<CharucoCorners> find_charuco_corners(const cv::Mat& image, const CharucoBoardSpec& board) {
  CharucoDetection d;
  CAMLAB_ASSIGN(d, detect_charuco(image, board));
  CharucoCorners out;
  out.cols = d.cols;
  out.rows = d.rows;
  out.markers = d.markers;
  for (const CharucoCornerStages& c : d.corners) {
    if (!c.saddle_px) {
      ++out.dropped;
      continue;
    }
    out.ids.push_back(c.id);
    out.corners_px.push_back(*c.saddle_px);
  }
  if (out.ids.empty())
    return make_error("board_not_found", "no corner of the " + std::to_string(board.squares_cols) +
                                             "x" + std::to_string(board.squares_rows) + "-square " +
                                             board.dictionary + " ChArUco board found (" +
                                             std::to_string(d.markers) + " markers decoded, " +
                                             std::to_string(d.corners.size()) +
                                             " corners named, none refined)");
  return out;
}

}  // namespace camlab::calib
