// Edge measurement on synthetic edges with known disk diameter and baseline blur:
// the baseline inversion against its forward map, the diameter against the truth under
// noise, and every rejection and flag on the case that must raise it.
#include "analysis/edge/edge_measure.h"

#include <cmath>
#include <limits>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace camlab::analysis {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace defocus_test {

constexpr double kPi = std::numbers::pi;

// A vertical-ish edge (5 degrees off the column axis) through the image centre, with its
// segment spanning `length` px, and Gaussian noise so that contrast / noise = cnr.
struct SyntheticEdge {
  cv::Mat image;
  EdgeSegment segment;
};

SyntheticEdge make_edge(int size, double diameter, double sigma_b, double cnr, double length,
                        unsigned seed, double angle_deg = 95.0, double light = 1000.0) {
  const double a = angle_deg * kPi / 180.0;
  const double c = 0.5 * (size - 1) + 0.31;
  SyntheticEdge e;
  e.image = render_edge_model(size, size, EdgeLine{c, c, a}, diameter, sigma_b, 100.0, light);
  if (cnr > 0) {
    cv::Mat noise(size, size, CV_32F);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, (light - 100.0) / cnr);
    e.image += noise;
  }
  e.segment.name = "edge";
  e.segment.start_x_px = c - 0.5 * length * std::cos(a);
  e.segment.start_y_px = c - 0.5 * length * std::sin(a);
  e.segment.end_x_px = c + 0.5 * length * std::cos(a);
  e.segment.end_y_px = c + 0.5 * length * std::sin(a);
  return e;
}

TEST(BaselineBlur, InversionUndoesTheForwardMap) {
  for (double sigma : {0.7, 1.5}) {
    for (double d : {2.0, 6.0, 15.0}) {
      auto app = apparent_diameter_px(d, sigma, 0.1);
      ASSERT_TRUE(app.ok());
      EXPECT_GT(*app, d);  // the Gaussian only widens
      auto inv = remove_baseline_blur(*app, sigma, 0.1);
      ASSERT_TRUE(inv.ok());
      EXPECT_FALSE(inv->at_baseline);
      EXPECT_NEAR(inv->diameter_px, d, 2e-4) << "sigma " << sigma;
      // The slope maps sigmas: check it against a central difference of the forward map.
      auto up = apparent_diameter_px(d + 0.1, sigma, 0.1),
           down = apparent_diameter_px(d - 0.1, sigma, 0.1);
      ASSERT_TRUE(up.ok() && down.ok());
      EXPECT_NEAR(inv->slope, (*up - *down) / 0.2, 0.02);
      EXPECT_GT(inv->slope, 0.0);
      EXPECT_LE(inv->slope, 1.0 + 1e-3);
    }
  }
}

TEST(BaselineBlur, ZeroSigmaIsIdentityAndSharpEdgeReadsAtBaseline) {
  auto same = remove_baseline_blur(4.2, 0.0, 0.3);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->diameter_px, 4.2);
  auto zero = apparent_diameter_px(0.0, 1.0, 0.1);
  ASSERT_TRUE(zero.ok());
  // A Gaussian's 10-90 width over a disk's: D_app(0) is near 3 sigma.
  EXPECT_GT(*zero, 2.5);
  EXPECT_LT(*zero, 4.0);
  auto inv = remove_baseline_blur(*zero - 0.05, 1.0, 0.1);
  ASSERT_TRUE(inv.ok());
  EXPECT_TRUE(inv->at_baseline);
  EXPECT_EQ(inv->diameter_px, 0.0);
  EXPECT_FALSE(remove_baseline_blur(NAN, 1.0, 0.0).ok());
}

