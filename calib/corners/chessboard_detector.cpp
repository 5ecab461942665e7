#include "calib/corners/chessboard_detector.h"

#include <algorithm>

#include "calib/corners/board_ring.h"
#include "calib/corners/image_8bit.h"
#include "calib/corners/mrgingham_corners.h"
#include "calib/corners/saddle_corners.h"

namespace camlab::calib {

namespace {

std::string board_name(int cols, int rows) {
  return std::to_string(cols) + "x" + std::to_string(rows);
}

// Error "board_not_found" (why_not "part_of_bigger_board") when OpenCV's board goes on past
// its edge (board_ring.h): a window of a bigger board, which the classic detector may
// return when it finds more squares than the board asked for has.
Result<ChessboardCorners> whole_board_only(Result<ChessboardCorners> found, const cv::Mat& image,
                                           bool* part_of_bigger) {
  if (!found) return found;
  const cv::Mat tone = ring_tone_image(stretch_to_8bit(image), 1.0);
  const auto& c = found->corners_px;
  const int cols = found->cols;
  auto corner = [&](int i, int j) {
    const cv::Point2d& p = c[static_cast<size_t>(j * cols + i)];
    return cv::Point2f(static_cast<float>(p.x), static_cast<float>(p.y));
  };
  if (board_goes_on(ring_alternation(tone, corner, found->cols, found->rows, 2))) {
    *part_of_bigger = true;
    return make_error("board_not_found",
                      "the " + board_name(found->cols, found->rows) + " grid " + found->detector +
                          " found is part of a bigger chessboard, not the board asked for");
  }
  return found;
}

}  // namespace

Status check_chessboard_detector(const std::string& detector, int cols, int rows) {
  if (detector != "auto" && detector != "saddle" && detector != "opencv" &&
      detector != "mrgingham" && detector != "markers")
    return make_error("invalid_argument", "unknown chessboard detector '" + detector +
                                              "': use auto, saddle, opencv or mrgingham, markers "
                                              "for a chessboard with OpenCV's three circle "
                                              "markers (or charuco for a ChArUco board)");
  if (detector == "markers" && (cols < 3 || rows < 3))
    return make_error("unsupported",
                      "the markers detector needs a board of at least 3x3 inner corners, not " +
                          board_name(cols, rows));
  if (detector == "mrgingham" && cols != rows)
    return make_error("unsupported",
                      "the mrgingham detector needs a square board (mrgingham 1.22 finds N x N "
                      "inner corners only), not " +
                          board_name(cols, rows) + "; use the auto, saddle or opencv detector");
  return {};
}

BoardMiss why_no_board(const cv::Mat& image, int cols, int rows) {
  // The largest lattice of X-junctions says what the image holds instead.
  const int span = std::max(cols, rows) + 3;
  auto lattice = find_saddle_lattice(image, span, 4);
  if (!lattice)
    return {"no_corners",
            "no chessboard corners in the image (no board, or one too blurred or too dark to "
            "show its corners)"};
  int imin = 1 << 20, imax = -(1 << 20), jmin = imin, jmax = imax;
  for (const auto& p : lattice->ij) {
    imin = std::min(imin, p.x), imax = std::max(imax, p.x);
    jmin = std::min(jmin, p.y), jmax = std::max(jmax, p.y);
  }
  const int nx = imax - imin + 1, ny = jmax - jmin + 1;
  const std::string seen =
      std::to_string(lattice->ij.size()) + " corners spanning " + board_name(nx, ny);
  if (std::max(nx, ny) > std::max(cols, rows) || std::min(nx, ny) > std::min(cols, rows))
    return {"bigger_grid", "the largest chessboard grid seen (" + seen + ") is bigger than the " +
                               board_name(cols, rows) +
                               " board asked for, and no one window of it is ringed by the "
                               "board's edge squares: another board, or junctions along the "
                               "board's frame"};
  return {"partial_board", "the largest chessboard grid seen (" + seen + ") is not the whole " +
                               board_name(cols, rows) +
                               " board: cut by the frame, covered, or another, smaller board"};
}

Result<ChessboardCorners> find_chessboard(const cv::Mat& image, int cols, int rows,
                                          const std::string& detector, BoardMiss* miss) {
  if (Status s = check_chessboard_detector(detector, cols, rows); !s) return s.error();
  if (detector == "opencv") return find_chessboard_corners(image, cols, rows);
  if (detector == "mrgingham") return find_chessboard_corners_mrgingham(image, cols);
  auto found = find_chessboard_corners_saddle(image, cols, rows);
  if (found.ok() || detector == "saddle") return found;
  if (found.error().code == "bad_image" || found.error().code == "invalid_argument") return found;
  // auto: each next detector is a second, independent chance, cheapest first (one core,
  // 640x480 photos): mrgingham on a square board, then OpenCV's classic detector (1-40 ms)
  // and its sector-based one (40-50 ms). OpenCV's are last so that auto never finds fewer
  // boards than they do; each of their boards is checked not to be part of a bigger one.
  if (cols == rows)
    if (auto m = find_chessboard_corners_mrgingham(image, cols); m.ok()) return m;
  bool part_of_bigger = false;
  for (bool classic : {true, false}) {
    auto o = whole_board_only(classic ? find_chessboard_corners_classic(image, cols, rows)
                                      : find_chessboard_corners_sb(image, cols, rows, false),
                              image, &part_of_bigger);
    if (o.ok()) return o;
  }
  BoardMiss why = part_of_bigger ? BoardMiss{"part_of_bigger_board",
                                             "OpenCV's detectors found " + board_name(cols, rows) +
                                                 " corners only as part of a bigger chessboard"}
                                 : why_no_board(image, cols, rows);
  Error e = make_error("board_not_found", "no whole " + board_name(cols, rows) +
                                              " inner-corner chessboard found: " + why.detail);
  if (miss) *miss = std::move(why);
  return e;
}

}  // namespace camlab::calib
