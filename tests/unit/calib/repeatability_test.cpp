// Repeatability without a truth (calib/repeatability.h) on views drawn through a known lens:
// the halves agree as the noise allows, each view is predicted about as well as the views
// fit, a view of another board stands out in leave-one-out, and too few views say so.
#include <cmath>

#include <gtest/gtest.h>

#include "calib/repeatability.h"
#include "calib/solver.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace repeatability_test {

const BoardSpec kBoard{10, 7, 0.05};
const LensModel kTruth{
    "LENSMODEL_OPENCV4", {1000, 1000, 805, 598, -0.25, 0.08, 0.0005, -0.0004}, 1600, 1200};

CalibrationData views(int n, uint32_t seed) {
  testing::ViewSetSpec spec;
  spec.views = n;
  spec.noise_px = 0.2;
  spec.seed = seed;
  return testing::make_views(kTruth, kBoard, spec);
}

// The repeatability of an OPENCV4 solve of `data`.
Result<Repeatability> repeatability_of(const CalibrationData& data, Solution* full) {
  SolveOptions o;
  o.lensmodel = "LENSMODEL_OPENCV4";
  auto s = solve(data, o);
  if (!s) return s.error();
  *full = *s;
  return measure_repeatability(data, o, *full);
}

TEST(Repeatability, HalvesAgreeAndViewsArePredictedAsTheNoiseAllows) {
  const auto data = views(20, 3);
  Solution full;
  auto r = repeatability_of(data, &full);
  ASSERT_TRUE(r.ok()) << r.error().message;
  ASSERT_TRUE(r->odd_even_ran) << r->odd_even_reason;
  EXPECT_EQ(r->odd_views + r->even_views, 20);
  // Each half's projection is off the truth by its own noise-driven error; two such are
  // a fraction of a pixel apart on 10 views of 70 corners at 0.2 px.
  EXPECT_LT(r->odd_even_rms_px, 0.15);
  // Both halves near the truth's focal length.
  for (double f : r->halves_focal_px) EXPECT_NEAR(f, 1000, 5);
  ASSERT_EQ(r->left_out.size(), 20u);
  // A held-out view is predicted no better than the views fit, and not much worse: the
  // noise (0.2 px per axis, 0.28 px per corner) plus the lens's own error.
  EXPECT_GE(r->left_out_rms_px, 0.95 * full.rms_px);
  EXPECT_LT(r->left_out_rms_px, 1.3 * full.rms_px);
  EXPECT_GT(r->seconds, 0);
}

TEST(Repeatability, AViewOfABentBoardStandsOutInLeaveOneOut) {
  auto data = views(14, 5);
  // View 6's board was bent: its corners sag by up to 2.5 px towards its middle row, a
  // shape no pose of a flat board gives.
  BoardView& bent = data.views[6];
  bent.name = "bent_board.png";
  for (int j = 0; j < kBoard.rows; ++j)
    for (int i = 0; i < kBoard.cols; ++i) {
      const double u = (i - 0.5 * (kBoard.cols - 1)) / (0.5 * (kBoard.cols - 1));
      bent.corners[j * kBoard.cols + i].y_px += 2.5 * (1 - u * u);
    }
  Solution full;
  auto r = repeatability_of(data, &full);
  ASSERT_TRUE(r.ok()) << r.error().message;
  const ViewPrediction* worst = nullptr;
  for (const auto& v : r->left_out)
    if (!worst || v.rms_px > worst->rms_px) worst = &v;
  ASSERT_NE(worst, nullptr);
  EXPECT_EQ(worst->view, "bent_board.png");
  double others = 0;
  for (const auto& v : r->left_out)
    if (&v != worst) others = std::max(others, v.rms_px);
  EXPECT_GT(worst->rms_px, 2 * others);
}

TEST(Repeatability, TooFewViewsForHalvesSayWhy) {
  const auto data = views(6, 9);
  Solution full;
  auto r = repeatability_of(data, &full);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_FALSE(r->odd_even_ran);
  EXPECT_NE(r->odd_even_reason.find("6 views"), std::string::npos) << r->odd_even_reason;
  EXPECT_EQ(r->left_out.size(), 6u);
  const nlohmann::json j = to_json(*r);
  EXPECT_FALSE(j["odd_even"]["ran"].get<bool>());
  EXPECT_EQ(j["leave_one_out"]["views"], 6);
}

}  // namespace repeatability_test
}  // namespace
}  // namespace camlab::calib