TEST(MeasureEdge, DiameterWithinTolerancesAtCnr50WithBaseline) {
  // Truth D with a baseline of 1 px: bias and spread over noise draws, CI coverage.
  for (double d : {3.0, 12.0}) {
    double sum = 0, sum2 = 0;
    int covered = 0;
    const int draws = 12;
    for (int k = 0; k < draws; ++k) {
      const SyntheticEdge e = make_edge(200, d, 1.0, 50.0, 180.0, 100 + k);
      EdgeMeasureOptions o;
      o.baseline_sigma_px = 1.0;
      auto m = measure_edge(e.image, e.segment, {}, o);
      ASSERT_TRUE(m.ok());
      ASSERT_EQ(m->status, kEdgeOk) << m->message;
      sum += m->diameter_px;
      sum2 += m->diameter_px * m->diameter_px;
      covered += m->ci_low_px <= d && d <= m->ci_high_px;
      EXPECT_GT(m->apparent_diameter_px, m->diameter_px);
      EXPECT_GE(m->half_width_px, 0.5 * d + 6.0);
    }
    const double mean = sum / draws, spread = std::sqrt(std::max(0.0, sum2 / draws - mean * mean));
    EXPECT_NEAR(mean, d, std::max(0.05, 0.01 * d)) << "D " << d;
    EXPECT_LT(spread, 0.08) << "D " << d;
    EXPECT_GE(covered, draws - 3);
  }
}

TEST(MeasureEdge, LargeBlurGrowsTheWindow) {
  const SyntheticEdge e = make_edge(240, 30.0, 0.0, 100.0, 220.0, 5);
  auto m = measure_edge(e.image, e.segment, {}, {});
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->status, kEdgeOk) << m->message;
  EXPECT_NEAR(m->diameter_px, 30.0, 0.3);
  EXPECT_GE(m->half_width_px, 21.0);
}

TEST(MeasureEdge, ShortTargetIsRejectedAsWindowTooSmall) {
  // A 40 px target cannot hold a 30 px blur with flat level beside it.
  SyntheticEdge e = make_edge(200, 30.0, 0.0, 100.0, 40.0, 6);
  e.segment.max_half_width_px = 20.0;
  auto m = measure_edge(e.image, e.segment, {}, {});
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeWindowTooSmall) << m->message;
  EXPECT_FALSE(m->measured());
  EXPECT_FALSE(m->message.empty());
}

TEST(MeasureEdge, NeighbourWithinTheBlurIsFittedJointly) {
  // A bar 6 px wide blurred by 12 px: the two edges' blurs overlap, so the two are
  // fitted together with one diameter (edge_pair.h).
  const double a = 95.0 * kPi / 180.0, c = 100.31, size = 200;
  const cv::Mat left = render_edge_model(size, size, EdgeLine{c, c, a}, 12.0, 0.0, 0.0, 1.0);
  const cv::Mat right =
      render_edge_model(size, size, EdgeLine{c + 6.0 / std::sin(a), c, a}, 12.0, 0.0, 0.0, 1.0);
  const cv::Mat image = 100.0 + 900.0 * (left - right);  // dark outside, light in the bar
  EdgeSegment e1{"left",
                 c - 80 * std::cos(a),
                 c - 80 * std::sin(a),
                 c + 80 * std::cos(a),
                 c + 80 * std::sin(a),
                 0};
  EdgeSegment e2 = e1;
  e2.name = "right";
  e2.start_x_px += 6.0 / std::sin(a);
  e2.end_x_px += 6.0 / std::sin(a);
  const std::vector<EdgeSegment> all = {e1, e2};
  auto m = measure_edge(image, all[0], all, {});
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->status, kEdgeOk) << m->message;
  EXPECT_EQ(m->joint_with, "right");
  EXPECT_NEAR(m->joint_separation_px, 6.0, 0.01);
  EXPECT_NEAR(m->diameter_px, 12.0, 0.01);  // noise-free: the model is exact
  EXPECT_NEAR(m->fit.light_level - m->fit.dark_level, 900.0, 1.0);
}

