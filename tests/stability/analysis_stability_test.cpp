// Hard cases for the optics measurements (docs/physics.md): each gives the
// right answer or a specific status/error, and never a NaN.
#include <cmath>
#include <limits>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "analysis/defocus/coc_fits.h"
#include "analysis/edge/edge_measure.h"
#include "analysis/exposure/exposure.h"

namespace camlab::analysis {
namespace {

constexpr double kPi = std::numbers::pi;

struct Case {
  cv::Mat image;
  EdgeSegment segment;
};

Case edge_case(int size, double diameter, double angle_deg, double sigma_b, double cnr,
               unsigned seed) {
  const double a = angle_deg * kPi / 180.0, c = 0.5 * (size - 1) + 0.27;
  Case k;
  k.image = render_edge_model(size, size, EdgeLine{c, c, a}, diameter, sigma_b, 200.0, 1200.0);
  cv::Mat noise(size, size, CV_32F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, 1000.0 / cnr);
  k.image += noise;
  const double half = 0.45 * size;
  k.segment = {"edge",
               c - half * std::cos(a),
               c - half * std::sin(a),
               c + half * std::cos(a),
               c + half * std::sin(a),
               0};
  return k;
}

void expect_finite(const EdgeMeasurement& m) {
  for (double v : {m.diameter_px, m.apparent_diameter_px, m.ci_low_px, m.rms_residual})
    EXPECT_FALSE(std::isnan(v)) << m.status;
  EXPECT_FALSE(std::isnan(m.ci_high_px));
  EXPECT_FALSE(std::isnan(m.diameter_sigma_px));
}

TEST(AnalysisStability, SubPixelBlurIsMeasuredOrBoundedNeverNaN) {
  for (double d : {0.0, 0.3, 0.8}) {
    const Case k = edge_case(160, d, 95.0, 0.0, 50.0, 3);
    auto m = measure_edge(k.image, k.segment, {}, {});
    ASSERT_TRUE(m.ok());
    expect_finite(*m);
    EXPECT_EQ(m->status, kEdgeOk);
    // Near D = 0 the model changes as D^2: only a bound is meaningful; it must hold.
    EXPECT_LE(m->ci_low_px, d + 0.05);
    EXPECT_LT(std::fabs(m->diameter_px - d), 0.25) << d;
  }
}

TEST(AnalysisStability, VeryLargeBlurIsMeasuredWithAWideWindow) {
  const Case k = edge_case(320, 50.0, 95.0, 0.0, 100.0, 4);
  auto m = measure_edge(k.image, k.segment, {}, {});
  ASSERT_TRUE(m.ok());
  ASSERT_EQ(m->status, kEdgeOk) << m->message;
  EXPECT_NEAR(m->diameter_px, 50.0, 0.5);
}

TEST(AnalysisStability, EdgesAtZeroAndFortyFiveDegrees) {
  for (double angle : {90.0, 0.0, 45.0, 135.0}) {
    const Case k = edge_case(160, 4.0, angle, 0.0, 50.0, 5);
    auto m = measure_edge(k.image, k.segment, {}, {});
    ASSERT_TRUE(m.ok());
    ASSERT_EQ(m->status, kEdgeOk) << angle << ": " << m->message;
    EXPECT_NEAR(m->diameter_px, 4.0, 0.08) << angle;
  }
}

TEST(AnalysisStability, BaselineBlurLargerThanTheDefocus) {
  // A 2 px disk under a 1.5 px Gaussian: still recovered (wider interval), not 5 px.
  const Case k = edge_case(200, 2.0, 95.0, 1.5, 100.0, 6);
  EdgeMeasureOptions o;
  o.baseline_sigma_px = 1.5;
  auto m = measure_edge(k.image, k.segment, {}, o);
  ASSERT_TRUE(m.ok());
  expect_finite(*m);
  ASSERT_TRUE(m->status == kEdgeOk || m->status == kEdgeAtBaseline) << m->message;
  EXPECT_GT(m->apparent_diameter_px, 4.0)
      << m->status << " D " << m->diameter_px << " sigma " << m->diameter_sigma_px;
  // Under a Gaussian wider than the disk, D_app changes slowly with D (slope ~0.2), so
  // D is poorly determined; it must stay within 3 sigma of the truth.
  EXPECT_NEAR(m->diameter_px, 2.0, 3.0 * m->diameter_sigma_px)
      << m->status << " D " << m->diameter_px << " sigma " << m->diameter_sigma_px << " app "
      << m->apparent_diameter_px;
}

TEST(AnalysisStability, DiffractionLimitedApertureIsFlagged) {
  const Case k = edge_case(160, 2.0, 95.0, 0.0, 80.0, 7);
  EdgeMeasureOptions o;
  o.airy_diameter_px = 2.44 * 0.55 * 22 / 4.0;  // f/22, 4 um pixels: 7.4 px
  auto m = measure_edge(k.image, k.segment, {}, o);
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeBelowDiffraction);
  EXPECT_FALSE(m->measured());
}

// Bars narrower than the blur: their two edges are fitted jointly with one diameter
// (edge_pair.h) when the data determine it -- the right answer -- and stay rejected with
// the reason when the bar's width and the blur trade off. Never a silent wrong number.
TEST(AnalysisStability, BarNarrowerThanTheBlurIsMeasuredJointlyOrRejected) {
  const double a = 93.0 * kPi / 180.0, c = 100.27;
  struct Case {
    double width, diameter;
    bool measurable;
  };
  for (const Case& k : {Case{4.0, 10.0, true}, Case{2.0, 10.0, true}, Case{1.6, 2.0, false}}) {
    const double shift = k.width / std::sin(a);
    const cv::Mat left = render_edge_model(200, 200, EdgeLine{c, c, a}, k.diameter, 0.0, 0.0, 1.0);
    const cv::Mat right =
        render_edge_model(200, 200, EdgeLine{c + shift, c, a}, k.diameter, 0.0, 0.0, 1.0);
    cv::Mat image = 1000.0 - 800.0 * (left - right);
    cv::Mat noise(image.size(), CV_32F);
    cv::RNG rng(21);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 800.0 / 50.0);
    image += noise;
    std::vector<EdgeSegment> edges = {{"a", c - 80 * std::cos(a), c - 80 * std::sin(a),
                                       c + 80 * std::cos(a), c + 80 * std::sin(a), 0},
                                      {"b", c + shift - 80 * std::cos(a), c - 80 * std::sin(a),
                                       c + shift + 80 * std::cos(a), c + 80 * std::sin(a), 0}};
    for (const EdgeSegment& e : edges) {
      auto m = measure_edge(image, e, edges, {});
      ASSERT_TRUE(m.ok());
      expect_finite(*m);
      if (k.measurable) {
        ASSERT_EQ(m->status, kEdgeOk) << m->message;
        EXPECT_EQ(m->joint_with, e.name == "a" ? "b" : "a");
        EXPECT_NEAR(m->diameter_px, k.diameter,
                    std::max(0.05, 0.01 * k.diameter) + 3 * m->diameter_sigma_px);
      } else {
        EXPECT_EQ(m->status, kEdgeNeighbourOverlap) << m->diameter_px;
        EXPECT_NE(m->message.find("ill-conditioned"), std::string::npos) << m->message;
      }
    }
  }
}

