// The default detector among distractors, on chessboards drawn by the test itself (exact
// area-sampled squares under a homography, independent of the virtual camera's renderer):
// a bigger board than the one asked for is never returned as it; a board in a white
// margin and a grey frame (the frame's junctions join the saddle lattice) is found by the
// fast path; a second, smaller board beside the board does not disturb it; and the ring
// test of calib/corners/board_ring.h tells a whole board from a window of a bigger one.
#include <algorithm>
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "calib/corners/board_ring.h"
#include "calib/corners/chessboard_detector.h"

namespace camlab::calib {
namespace {

constexpr int kSupersample = 4;

// A board to draw: squares_x x squares_y squares of square_px (board units: pixels of
// the board seen straight on), its top-left square black, inside a margin of margin_px in
// tone margin, inside a frame of frame_px in tone frame; placed by a homography from board
// units to image pixels.
struct DrawnBoard {
  int squares_x = 10, squares_y = 7;
  double square_px = 30;
  double margin_px = 0, frame_px = 0;
  double margin = 1.0, frame = 0.5;
  cv::Matx33d board_to_image = cv::Matx33d::eye();

  // The tone at board point (u, v), or -1 outside the board with its margin and frame.
  double tone(double u, double v) const {
    const double w = squares_x * square_px, h = squares_y * square_px;
    if (u >= 0 && v >= 0 && u < w && v < h) {
      const int i = static_cast<int>(u / square_px), j = static_cast<int>(v / square_px);
      return (i + j) % 2 == 0 ? 0.0 : 1.0;
    }
    const double out = std::max({-u, -v, u - w, v - h});
    if (out <= margin_px) return margin;
    if (out <= margin_px + frame_px) return frame;
    return -1;
  }

  // Inner corner (i, j), row-major, in image pixels (pixel centres at integers).
  cv::Point2d corner(int i, int j) const {
    const cv::Vec3d p = board_to_image * cv::Vec3d((i + 1) * square_px, (j + 1) * square_px, 1);
    return {p[0] / p[2], p[1] / p[2]};
  }
};

// Draws boards over a background tone: each pixel the mean of kSupersample^2 samples.
cv::Mat draw(const std::vector<DrawnBoard>& boards, cv::Size size, double background = 0.35) {
  cv::Mat image(size, CV_8UC1);
  std::vector<cv::Matx33d> image_to_board;
  for (const auto& b : boards) image_to_board.push_back(b.board_to_image.inv());
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      double sum = 0;
      for (int sy = 0; sy < kSupersample; ++sy)
        for (int sx = 0; sx < kSupersample; ++sx) {
          const double px = x - 0.5 + (sx + 0.5) / kSupersample,
                       py = y - 0.5 + (sy + 0.5) / kSupersample;
          double t = background;
          for (size_t k = 0; k < boards.size(); ++k) {
            const cv::Vec3d q = image_to_board[k] * cv::Vec3d(px, py, 1);
            const double v = boards[k].tone(q[0] / q[2], q[1] / q[2]);
            if (v >= 0) t = v;  // later boards in front
          }
          sum += t;
        }
      image.at<uint8_t>(y, x) =
          cv::saturate_cast<uint8_t>(20 + 215 * sum / (kSupersample * kSupersample));
    }
  return image;
}

// A homography that places a board of w x h board units with its centre at `centre`,
// turned by `turn_deg` in the image and tilted by a perspective term.
cv::Matx33d placement(double w, double h, cv::Point2d centre, double turn_deg, double tilt) {
  const double a = turn_deg * M_PI / 180;
  const cv::Matx33d to_centre(1, 0, -w / 2, 0, 1, -h / 2, 0, 0, 1);
  const cv::Matx33d turn(std::cos(a), -std::sin(a), 0, std::sin(a), std::cos(a), 0, 0, 0, 1);
  const cv::Matx33d perspective(1, 0, 0, 0, 1, 0, tilt, 0, 1);
  const cv::Matx33d place(1, 0, centre.x, 0, 1, centre.y, 0, 0, 1);
  return place * perspective * turn * to_centre;
}

double worst_error_px(const ChessboardCorners& found, const DrawnBoard& truth, int cols, int rows) {
  double best = 1e9;
  for (bool half_turn : {false, true}) {
    double worst = 0;
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i < cols; ++i) {
        const size_t k = static_cast<size_t>(j * cols + i);
        const cv::Point2d t =
            half_turn ? truth.corner(cols - 1 - i, rows - 1 - j) : truth.corner(i, j);
        worst = std::max(worst, cv::norm(found.corners_px[k] - t));
      }
    best = std::min(best, worst);
  }
  return best;
}

