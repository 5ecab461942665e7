// Joint fit of two overlapping edges (analysis/edge/edge_pair.h) and its use by measure_edge
// (edge/edge_measure.h) against the truth: two parallel edges rendered with the exact model (the
// superposition of two pixel-integrated pillbox steps), noise at contrast-to-noise 50.
#include "analysis/edge/edge_pair.h"

#include <cmath>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "analysis/edge/edge_measure.h"

namespace camlab::analysis {
namespace {

constexpr double kAngle = 93.0 * std::numbers::pi / 180.0;  // 3 degrees off the pixel grid
constexpr double kCentre = 110.27;

// A bright bar `width` px wide (level 1800 on 1000) under a disk of `diameter` px.
cv::Mat bar(double diameter, double width, unsigned seed, double cnr = 50.0) {
  const double shift = width / std::sin(kAngle);
  const cv::Mat left =
      render_edge_model(220, 220, EdgeLine{kCentre, kCentre, kAngle}, diameter, 0.0, 0.0, 1.0);
  const cv::Mat right = render_edge_model(220, 220, EdgeLine{kCentre + shift, kCentre, kAngle},
                                          diameter, 0.0, 0.0, 1.0);
  cv::Mat image = 1000.0 - 800.0 * (left - right);
  cv::Mat noise(image.size(), CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 800.0 / cnr);
  return image + noise;
}

std::vector<EdgeSegment> bar_edges(double width) {
  const double shift = width / std::sin(kAngle), c = std::cos(kAngle), s = std::sin(kAngle);
  return {{"left", kCentre - 80 * c, kCentre - 80 * s, kCentre + 80 * c, kCentre + 80 * s, 0},
          {"right", kCentre + shift - 80 * c, kCentre - 80 * s, kCentre + shift + 80 * c,
           kCentre + 80 * s, 0}};
}

// Bias over noise draws within the limit (0.05 px or 1%, the larger) for bars
// narrower than, as wide as and wider than the blur, where one edge's window cannot hold
// its blur without the other's.
TEST(EdgePair, SharedDiameterIsUnbiasedWhereTheBlursOverlap) {
  struct Case {
    double diameter, width;
  };
  for (const Case& k : {Case{1.0, 4.0}, Case{3.0, 8.0}, Case{10.0, 2.0}, Case{10.0, 8.0},
                        Case{20.0, 8.0}, Case{30.0, 16.0}}) {
    const auto edges = bar_edges(k.width);
    double sum = 0, sum2 = 0;
    constexpr int kDraws = 4;
    for (int draw = 0; draw < kDraws; ++draw) {
      const cv::Mat image = bar(k.diameter, k.width, 50 + draw);
      auto m = measure_edge(image, edges[draw % 2], edges, {});
      ASSERT_TRUE(m.ok());
      ASSERT_EQ(m->status, kEdgeOk)
          << "D " << k.diameter << " width " << k.width << ": " << m->message;
      EXPECT_EQ(m->joint_with, edges[1 - draw % 2].name);
      EXPECT_NEAR(m->joint_separation_px, k.width, 0.25);
      sum += m->diameter_px;
      sum2 += m->diameter_px * m->diameter_px;
    }
    const double mean = sum / kDraws,
                 spread = std::sqrt(std::max(0.0, sum2 / kDraws - mean * mean));
    // The mean of 4 draws carries spread / 2 of noise besides any bias.
    EXPECT_NEAR(mean, k.diameter, std::max(0.05, 0.01 * k.diameter) + spread)
        << "D " << k.diameter << " width " << k.width << " spread " << spread;
  }
}

// The pair fit alone: levels, lines and an honest sigma.
TEST(EdgePair, FitRecoversLevelsLinesAndAnHonestSigma) {
  const cv::Mat image = bar(6.0, 5.0, 7);
  EdgePairFitOptions o;
  o.half_length_px = 60;
  o.across_min_px = -20;  // line b lies on line a's -n side (n = (-sin a, cos a))
  o.across_max_px = 12;
  auto f =
      fit_pillbox_edge_pair(image, EdgeLine{kCentre + 0.4, kCentre, kAngle + 0.01},
                            EdgeLine{kCentre + 5.0 / std::sin(kAngle) - 0.3, kCentre, kAngle}, o);
  ASSERT_TRUE(f.ok()) << f.error().message;
  EXPECT_NEAR(f->diameter_px, 6.0, 4 * f->diameter_sigma_px + 0.01);
  EXPECT_GT(f->diameter_sigma_px, 0.005);
  EXPECT_LT(f->diameter_sigma_px, 0.08);
  EXPECT_NEAR(f->separation_px, 5.0, 0.1);
  // Order as given: a is the left edge; levels run from its -n side (right, since the
  // normal points to -x) across the bar to the left.
  EXPECT_NEAR(f->level_0, 1000, 10);
  EXPECT_NEAR(f->level_1, 1800, 15);
  EXPECT_NEAR(f->level_2, 1000, 10);
  EXPECT_NEAR(f->line_a.x_px, kCentre, 0.1);
  EXPECT_LT(f->diameter_vif, 50);
  EXPECT_GT(f->diameter_profile_ratio, 0.1);
}

// Where the bar's width and the blur trade off (a 1.6 px bar under a 2 px disk: another
// (width, D) fits the pixels as well), the edge stays rejected, with the reason.
TEST(EdgePair, IllConditionedPairStaysRejected) {
  const auto edges = bar_edges(1.6);
  for (unsigned draw = 0; draw < 3; ++draw) {
    auto m = measure_edge(bar(2.0, 1.6, 90 + draw), edges[0], edges, {});
    ASSERT_TRUE(m.ok());
    EXPECT_EQ(m->status, kEdgeNeighbourOverlap);
    EXPECT_NE(m->message.find("ill-conditioned"), std::string::npos) << m->message;
    EXPECT_FALSE(std::isnan(m->diameter_px));
  }
}

// Two edges far from parallel are not fitted jointly.
TEST(EdgePair, EdgesFarFromParallelAreNotAPair) {
  const cv::Mat image = bar(4.0, 6.0, 3);
  EdgePairFitOptions o;
  auto f = fit_pillbox_edge_pair(image, EdgeLine{kCentre, kCentre, kAngle},
                                 EdgeLine{kCentre + 6, kCentre, kAngle + 0.5}, o);
  ASSERT_FALSE(f.ok());
  EXPECT_EQ(f.error().code, kErrInvalidArgument);
}

}  // namespace
}  // namespace camlab::analysis
