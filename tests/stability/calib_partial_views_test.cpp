// Partial views at the imager's edges (docs/calibration.md): the same number of views,
// once with the boards cut off by the frame (their visible corners kept, as the ChArUco
// and marker-chessboard detectors keep them) and once with every board moved until it
// is whole on the imager (what a whole-board detector needs). Corners from the wide
// OPENCV8 truth by mrcal_project with fixed-seed noise (synthetic_views.h), poses from
// border_views.h. With the partial views the corners must cover >= 90% of the imager's
// border cells and the projection at the imager's four corners must be closer to the
// truth than with the whole boards.
#include <cstdio>

#include <gtest/gtest.h>

#include "border_views.h"
#include "calib/report.h"
#include "calib/solver.h"

namespace camlab::calib {
namespace {

struct Outcome {
  double border_coverage = 0;
  testing::BorderError error;
  int partial_views = 0;
};

Outcome calibrate_poses(const LensModel& truth, const BoardSpec& board,
                        const std::vector<std::array<double, 6>>& poses, double noise_px) {
  const CalibrationData data = testing::observe_poses(truth, board, poses, noise_px, 3);
  Outcome o;
  for (const auto& v : data.views) o.partial_views += v.present_count() < board.cols * board.rows;
  SolveOptions options;
  options.lensmodel = "LENSMODEL_OPENCV8";
  options.compute_covariance = false;
  auto s = solve(data, options);
  EXPECT_TRUE(s.ok()) << s.error().message;
  if (!s.ok()) return o;
  EXPECT_EQ(s->views_used.size(), poses.size());
  const CalibrationReport report = make_report(data, *s, 0);
  o.border_coverage = report.edge_coverage;
  o.error = testing::border_error(truth, s->model);
  return o;
}

TEST(CalibPartialViews, CutBoardsCoverTheBorderAndPinTheCorners) {
  const LensModel truth = testing::wide_opencv8_truth();
  const BoardSpec board{10, 7, 0.06};  // the ChArUco example board's inner corners
  testing::BorderPlan plan;
  const auto cut = testing::border_plan_poses(truth, board, plan);
  ASSERT_EQ(cut.size(), size_t(plan.views));
  std::vector<std::array<double, 6>> whole;
  for (const auto& rt : cut) {
    whole.push_back(testing::whole_twin(truth, board, rt));
    ASSERT_TRUE(testing::board_whole(truth, board, whole.back()));
  }
  const Outcome a = calibrate_poses(truth, board, cut, plan.noise_px);
  const Outcome b = calibrate_poses(truth, board, whole, plan.noise_px);
  std::printf(
      "%d views: cut boards (%d partial): border coverage %.0f%%, imager corners %.3f px RMS "
      "(max %.3f), border %.3f px RMS (max %.3f)\n"
      "          whole boards (%d partial): border coverage %.0f%%, imager corners %.3f px RMS "
      "(max %.3f), border %.3f px RMS (max %.3f)\n",
      plan.views, a.partial_views, 100 * a.border_coverage, a.error.corners_rms_px,
      a.error.corners_max_px, a.error.border_rms_px, a.error.border_max_px, b.partial_views,
      100 * b.border_coverage, b.error.corners_rms_px, b.error.corners_max_px,
      b.error.border_rms_px, b.error.border_max_px);
  EXPECT_GE(a.partial_views, plan.border_views / 2);  // the plan does cut boards off
  EXPECT_EQ(b.partial_views, 0);
  EXPECT_GE(a.border_coverage, 0.9);
  EXPECT_LT(b.border_coverage, a.border_coverage);
  EXPECT_LT(a.error.corners_rms_px, b.error.corners_rms_px);
  EXPECT_LT(a.error.border_rms_px, b.error.border_rms_px);
}

}  // namespace
}  // namespace camlab::calib
