// Near-duplicate views: a board held still twice is one pose, whatever the noise or the
// labels' turn; a small deliberate tilt or shift is a new one. Views drawn through a
// pinhole lens with the test's own projection (synthetic_views.h), poses chosen here.
#include "calib/view_novelty.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

#include "synthetic_views.h"

namespace camlab::calib {
namespace {

const LensModel kLens{"LENSMODEL_PINHOLE", {900, 900, 639.5, 399.5}, 1280, 800};
const BoardSpec kBoard{10, 7, 0.03};

BoardView view_at(const cv::Vec3d& centre_m, double tilt_x_rad, double noise_px, unsigned seed) {
  std::mt19937 rng(seed);
  const auto rt = testing::pose_facing(centre_m, tilt_x_rad, 0.1, 0.05, kBoard);
  return testing::observe(kLens, kBoard, rt, noise_px, 0, rng, "view");
}

CalibrationData data_with(BoardView first) {
  CalibrationData data;
  data.board = kBoard;
  data.imager_width_px = kLens.width_px;
  data.imager_height_px = kLens.height_px;
  data.views.push_back(std::move(first));
  return data;
}

TEST(ViewNovelty, TheSamePoseWithOtherNoiseIsANearDuplicate) {
  const cv::Vec3d centre(0.05, -0.02, 0.6);
  const CalibrationData data = data_with(view_at(centre, 0.3, 0.3, 1));
  const BoardView again = view_at(centre, 0.3, 0.3, 2);
  ASSERT_EQ(again.present_count(), 70);
  auto duplicate = find_near_duplicate(data, again);
  ASSERT_TRUE(duplicate.has_value());
  EXPECT_EQ(duplicate->view, 0);
  EXPECT_EQ(duplicate->shared_corners, 70);
  EXPECT_NEAR(duplicate->rms_px, 0.6, 0.2) << "two draws of 0.3 px noise per axis";
  EXPECT_FALSE(duplicate->rotated_labels);
  EXPECT_NE(describe(*duplicate, data).find("view 0"), std::string::npos);
}

// A chessboard's labels can come out turned 180 deg: the same corners, numbered backwards.
// A ChArUco board's ids cannot.
TEST(ViewNovelty, LabelsTurnedHalfRoundAreStillTheSamePoseForAChessboardOnly) {
  const cv::Vec3d centre(0.0, 0.0, 0.7);
  const CalibrationData data = data_with(view_at(centre, 0.2, 0.2, 3));
  BoardView turned = view_at(centre, 0.2, 0.2, 4);
  std::reverse(turned.corners.begin(), turned.corners.end());
  auto duplicate = find_near_duplicate(data, turned);
  ASSERT_TRUE(duplicate.has_value());
  EXPECT_TRUE(duplicate->rotated_labels);
  turned.detector = "charuco";
  EXPECT_FALSE(find_near_duplicate(data, turned).has_value());
}

// A board 0.6 m away filling 40% of the imager: tolerance 2.6 px. 2 deg of wobble moves
// its corners 1.1 px, a 10 deg tilt 6.4 px, a 2 cm shift 31 px.
TEST(ViewNovelty, WobbleIsTheSamePoseADeliberateTiltOrShiftANewOne) {
  const cv::Vec3d centre(0.05, -0.02, 0.6);
  const BoardView first = view_at(centre, 0.3, 0.2, 5);
  const CalibrationData data = data_with(first);
  const double extent_px = near_duplicate_tolerance_px(first) / 0.005;
  EXPECT_GT(extent_px, 450);
  EXPECT_LT(extent_px, 560);
  EXPECT_TRUE(find_near_duplicate(data, view_at(centre, 0.3 + 2 * M_PI / 180, 0.2, 6)));
  EXPECT_FALSE(find_near_duplicate(data, view_at(centre, 0.3 + 10 * M_PI / 180, 0.2, 6)));
  EXPECT_FALSE(find_near_duplicate(data, view_at(centre + cv::Vec3d(0.02, 0, 0), 0.3, 0.2, 7)));
}

// A far board is small: its tolerance is the 1 px floor, above two detections' noise, and
// a 20 deg tilt (2.2 px at 4 m) is a new pose.
TEST(ViewNovelty, AFarBoardsToleranceIsOnePixel) {
  const cv::Vec3d centre(0.0, 0.0, 4.0);
  const BoardView far = view_at(centre, 0.0, 0.2, 8);
  ASSERT_EQ(far.present_count(), 70);
  EXPECT_DOUBLE_EQ(near_duplicate_tolerance_px(far), 1.0);
  const CalibrationData data = data_with(far);
  EXPECT_TRUE(find_near_duplicate(data, view_at(centre, 0.0, 0.2, 9)).has_value());
  EXPECT_FALSE(find_near_duplicate(data, view_at(centre, 20 * M_PI / 180, 0.2, 10)).has_value());
}

// A view that shows mostly corners the earlier one did not (the board moved half out of
// the earlier frame's crop) adds them, even where the corners both show agree.
TEST(ViewNovelty, AViewOfMostlyNewCornersIsNotADuplicate) {
  const cv::Vec3d centre(0.0, 0.0, 0.7);
  BoardView partial = view_at(centre, 0.2, 0.2, 11);
  for (size_t j = 0; j < partial.corners.size(); ++j)
    if (j % 10 >= 4) partial.corners[j].present = false;  // the left 4 columns only
  const CalibrationData data = data_with(partial);
  EXPECT_FALSE(find_near_duplicate(data, view_at(centre, 0.2, 0.2, 12)).has_value());
  // The other way round, the partial view repeats what the whole one showed.
  const CalibrationData whole = data_with(view_at(centre, 0.2, 0.2, 13));
  EXPECT_TRUE(find_near_duplicate(whole, partial).has_value());
}

}  // namespace
}  // namespace camlab::calib
