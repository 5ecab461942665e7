// The residual-pattern score that gates `--model auto`'s spline cross-check
// (calib/residual_pattern.h): residuals of pure noise score low, the misfit of a model
// that cannot describe the lens scores high, and the statistic reads the corners' weights.
#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "calib/residual_pattern.h"
#include "calib/solver.h"
#include "synthetic_views.h"

namespace camlab::calib {
namespace {

const BoardSpec kBoard{10, 8, 0.04};

// A solution whose residuals are given directly: every corner of every view an inlier.
Solution with_residuals(const CalibrationData& data,
                        const std::function<std::array<double, 2>(int, int)>& residual) {
  Solution s;
  for (int v = 0; v < static_cast<int>(data.views.size()); ++v)
    for (int k = 0; k < static_cast<int>(data.views[v].corners.size()); ++k) {
      if (!data.views[v].corners[k].present) continue;
      const auto r = residual(v, k);
      s.residuals.push_back({v, k, r[0], r[1], false});
    }
  return s;
}

TEST(ResidualPattern, NoiseScoresLowAndASmoothMisfitHigh) {
  testing::ViewSetSpec spec;
  spec.views = 30;
  spec.noise_px = 0;
  const CalibrationData data = testing::make_views(testing::wide_opencv8_truth(), kBoard, spec);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0, 0.1);
  const Solution noisy = with_residuals(data, [&](int, int) {
    return std::array<double, 2>{noise(rng), noise(rng)};
  });
  const ResidualPattern n = residual_pattern(data, noisy);
  EXPECT_GT(n.cells, 50);
  EXPECT_LT(std::fabs(n.z), 3.5) << "independent noise: z is about 0 +- 1";
  EXPECT_LT(std::fabs(n.neighbour_z), 3.5);
  EXPECT_LT(n.z + n.neighbour_z, 2.0);

  // A radial misfit of 0.05 px at the imager's edge, half the noise, under the same noise:
  // the same sign wherever the boards crossed the same part of the imager.
  const Solution misfit = with_residuals(data, [&](int v, int k) {
    const auto& c = data.views[v].corners[k];
    const double x = (c.x_px - 640) / 640, y = (c.y_px - 400) / 640;
    return std::array<double, 2>{0.05 * x * (x * x + y * y) + noise(rng),
                                 0.05 * y * (x * x + y * y) + noise(rng)};
  });
  const ResidualPattern m = residual_pattern(data, misfit);
  EXPECT_GT(m.z + m.neighbour_z, 2.0) << "z " << m.z << ", neighbour z " << m.neighbour_z;
}

TEST(ResidualPattern, AFittedModelThatCannotDescribeTheLensScoresAboveTheGate) {
  testing::ViewSetSpec spec;
  spec.views = 30;
  spec.noise_px = 0.1;
  const CalibrationData data = testing::make_views(testing::wide_opencv8_truth(), kBoard, spec);
  SolveOptions o;
  o.compute_covariance = false;
  o.lensmodel = "LENSMODEL_OPENCV8";
  auto right = solve(data, o);
  o.lensmodel = "LENSMODEL_OPENCV4";  // a 103-deg lens: OPENCV4 leaves a misfit at the edges
  auto wrong = solve(data, o);
  ASSERT_TRUE(right.ok() && wrong.ok());
  const ResidualPattern r = residual_pattern(data, *right), w = residual_pattern(data, *wrong);
  std::printf("OPENCV8 (the truth's model): score %.1f; OPENCV4: score %.1f\n", r.z + r.neighbour_z,
              w.z + w.neighbour_z);
  EXPECT_LT(r.z + r.neighbour_z, 2.0);
  EXPECT_GT(w.z + w.neighbour_z, 2.0);
}

TEST(ResidualPattern, TooFewResidualsScoreZero) {
  CalibrationData data;
  data.board = kBoard;
  data.imager_width_px = 1280;
  data.imager_height_px = 800;
  const ResidualPattern p = residual_pattern(data, Solution{});
  EXPECT_EQ(p.z, 0);
  EXPECT_EQ(p.neighbour_z, 0);
  EXPECT_EQ(p.residuals, 0);
}

}  // namespace
}  // namespace camlab::calib