TEST(AnalysisStability, DarkFrameAndNaNPixelsGiveAStatusNotNaN) {
  Case k = edge_case(128, 3.0, 95.0, 0.0, 50.0, 8);
  cv::Mat dark(128, 128, CV_32F, cv::Scalar(0.0));
  cv::RNG rng(1);
  rng.fill(dark, cv::RNG::NORMAL, 0.0, 2.0);
  auto m = measure_edge(dark, k.segment, {}, {});
  ASSERT_TRUE(m.ok());
  EXPECT_EQ(m->status, kEdgeFitFailed);
  EXPECT_NE(m->message.find("no_contrast"), std::string::npos) << m->message;
  expect_finite(*m);
  // A few NaN pixels (a dead-pixel map) are skipped by the fit.
  for (int i = 0; i < 30; ++i)
    k.image.at<float>(10 + 3 * i, 60 + i % 7) = std::numeric_limits<float>::quiet_NaN();
  auto n = measure_edge(k.image, k.segment, {}, {});
  ASSERT_TRUE(n.ok());
  EXPECT_EQ(n->status, kEdgeOk);
  EXPECT_NEAR(n->diameter_px, 3.0, 0.1);
}

TEST(AnalysisStability, VCurveWithItsMinimumAtTheEndOfTheSweepIsFlagged) {
  std::vector<BlurSample> s;
  for (int p = 0; p <= 100; p += 10)
    s.push_back({double(p), 0.2 * std::fabs(p - 100.0) + 0.0, 0.03});
  auto fit = fit_v_curve(s);
  ASSERT_TRUE(fit.ok());
  EXPECT_TRUE(fit->p0_at_end);
  EXPECT_NEAR(fit->best_position, 100.0, 0.5);
  // Flat (no V at all): an error, not a number.
  std::vector<BlurSample> flat;
  for (int p = 0; p <= 100; p += 10) flat.push_back({double(p), 3.0, 0.03});
  auto none = fit_v_curve(flat);
  if (none.ok()) {
    EXPECT_TRUE(none->p0_at_end || none->chi2_per_dof > 10) << none->best_position;
  } else {
    EXPECT_EQ(none.error().code, "no_v_shape");
  }
}

TEST(AnalysisStability, ExposureDarkFramesAndClippedEverywhere) {
  // Dark frames only: photon transfer refuses.
  std::vector<PairStats> dark(5, PairStats{1000, 1, 0.0, 0.3, 4096, false});
  auto pt = fit_photon_transfer(dark);
  ASSERT_FALSE(pt.ok());
  EXPECT_EQ(pt.error().code, "no_signal");
  // Every frame clipped: bound + flag, never NaN; a zero-signal, zero-noise pixel: 0.
  HdrFrame f{cv::Mat(4, 4, CV_32F, cv::Scalar(4031.0)), 100.0, 1.0, 4031.0};
  HdrFrame g{cv::Mat(4, 4, CV_32F, cv::Scalar(4031.0)), 1000.0, 1.0, 4031.0};
  f.signal_dn.at<float>(0, 0) = 0.0f;
  g.signal_dn.at<float>(0, 0) = 0.0f;
  std::vector<HdrFrame> frames = {f, g};
  auto hdr = merge_hdr(frames, {0.2, 0.0});
  ASSERT_TRUE(hdr.ok());
  EXPECT_EQ(hdr->clipped_everywhere, 15);
  EXPECT_EQ(hdr->radiance.at<float>(0, 0), 0.0f);
  EXPECT_NEAR(hdr->radiance.at<float>(1, 1), 40.31, 1e-3);
  EXPECT_EQ(cv::countNonZero(hdr->radiance != hdr->radiance), 0);  // no NaN
}

}  // namespace
}  // namespace camlab::analysis
