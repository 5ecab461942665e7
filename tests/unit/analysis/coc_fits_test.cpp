// C = k / N and V-curve fits against exact synthetic diameters and noisy draws around
// them (fixed seeds).
#include "analysis/defocus/coc_fits.h"

#include <cmath>
#include <random>
#include <vector>

#include <gtest/gtest.h>

namespace camlab::analysis {
namespace {

TEST(ApertureFit, RecoversKExactlyAndReportsConsistency) {
  const double k = 23.7;
  std::vector<BlurSample> s;
  for (double n : {2.0, 2.8, 4.0, 5.6, 8.0, 11.0}) s.push_back({n, k / n, 0.02});
  // A frame whose blur is below 1 px is left out.
  s.push_back({32.0, k / 32.0, 0.02});
  auto fit = fit_coc_vs_aperture(s);
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->k_px, k, 1e-12);
  EXPECT_EQ(fit->used_count, 6);
  EXPECT_FALSE(fit->used.back());
  EXPECT_LT(fit->max_abs_cn_deviation, 1e-12);
  EXPECT_GT(fit->k_sigma_px, 0.0);
}

TEST(ApertureFit, NoisyDrawsScatterAsTheReportedSigma) {
  const double k = 12.0, sigma = 0.03;
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, sigma);
  double sum = 0, sum2 = 0, sigma_sum = 0;
  const int draws = 400;
  for (int d = 0; d < draws; ++d) {
    std::vector<BlurSample> s;
    for (double n : {2.0, 2.8, 4.0, 5.6, 8.0}) s.push_back({n, k / n + noise(rng), sigma});
    auto fit = fit_coc_vs_aperture(s);
    ASSERT_TRUE(fit.ok());
    sum += fit->k_px;
    sum2 += fit->k_px * fit->k_px;
    sigma_sum += fit->k_sigma_px;
  }
  const double mean = sum / draws, spread = std::sqrt(sum2 / draws - mean * mean);
  EXPECT_NEAR(mean, k, 3 * spread / std::sqrt(draws));
  // sigma is floored at the unscaled one (chi2 < 1 is not used to shrink it).
  EXPECT_NEAR(spread, sigma_sum / draws, 0.3 * spread);
}

TEST(ApertureFit, InconsistentFrameShowsInItsDeviation) {
  std::vector<BlurSample> s = {{2, 6.0, 0.01}, {4, 3.0, 0.01}, {8, 1.5 * 1.1, 0.01}};
  auto fit = fit_coc_vs_aperture(s);
  ASSERT_TRUE(fit.ok());
  EXPECT_GT(fit->cn_deviation[2], 0.07);
  EXPECT_GT(fit->chi2_per_dof, 10.0);
}

TEST(ApertureFit, TooFewOrInvalidSamplesAreErrors) {
  std::vector<BlurSample> one = {{2, 6.0, 0.01}, {4, 0.5, 0.01}};
  auto fit = fit_coc_vs_aperture(one);
  ASSERT_FALSE(fit.ok());
  EXPECT_EQ(fit.error().code, "too_few_samples");
  std::vector<BlurSample> nan = {{2, NAN, 0.01}, {4, 3.0, NAN}, {8, 1.5, 0.01}};
  EXPECT_FALSE(fit_coc_vs_aperture(nan).ok());
  std::vector<BlurSample> negative = {{-2, 6.0, 0.01}, {4, 3.0, 0.01}};
  EXPECT_EQ(fit_coc_vs_aperture(negative).error().code, "invalid_argument");
}

TEST(VCurveFit, RecoversBestFocusAndSlopeExactly) {
  const double p0 = 103.37, slope = 0.42;
  std::vector<BlurSample> s;
  for (int p = 60; p <= 150; p += 10) s.push_back({double(p), slope * std::fabs(p - p0), 0.02});
  s.push_back({104.0, slope * std::fabs(104.0 - p0), 0.02});  // 0.26 px: below 1 px, left out
  auto fit = fit_v_curve(s);
  ASSERT_TRUE(fit.ok());
  EXPECT_NEAR(fit->best_position, p0, 1e-9);
  EXPECT_NEAR(fit->slope_px_per_step, slope, 1e-12);
  EXPECT_FALSE(fit->p0_at_end);
  EXPECT_EQ(fit->used_count, 10);
  EXPECT_FALSE(fit->used.back());
  EXPECT_GT(fit->left_count, 0);
  EXPECT_GT(fit->right_count, 0);
}

TEST(VCurveFit, NoisyDrawsWithinAHundredthStepAndSigmaHonest) {
  const double p0 = 47.8, slope = 0.5, sigma = 0.03;
  std::mt19937 rng(11);
  std::normal_distribution<double> noise(0.0, sigma);
  double sum = 0, sum2 = 0, sig = 0;
  const int draws = 300;
  for (int d = 0; d < draws; ++d) {
    std::vector<BlurSample> s;
    for (int p = 0; p <= 100; p += 5)
      s.push_back({double(p), slope * std::fabs(p - p0) + noise(rng), sigma});
    auto fit = fit_v_curve(s);
    ASSERT_TRUE(fit.ok());
    sum += fit->best_position;
    sum2 += fit->best_position * fit->best_position;
    sig += fit->best_position_sigma;
  }
  const double mean = sum / draws, spread = std::sqrt(sum2 / draws - mean * mean);
  EXPECT_NEAR(mean, p0, 0.01);
  EXPECT_NEAR(spread, sig / draws, 0.3 * spread);
}

TEST(VCurveFit, OneArmedSweepIsFlagged) {
  std::vector<BlurSample> s;
  for (int p = 0; p <= 40; p += 10) s.push_back({double(p), 0.3 * (80 - p), 0.02});
  auto fit = fit_v_curve(s);
  ASSERT_TRUE(fit.ok());
  EXPECT_TRUE(fit->p0_at_end);
  EXPECT_NEAR(fit->best_position, 80.0, 1e-9);
}

TEST(VCurveFit, TooFewSamplesIsAnError) {
  std::vector<BlurSample> s = {{0, 3, 0.01}, {10, 0.2, 0.01}, {20, 3, 0.01}};
  auto fit = fit_v_curve(s);
  ASSERT_FALSE(fit.ok());
  EXPECT_EQ(fit.error().code, "too_few_samples");
}

}  // namespace
}  // namespace camlab::analysis
