// The 1-sigma of fx and of the field of view (calib/intrinsics_uncertainty.h) against
// their spread over repeated calibrations: the same board poses, fresh corner noise each
// time, solved again. 24 repeats estimate a standard deviation to about 15%, so the
// predicted sigma must lie within 0.6-1.6x of the spread seen.
#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "calib/intrinsics_uncertainty.h"
#include "calib/lens_model.h"
#include "calib/solver.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

double stddev(const std::vector<double>& v) {
  double mean = 0;
  for (double x : v) mean += x / v.size();
  double var = 0;
  for (double x : v) var += (x - mean) * (x - mean) / (v.size() - 1);
  return std::sqrt(var);
}

TEST(IntrinsicsUncertainty, PredictsTheSpreadOfRepeatedCalibrations) {
  const LensModel truth{
      "LENSMODEL_OPENCV4", {1000, 1000, 805, 598, -0.25, 0.08, 0.0005, -0.0004}, 1600, 1200};
  const BoardSpec board{10, 7, 0.05};
  testing::ViewSetSpec spec;
  spec.views = 12;
  spec.noise_px = 0;
  std::vector<std::array<double, 6>> poses;
  const CalibrationData clean = testing::make_views(truth, board, spec, &poses);
  ASSERT_EQ(poses.size(), 12u);
  constexpr double kNoisePx = 0.3;
  constexpr int kRepeats = 24;
  std::vector<double> fx, fov_h;
  std::optional<IntrinsicsUncertainty> predicted;
  std::mt19937 rng(11);
  for (int r = 0; r < kRepeats; ++r) {
    CalibrationData data = clean;
    for (size_t v = 0; v < poses.size(); ++v)
      data.views[v] =
          testing::observe(truth, board, poses[v], kNoisePx, 0, rng, clean.views[v].name);
    SolveOptions o;
    o.lensmodel = "LENSMODEL_OPENCV4";
    o.board_warp = false;
    auto s = solve(data, o);
    ASSERT_TRUE(s.ok()) << s.error().message;
    auto fov = field_of_view(s->model);
    ASSERT_TRUE(fov.ok());
    fx.push_back(s->model.intrinsics[0]);
    fov_h.push_back(fov->horizontal_deg);
    if (r == 0) {
      auto u = intrinsics_uncertainty(*s);
      ASSERT_TRUE(u.ok()) << u.error().message;
      ASSERT_TRUE(u->horizontal_fov_deg && u->vertical_fov_deg && u->diagonal_fov_deg);
      predicted = *u;
    }
  }
  const double fx_spread = stddev(fx), fov_spread = stddev(fov_h);
  std::printf(
      "fx: predicted %.4f px, spread %.4f px; horizontal FOV: predicted %.5f deg, "
      "spread %.5f deg\n",
      predicted->fx_px, fx_spread, *predicted->horizontal_fov_deg, fov_spread);
  EXPECT_GT(predicted->fx_px, 0.6 * fx_spread);
  EXPECT_LT(predicted->fx_px, 1.6 * fx_spread);
  EXPECT_GT(*predicted->horizontal_fov_deg, 0.6 * fov_spread);
  EXPECT_LT(*predicted->horizontal_fov_deg, 1.6 * fov_spread);
}

TEST(IntrinsicsUncertainty, NoCovarianceIsAnError) {
  Solution s;
  s.model = {"LENSMODEL_PINHOLE", {1000, 1000, 800, 600}, 1600, 1200};
  s.covariance_error = "not asked for";
  auto u = intrinsics_uncertainty(s);
  ASSERT_FALSE(u.ok());
  EXPECT_EQ(u.error().code, "no_covariance");
  EXPECT_NE(u.error().message.find("not asked for"), std::string::npos);
}

}  // namespace
}  // namespace camlab::calib
