// The renderer's radiometry against H = T x E, E ~ 1/N^2, linear gain, and photon
// statistics (variance = mean in electrons).
#include <gtest/gtest.h>

#include <cmath>

#include <opencv2/core.hpp>

#include "test_specs.h"

namespace camlab::mock {
namespace {

using testing::make_renderer;
using testing::pinhole_camera_json;
using testing::uniform_scene_json;

// Mean signal above black, in DN, over the whole frame.
double mean_above_black(const RenderedFrame& frame, int black_dn) {
  return cv::mean(frame.image)[0] - black_dn;
}

class ExposurePhysics : public ::testing::Test {
 protected:
  Renderer renderer = make_renderer(pinhole_camera_json(128, 128), uniform_scene_json());
  RenderOptions options;  // noise on: the means must hold with real noise
  RenderSettings base() {
    RenderSettings s = renderer.default_settings();
    s.exposure_us = 1000;
    s.f_number = 4.0;
    s.focus_position = 0;
    return s;
  }
};

TEST_F(ExposurePhysics, DoublingExposureTimeDoublesTheSignalBelowSaturation) {
  RenderSettings s = base();
  double previous = 0;
  for (double t_us : {1000.0, 2000.0, 4000.0, 8000.0}) {
    s.exposure_us = t_us;
    options.frame_number++;
    auto frame = renderer.render(s, 0, options);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    const double signal = mean_above_black(*frame, 64);
    ASSERT_LT(cv::mean(frame->image)[0], 0.8 * 4095) << "test must stay below saturation";
    if (previous > 0) {
      EXPECT_NEAR(signal / previous, 2.0, 0.02) << "at " << t_us << " us";
    }
    previous = signal;
  }
}

TEST_F(ExposurePhysics, OneStopOfFNumberHalvesTheSignal) {
  RenderSettings s = base();
  s.exposure_us = 8000;
  double previous = 0;
  for (double n : {2.0, 2.0 * std::sqrt(2.0), 4.0, 4.0 * std::sqrt(2.0), 8.0}) {
    s.f_number = n;
    options.frame_number++;
    auto frame = renderer.render(s, 0, options);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    const double signal = mean_above_black(*frame, 64);
    if (previous > 0) {
      EXPECT_NEAR(signal / previous, 0.5, 0.005) << "at f/" << n;
    }
    previous = signal;
  }
}

TEST_F(ExposurePhysics, SignalMatchesTheRadiometricPrediction) {
  // electrons = QE x (rho E / (4 N^2)) x photons-per-lux-s-m2 x pitch^2 x T, then x K.
  RenderSettings s = base();
  auto frame = renderer.render(s, 0, options);
  ASSERT_TRUE(frame.ok());
  const double photons_per_lux_s_m2 = 4.0906e15;
  const double expected_e =
      0.6 * (0.5 * 1000 / (4 * 16.0)) * photons_per_lux_s_m2 * (4e-6 * 4e-6) * 1000e-6;
  const double k_dn_per_e = (4095.0 - 64) / 20000;
  EXPECT_NEAR(mean_above_black(*frame, 64) / (expected_e * k_dn_per_e), 1.0, 0.01);
  EXPECT_NEAR(frame->truth["electrons_per_unit_reflectance"].get<double>() * 0.5 / expected_e, 1.0,
              1e-9);
}

TEST_F(ExposurePhysics, GainIsLinear) {
  RenderSettings s = base();
  s.exposure_us = 2000;
  auto unity = renderer.render(s, 0, options);
  s.gain = 2.0;
  options.frame_number++;
  auto doubled = renderer.render(s, 0, options);
  ASSERT_TRUE(unity.ok() && doubled.ok());
  EXPECT_NEAR(mean_above_black(*doubled, 64) / mean_above_black(*unity, 64), 2.0, 0.02);
}

TEST_F(ExposurePhysics, ShotNoiseVarianceEqualsTheMeanInElectrons) {
  // Photon transfer from a pair of frames: the difference removes any fixed pattern, so
  // var(a - b) / 2 is the temporal variance; in electrons it equals the mean (Poisson)
  // plus the read noise squared.
  RenderSettings s = base();
  s.exposure_us = 4000;
  auto a = renderer.render(s, 0, options);
  options.frame_number++;
  auto b = renderer.render(s, 0, options);
  ASSERT_TRUE(a.ok() && b.ok());
  cv::Mat fa, fb;
  a->image.convertTo(fa, CV_64F);
  b->image.convertTo(fb, CV_64F);
  cv::Scalar mean_diff, std_diff;
  cv::meanStdDev(fa - fb, mean_diff, std_diff);
  const double k = (4095.0 - 64) / 20000;  // DN per electron
  const double mean_e = (cv::mean(fa)[0] + cv::mean(fb)[0]) / 2 / k - 64 / k;
  const double temporal_var_e = std_diff[0] * std_diff[0] / 2 / (k * k);
  const double expected_var_e = mean_e + 2.0 * 2.0 + 1.0 / 12 / (k * k);  // + read + quantisation
  EXPECT_NEAR(temporal_var_e / expected_var_e, 1.0, 0.05) << "mean " << mean_e << " e-";
}

TEST_F(ExposurePhysics, SaturationClipsAtTheFullWellNotBeyond) {
  RenderSettings s = base();
  s.exposure_us = 100000;
  s.f_number = 1.4;
  auto frame = renderer.render(s, 0, options);
  ASSERT_TRUE(frame.ok());
  double lo, hi;
  cv::minMaxLoc(frame->image, &lo, &hi);
  // Full well 20000 e- x K maps exactly onto the top of the 12-bit range.
  EXPECT_EQ(hi, 4095);
  EXPECT_GT(lo, 4000);
}

TEST_F(ExposurePhysics, NoiseOffGivesTheExpectedSignalExactlyAndIsDeterministic) {
  options.noise = false;
  RenderSettings s = base();
  auto a = renderer.render(s, 0, options);
  options.frame_number = 7;
  auto b = renderer.render(s, 0, options);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(cv::norm(a->image, b->image, cv::NORM_INF), 0);
  double lo, hi;
  cv::minMaxLoc(a->image, &lo, &hi);
  EXPECT_EQ(lo, hi) << "a uniform target without noise is one value";
}

TEST_F(ExposurePhysics, SameSeedSameFrameDifferentSeedDifferentNoise) {
  RenderSettings s = base();
  auto a = renderer.render(s, 0, options);
  auto b = renderer.render(s, 0, options);
  options.seed = 99;
  auto c = renderer.render(s, 0, options);
  ASSERT_TRUE(a.ok() && b.ok() && c.ok());
  EXPECT_EQ(cv::norm(a->image, b->image, cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(a->image, c->image, cv::NORM_INF), 0);
}

TEST_F(ExposurePhysics, TheThreadCountDoesNotChangeTheFrame) {
  // A defocused edge, so the lens and the pixel area are both sampled at random.
  nlohmann::json scene = uniform_scene_json();
  scene["targets"][0]["type"] = "slanted_edge";
  scene["targets"][0]["size_m"] = {1.0, 1.0};
  Renderer edge = make_renderer(pinhole_camera_json(64, 48), scene);
  RenderSettings s = base();  // focused at infinity: the edge at 1 m is a 4 px disk
  options.threads = 1;
  auto one = edge.render(s, 0, options);
  options.threads = 3;
  auto three = edge.render(s, 0, options);
  ASSERT_TRUE(one.ok() && three.ok());
  EXPECT_GT(one->stats.aperture_samples, 0);
  EXPECT_EQ(cv::norm(one->image, three->image, cv::NORM_INF), 0);
}

TEST_F(ExposurePhysics, ABracketReusesTheSceneIntegralAndMatchesAFreshRender) {
  nlohmann::json scene = uniform_scene_json();
  scene["targets"][0]["type"] = "slanted_edge";
  scene["targets"][0]["size_m"] = {1.0, 1.0};
  Renderer first = make_renderer(pinhole_camera_json(64, 48), scene);
  Renderer fresh = make_renderer(pinhole_camera_json(64, 48), scene);
  RenderSettings s = base();
  options.frame_number = 3;
  ASSERT_FALSE(first.render(s, 0, options)->stats.cached);
  s.exposure_us = 3000;  // exposure does not change the scene integral
  auto reused = first.render(s, 0, options);
  ASSERT_TRUE(reused.ok());
  EXPECT_TRUE(reused->stats.cached);
  auto recomputed = fresh.render(s, 0, options);
  ASSERT_TRUE(recomputed.ok());
  EXPECT_FALSE(recomputed->stats.cached);
  EXPECT_EQ(cv::norm(reused->image, recomputed->image, cv::NORM_INF), 0);
  s.f_number = 5.6;  // the aperture does
  EXPECT_FALSE(first.render(s, 0, options)->stats.cached);
}

TEST_F(ExposurePhysics, OutOfRangeSettingsAreRejectedWithTheAllowedRange) {
  RenderSettings s = base();
  s.exposure_us = 200000;  // the spec's max is 1000 x 100 us
  auto frame = renderer.render(s, 0, options);
  ASSERT_FALSE(frame.ok());
  EXPECT_EQ(frame.error().code, "out_of_range");
  EXPECT_NE(frame.error().message.find("[100, 100000] us"), std::string::npos)
      << frame.error().message;
  s = base();
  s.f_number = 1.0;
  frame = renderer.render(s, 0, options);
  ASSERT_FALSE(frame.ok());
  EXPECT_NE(frame.error().message.find("f_number"), std::string::npos);
  s = base();
  s.focus_position = -1;
  EXPECT_FALSE(renderer.render(s, 0, options).ok());
}

}  // namespace
}  // namespace camlab::mock
