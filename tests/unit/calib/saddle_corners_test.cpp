// The saddle-point detector (calib/corners/saddle_corners.h) on chessboards drawn here, not
// by the virtual camera: a board plane mapped into the image by a homography, each pixel
// the average of 8 x 8 samples of the squares it covers (its area), then a Gaussian blur
// of 0.8 px (a lens) and fixed-seed noise. The truth of corner (i, j) is the homography
// applied to (i, j) x spacing, in the convention that pixel (x, y) spans x +- 0.5.
#include <cmath>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/corners/saddle_corners.h"

namespace camlab::calib {
namespace {

struct Drawn {
  cv::Mat image;                   // CV_8UC1
  std::vector<cv::Point2d> truth;  // cols x rows inner corners, row-major, board order
};

// A board of (cols + 1) x (rows + 1) squares of 1 unit, inner corner (i, j) at board point
// (i + 1, j + 1), a white margin of 1 unit around it; H maps board units to pixels.
Drawn draw_board(int cols, int rows, const cv::Matx33d& H, cv::Size size, double noise_dn = 2) {
  const cv::Matx33d Hinv = H.inv();
  cv::Mat image(size, CV_8UC1);
  constexpr int kSub = 8;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      double sum = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx) {
          const cv::Vec3d q(x - 0.5 + (sx + 0.5) / kSub, y - 0.5 + (sy + 0.5) / kSub, 1);
          const cv::Vec3d b = Hinv * q;
          const double u = b[0] / b[2], v = b[1] / b[2];
          double value = 40;  // the room around the board: dark grey
          if (u >= -1 && v >= -1 && u <= cols + 2 && v <= rows + 2) value = 230;  // margin
          if (u >= 0 && v >= 0 && u < cols + 1 && v < rows + 1)
            value =
                (static_cast<int>(std::floor(u)) + static_cast<int>(std::floor(v))) % 2 ? 230 : 25;
          sum += value;
        }
      image.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(sum / (kSub * kSub));
    }
  cv::GaussianBlur(image, image, cv::Size(), 0.8);
  cv::Mat n(size, CV_16SC1);
  cv::RNG rng(11);
  rng.fill(n, cv::RNG::NORMAL, 0, noise_dn);
  cv::Mat out;
  cv::add(image, n, out, cv::noArray(), CV_8U);
  Drawn d{out, {}};
  for (int j = 0; j < rows; ++j)
    for (int i = 0; i < cols; ++i) {
      const cv::Vec3d p = H * cv::Vec3d(i + 1, j + 1, 1);
      d.truth.emplace_back(p[0] / p[2], p[1] / p[2]);
    }
  return d;
}

// A homography: board units scaled by `scale` px, turned by `turn_deg` in the image,
// tilted by perspective (`px`, `py`: the projective row), centred at `centre`.
cv::Matx33d homography(double scale, double turn_deg, double px, double py, cv::Point2d centre,
                       cv::Point2d board_centre) {
  const double c = std::cos(turn_deg * M_PI / 180), s = std::sin(turn_deg * M_PI / 180);
  const cv::Matx33d to_origin(1, 0, -board_centre.x, 0, 1, -board_centre.y, 0, 0, 1);
  const cv::Matx33d affine(scale * c, -scale * s, 0, scale * s, scale * c, 0, 0, 0, 1);
  const cv::Matx33d projective(1, 0, 0, 0, 1, 0, px, py, 1);
  const cv::Matx33d to_centre(1, 0, centre.x, 0, 1, centre.y, 0, 0, 1);
  return to_centre * affine * projective * to_origin;
}

// Errors of the detection against the truth under the labelling symmetry that fits best,
// among the proper ones (a half turn; quarter turns for a square board): -1 as the
// symmetry when only a mirror image fits.
struct Fit {
  int symmetry = -1;
  double rms_px = 1e9, max_px = 1e9;
};
Fit fit(const ChessboardCorners& found, const std::vector<cv::Point2d>& truth, int cols, int rows) {
  Fit best;
  for (int g = 0; g < (cols == rows ? 4 : 2); ++g) {
    double sum = 0, worst = 0;
    for (int j = 0; j < rows; ++j)
      for (int i = 0; i < cols; ++i) {
        int ti = i, tj = j;
        if (g == 1 && cols != rows) ti = cols - 1 - i, tj = rows - 1 - j;
        if (cols == rows) {
          const int m = cols - 1;
          if (g == 1) ti = j, tj = m - i;
          if (g == 2) ti = m - i, tj = m - j;
          if (g == 3) ti = m - j, tj = i;
        }
        const double e = cv::norm(found.corners_px[j * cols + i] - truth[tj * cols + ti]);
        sum += e * e;
        worst = std::max(worst, e);
      }
    const double rms = std::sqrt(sum / (cols * rows));
    if (rms < best.rms_px) best = {g, rms, worst};
  }
  if (best.max_px > 2) best.symmetry = -1;  // no proper labelling fits
  return best;
}