TEST(BoardRing, ABiggerBoardIsNeverReturnedAsTheBoardAskedFor) {
  // 11 x 8 squares: 10 x 7 inner corners, asked for as 9 x 6 (and 8 x 6), straight on,
  // turned and tilted.
  for (double turn : {0.0, 12.0, -25.0}) {
    DrawnBoard big;
    big.squares_x = 11, big.squares_y = 8, big.square_px = 36;
    big.margin_px = 18, big.frame_px = 0;
    big.board_to_image = placement(11 * 36, 8 * 36, {320, 240}, turn, 2e-4);
    const cv::Mat image = draw({big}, {640, 480});
    for (auto [cols, rows] : {std::pair{9, 6}, {8, 6}}) {
      BoardMiss miss;
      auto found = find_chessboard(image, cols, rows, "auto", &miss);
      EXPECT_FALSE(found.ok()) << cols << "x" << rows << " turn " << turn << " found by "
                               << (found.ok() ? found->detector : "");
      if (!found.ok()) {
        EXPECT_TRUE(miss.reason == "bigger_grid" || miss.reason == "part_of_bigger_board")
            << miss.reason << ": " << miss.detail;
      }
    }
    // The board itself is found, at its corners (by OpenCV's classic detector where the
    // saddle lattice misses a junction: within a fifth of a pixel).
    BoardMiss miss;
    auto whole = find_chessboard(image, 10, 7, "auto", &miss);
    ASSERT_TRUE(whole.ok()) << "turn " << turn << ": " << miss.detail;
    EXPECT_LT(worst_error_px(*whole, big, 10, 7), 0.25)
        << "turn " << turn << ", " << whole->detector;
  }
}

TEST(BoardRing, ABoardInAWhiteMarginAndGreyFrameIsFoundByTheFastPath) {
  // The frame's junctions with the edge squares' outer corners join the saddle lattice
  // (as on OpenCV's sample stereo photos); the ring test picks the board's own window.
  for (double frame_tone : {0.5, 0.15}) {
    DrawnBoard b;
    b.squares_x = 10, b.squares_y = 7, b.square_px = 34;
    b.margin_px = 7, b.frame_px = 25, b.frame = frame_tone;
    b.board_to_image = placement(10 * 34, 7 * 34, {300, 250}, 8, 3e-4);
    const cv::Mat image = draw({b}, {640, 480});
    auto found = find_chessboard(image, 9, 6, "auto");
    ASSERT_TRUE(found.ok()) << "frame tone " << frame_tone;
    EXPECT_EQ(found->detector, "saddle") << "frame tone " << frame_tone;
    EXPECT_LT(worst_error_px(*found, b, 9, 6), 0.15) << "frame tone " << frame_tone;
  }
}

TEST(BoardRing, ASmallerBoardBesideTheBoardDoesNotDisturbIt) {
  DrawnBoard board;
  board.squares_x = 10, board.squares_y = 7, board.square_px = 30;
  board.margin_px = 15;
  board.board_to_image = placement(300, 210, {380, 260}, -6, 2e-4);
  DrawnBoard distractor;  // a 6 x 5-square board on a "monitor" at the left
  distractor.squares_x = 6, distractor.squares_y = 5, distractor.square_px = 14;
  distractor.margin_px = 6;
  distractor.board_to_image = placement(84, 70, {90, 150}, 20, 0);
  const cv::Mat image = draw({board, distractor}, {640, 480});
  BoardMiss miss;
  auto found = find_chessboard(image, 9, 6, "auto", &miss);
  ASSERT_TRUE(found.ok()) << miss.detail;
  EXPECT_LT(worst_error_px(*found, board, 9, 6), 0.15);
  // Asked for the distractor's size, the distractor is what is found: the detector
  // finds the board asked for, whichever it is.
  auto small = find_chessboard(image, 5, 4, "auto");
  ASSERT_TRUE(small.ok());
  EXPECT_LT(worst_error_px(*small, distractor, 5, 4), 0.2);
}

TEST(BoardRing, RingTwoAlternatesOnlyAroundAWindowOfABiggerBoard) {
  DrawnBoard big;
  big.squares_x = 12, big.squares_y = 9, big.square_px = 32;
  big.margin_px = 20;
  big.board_to_image = placement(12 * 32, 9 * 32, {320, 240}, 0, 0);
  const cv::Mat tone = ring_tone_image(draw({big}, {640, 480}), 1.0);
  // The whole board: 11 x 8 inner corners; a 9 x 6 window in its middle.
  auto whole = [&](int i, int j) { return cv::Point2f(big.corner(i, j)); };
  auto window = [&](int i, int j) { return cv::Point2f(big.corner(i + 1, j + 1)); };
  EXPECT_TRUE(ringed_by_squares(ring_alternation(tone, whole, 11, 8, 1)));
  EXPECT_FALSE(board_goes_on(ring_alternation(tone, whole, 11, 8, 2)));
  EXPECT_TRUE(ringed_by_squares(ring_alternation(tone, window, 9, 6, 1)));
  EXPECT_TRUE(board_goes_on(ring_alternation(tone, window, 9, 6, 2)));
  for (double share : ring_alternation(tone, window, 9, 6, 2)) EXPECT_GT(share, 0.9);
  for (double share : ring_alternation(tone, whole, 11, 8, 2)) EXPECT_LT(share, 0.3);
}

}  // namespace
}  // namespace camlab::calib