TEST(MeasureEdge, NeighbourWithinTheBlurButFarFromParallelIsRejected) {
  const double a = 95.0 * kPi / 180.0, c = 100.31;
  const cv::Mat image = render_edge_model(200, 200, EdgeLine{c, c, a}, 12.0, 0.0, 100.0, 1000.0);
  const EdgeSegment e1{"edge",
                       c - 80 * std::cos(a),
                       c - 80 * std::sin(a),
                       c + 80 * std::cos(a),
                       c + 80 * std::sin(a),
                       0};
  // A segment 8 px to the side, 25 degrees off: it passes alongside within the blur.
  const double b = a + 25.0 * kPi / 180.0;
  const EdgeSegment e2{"slanted",
                       c - 8 - 10 * std::cos(b),
                       c - 10 * std::sin(b),
                       c - 8 + 10 * std::cos(b),
                       c + 10 * std::sin(b),
                       0};
  const std::vector<EdgeSegment> all = {e1, e2};
  auto m = measure_edge(image, all[0], all, {});
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeNeighbourOverlap) << m->message;
  EXPECT_NE(m->message.find("from parallel"), std::string::npos) << m->message;
}

TEST(MeasureEdge, BelowDiffractionFloorIsFlaggedNotMeasured) {
  const SyntheticEdge e = make_edge(160, 1.5, 0.0, 200.0, 140.0, 7);
  EdgeMeasureOptions o;
  o.airy_diameter_px = 3.0;
  auto m = measure_edge(e.image, e.segment, {}, o);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeBelowDiffraction) << m->message;
  EXPECT_NEAR(m->diameter_px, 1.5, 0.1);  // what the pixels show, kept for reference
}

TEST(MeasureEdge, InFocusEdgeReadsAtBaselineWithAnUpperBound) {
  const SyntheticEdge e = make_edge(160, 0.0, 1.2, 100.0, 140.0, 8);
  EdgeMeasureOptions o;
  o.baseline_sigma_px = 1.2;
  auto m = measure_edge(e.image, e.segment, {}, o);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeAtBaseline) << m->message;
  EXPECT_EQ(m->diameter_px, 0.0);
  EXPECT_TRUE(std::isfinite(m->ci_high_px));
  EXPECT_LT(m->ci_high_px, 2.0);
}

TEST(MeasureEdge, ClippedPixelsAreRejected) {
  SyntheticEdge e = make_edge(160, 4.0, 0.0, 100.0, 140.0, 9, 95.0, 1000.0);
  cv::min(e.image, 900.0, e.image);
  EdgeMeasureOptions o;
  o.saturation_level = 900.0;
  auto m = measure_edge(e.image, e.segment, {}, o);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeClipped);
}

TEST(MeasureEdge, InvalidInputIsAnError) {
  const SyntheticEdge e = make_edge(64, 2.0, 0.0, 0.0, 40.0, 1);
  EdgeSegment tiny = e.segment;
  tiny.end_x_px = tiny.start_x_px + 1;
  tiny.end_y_px = tiny.start_y_px + 1;
  EXPECT_FALSE(measure_edge(e.image, tiny, {}, {}).ok());
  EXPECT_FALSE(measure_edge(cv::Mat(), e.segment, {}, {}).ok());
  EdgeMeasureOptions bad;
  bad.baseline_sigma_px = NAN;
  EXPECT_FALSE(measure_edge(e.image, e.segment, {}, bad).ok());
}

// An interval whose upper end is infinite or wider than the window across the edge says
// nothing: reports say "unconstrained" (the review read [0.000, 8810527.724] px).
TEST(Defocus, AnIntervalPastTheWindowIsUnconstrained) {
  EdgeMeasurement m;
  m.half_width_px = 12;  // a 24 px window across the edge
  m.ci_high_px = 20;
  EXPECT_FALSE(m.upper_unconstrained());
  m.ci_high_px = 8810527.724;
  EXPECT_TRUE(m.upper_unconstrained());
  m.ci_high_px = std::numeric_limits<double>::infinity();
  EXPECT_TRUE(m.upper_unconstrained());
}

}  // namespace defocus_test
}  // namespace
}  // namespace camlab::analysis