TEST(SaddleCorners, FindsATiltedOblongBoardWithinFiveHundredthsOfAPixel) {
  const int cols = 9, rows = 6;
  const Drawn d = draw_board(
      cols, rows, homography(48, 8, 0.03, -0.02, {400, 300}, {(cols + 2) / 2.0, (rows + 2) / 2.0}),
      {800, 600});
  auto found = find_chessboard_corners_saddle(d.image, cols, rows);
  ASSERT_TRUE(found.ok()) << found.error().message;
  ASSERT_EQ(found->corners_px.size(), d.truth.size());
  const Fit f = fit(*found, d.truth, cols, rows);
  // Upright (turned 8 deg): the board's own order, not the half turn.
  EXPECT_EQ(f.symmetry, 0);
  EXPECT_LT(f.rms_px, 0.05);
  EXPECT_LT(f.max_px, 0.15);
}

TEST(SaddleCorners, FindsSmallBoardsAtFullResolutionAndTurnedOnesNeverMirrored) {
  struct Case {
    const char* what;
    double scale, turn_deg, px, py;
    int expected_symmetry;  // -2: any proper one
  } cases[] = {
      // Squares of 9 px: too small for the half-resolution pass, found at full resolution.
      {"small", 9, -5, 0, 0, 0},
      {"turned 90 deg", 40, 90, 0.0, 0.02, -2},
      {"turned 180 deg", 40, 180, 0.02, 0.0, 1},  // labelled from the image's top left
      {"steep perspective", 40, 20, 0.09, 0.0, 0},
  };
  const int cols = 7, rows = 5;
  for (const auto& c : cases) {
    const Drawn d = draw_board(cols, rows,
                               homography(c.scale, c.turn_deg, c.px, c.py, {320, 240},
                                          {(cols + 2) / 2.0, (rows + 2) / 2.0}),
                               {640, 480});
    auto found = find_chessboard_corners_saddle(d.image, cols, rows);
    ASSERT_TRUE(found.ok()) << c.what << ": " << found.error().message;
    const Fit f = fit(*found, d.truth, cols, rows);
    EXPECT_GE(f.symmetry, 0) << c.what << ": the labelling is a mirror image";
    if (c.expected_symmetry >= 0) {
      EXPECT_EQ(f.symmetry, c.expected_symmetry) << c.what;
    }
    EXPECT_LT(f.rms_px, 0.08) << c.what;
    if (c.expected_symmetry < 0) continue;
    // The first row runs along the image's +x.
    const cv::Point2d along_row = found->corners_px[cols - 1] - found->corners_px[0];
    EXPECT_GT(along_row.x, 0) << c.what;
  }
}

TEST(SaddleCorners, APartBoardOrABiggerBoardIsNotFound) {
  // The board's right part beyond the image's edge: whole boards only.
  const Drawn cut = draw_board(9, 6, homography(48, 0, 0, 0, {700, 300}, {5.5, 4}), {800, 600});
  auto found = find_chessboard_corners_saddle(cut.image, 9, 6);
  ASSERT_FALSE(found.ok());
  EXPECT_EQ(found.error().code, "board_not_found");
  EXPECT_NE(found.error().message.find("9x6"), std::string::npos) << found.error().message;
  // An 11 x 8 board asked for as 9 x 6: not a window of it, which would mislabel the board.
  const Drawn bigger = draw_board(11, 8, homography(40, 3, 0, 0, {400, 300}, {6.5, 5}), {800, 600});
  found = find_chessboard_corners_saddle(bigger.image, 9, 6);
  ASSERT_FALSE(found.ok());
  EXPECT_EQ(found.error().code, "board_not_found");
  // ... and found when asked for as it is, in either orientation of the size.
  EXPECT_TRUE(find_chessboard_corners_saddle(bigger.image, 11, 8).ok());
  EXPECT_TRUE(find_chessboard_corners_saddle(bigger.image, 8, 11).ok());
}

TEST(SaddleCorners, SixteenBitInputGivesTheCornersOfItsEightBitStretch) {
  const int cols = 9, rows = 6;
  const Drawn d =
      draw_board(cols, rows, homography(44, 4, 0.01, 0.01, {400, 300}, {5.5, 4}), {800, 600});
  cv::Mat raw;  // a 12-bit sensor's DN with a black level of 256
  d.image.convertTo(raw, CV_16U, 14.0, 256);
  auto from8 = find_chessboard_corners_saddle(d.image, cols, rows);
  auto from16 = find_chessboard_corners_saddle(raw, cols, rows);
  ASSERT_TRUE(from8.ok() && from16.ok());
  const Fit f8 = fit(*from8, d.truth, cols, rows), f16 = fit(*from16, d.truth, cols, rows);
  EXPECT_LT(f8.rms_px, 0.05);
  EXPECT_LT(f16.rms_px, 0.05);
}

}  // namespace
}  // namespace camlab::calib
