// The colour (Bayer) virtual camera: each pixel sees its own channel, with that channel's
// reflectance, QE and focus. Checked against the physics written out here (radiometry,
// the thin lens with a focal length per channel), against the monochrome renderer (a
// grey scene on a sensor whose channels are alike is the monochrome frame, bit for bit),
// and for the truth each frame carries per channel.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>

#include "test_specs.h"

namespace camlab::mock {
namespace {

using nlohmann::json;

constexpr double kPitchMm = 0.004, kFocalMm = 8.0;
const char* const kChannelNames[3] = {"R", "G", "B"};

// The colour (0 R, 1 G, 2 B) of pixel (x, y) of an RGGB mosaic, written out.
int rggb_colour(int x, int y) { return (y % 2 == 0) ? (x % 2 == 0 ? 0 : 1) : (x % 2 == 0 ? 1 : 2); }

// Mean DN of the pixels of one colour of an RGGB mosaic.
double channel_mean(const cv::Mat& mosaic, int colour) {
  double sum = 0;
  int n = 0;
  for (int y = 0; y < mosaic.rows; ++y)
    for (int x = 0; x < mosaic.cols; ++x)
      if (rggb_colour(x, y) == colour) {
        sum += mosaic.depth() == CV_8U ? mosaic.at<uint8_t>(y, x) : mosaic.at<uint16_t>(y, x);
        ++n;
      }
  return sum / n;
}

// Image distance of a thin lens: 1 / (1/f - 1/z_o).
double image_distance(double focal_mm, double object_mm) {
  return 1.0 / (1.0 / focal_mm - 1.0 / object_mm);
}

json edge_scene_json(double distance_m, json dark, json light) {
  return {{"illuminance_lux", 2000},
          {"background_reflectance", 0.18},
          {"targets",
           {{{"type", "slanted_edge"},
             {"name", "edge"},
             {"size_m", {1.0, 1.0}},
             {"angle_deg", 5.0},
             {"dark_reflectance", dark},
             {"light_reflectance", light},
             {"pose", {{"position_m", {0.0, 0.0, distance_m}}}}}}}};
}

TEST(ColourRender, AGreySceneOnAlikeChannelsIsTheMonochromeFrameExactly) {
  // Same QE in every channel, no chromatic aberration, grey targets: nothing tells the
  // channels apart, so each pixel must see exactly what the monochrome sensor's does,
  // through the same rays (lens sampled: the edge is out of focus), noise and all.
  json mono = testing::pinhole_camera_json(96, 64);
  json colour = testing::colour_camera_json(96, 64, "GRBG", {0.6, 0.6, 0.6}, {0, 0, 0});
  for (double blur_sigma_px : {0.0, 0.7}) {
    mono["lens"]["baseline_blur_sigma_px"] = blur_sigma_px;
    colour["lens"]["baseline_blur_sigma_px"] = blur_sigma_px;
    Renderer m = testing::make_renderer(mono, edge_scene_json(0.5, 0.1, 0.7));
    Renderer c = testing::make_renderer(colour, edge_scene_json(0.5, 0.1, 0.7));
    RenderSettings settings = m.default_settings();
    settings.f_number = 2.0;
    settings.focus_position = 0;  // focused at infinity: the edge at 0.5 m is blurred
    settings.exposure_us = 3000;
    RenderOptions options;
    options.seed = 5;
    auto a = m.render(settings, 0, options);
    auto b = c.render(settings, 0, options);
    ASSERT_TRUE(a.ok() && b.ok());
    ASSERT_GT(a->stats.aperture_samples, 0) << "the lens must be sampled";
    EXPECT_EQ(b->stats.aperture_samples, a->stats.aperture_samples);
    EXPECT_EQ(cv::norm(a->image, b->image, cv::NORM_INF), 0.0) << "blur " << blur_sigma_px;
  }
}

TEST(ColourRender, EachChannelsSignalIsItsQeTimesItsReflectanceAsRadiometryGivesIt) {
  const std::array<double, 3> qe = {0.45, 0.6, 0.4};
  const std::array<double, 3> reflectance = {0.7, 0.5, 0.2};
  json camera = testing::colour_camera_json(64, 48, "RGGB", qe);
  json scene = testing::uniform_scene_json(1.0, 0.5);
  scene["targets"][0]["light_reflectance"] = reflectance;
  scene["background_reflectance"] = reflectance;
  Renderer renderer = testing::make_renderer(camera, scene);
  RenderSettings settings = renderer.default_settings();
  settings.exposure_us = 4000;
  settings.f_number = 2.8;
  settings.gain = 1.5;
  settings.focus_position = 0;
  RenderOptions options;
  options.noise = false;
  auto frame = renderer.render(settings, 0, options);
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  EXPECT_EQ(frame->truth["cfa"], "RGGB");

  // Radiometry written out: E = lux x R / (4 N^2) (focused at infinity, z_s = f);
  // photons = E x 4.0906e15 / (lux s m^2) x pitch^2 x t; electrons = QE x photons;
  // DN = black + electrons x K x gain with K = (4095 - 64) / 20000.
  const double k_dn_per_e = (4095.0 - 64.0) / 20000.0;
  for (int c = 0; c < 3; ++c) {
    const double photons = 1000.0 / (4 * 2.8 * 2.8) * 4.0906e15 * 4e-6 * 4e-6 * 4000e-6;
    const double electrons = qe[c] * reflectance[c] * photons;
    const double want_dn = 64 + electrons * k_dn_per_e * 1.5;
    ASSERT_LT(want_dn, 4000) << "below saturation";
    EXPECT_NEAR(channel_mean(frame->image, c), want_dn, 0.5) << kChannelNames[c];
    const json& truth = frame->truth["channels"][kChannelNames[c]];
    EXPECT_NEAR(truth["quantum_efficiency"].get<double>(), qe[c], 1e-12);
    EXPECT_NEAR(truth["electrons_per_unit_reflectance"].get<double>(), qe[c] * photons,
                1e-9 * qe[c] * photons);
    EXPECT_NEAR(truth["targets"][0]["expected_dn"]["light"].get<double>(), want_dn, 1e-6);
    EXPECT_NEAR(truth["background"]["expected_dn"].get<double>(), want_dn, 1e-6);
  }
}

TEST(ColourRender, APixelSeesOnlyItsOwnColour) {
  json scene = testing::uniform_scene_json(1.0, 0.5);
  scene["targets"][0]["light_reflectance"] = {0.0, 0.8, 0.0};  // a green target
  scene["background_reflectance"] = {0.0, 0.8, 0.0};
  Renderer renderer = testing::make_renderer(testing::colour_camera_json(32, 32), scene);
  RenderSettings settings = renderer.default_settings();
  settings.exposure_us = 2000;
  RenderOptions options;
  options.noise = false;
  auto frame = renderer.render(settings, 0, options);
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(channel_mean(frame->image, 0), 64.0) << "R sites stay at black";
  EXPECT_EQ(channel_mean(frame->image, 2), 64.0) << "B sites stay at black";
  EXPECT_GT(channel_mean(frame->image, 1), 500.0) << "G sites see the target";
}

TEST(ColourRender, EachChannelsPredictedBlurIsItsOwnThinLens) {
  // f_c = f + shift_c; the aperture is f / N of the nominal f; C_c = A |z_s - z_i,c| / z_i,c.
  const std::array<double, 3> shift_mm = {0.02, 0.0, -0.015};
  Renderer renderer = testing::make_renderer(
      testing::colour_camera_json(64, 64, "RGGB", {0.5, 0.5, 0.5}, shift_mm),
      edge_scene_json(1.0, json::array({0.1, 0.1, 0.1}), json::array({0.8, 0.7, 0.6})));
  RenderSettings settings = renderer.default_settings();
  settings.f_number = 2.0;
  settings.focus_position = 130;  // z_s = 8.130 mm: focused at about 0.5 m
  auto frame = renderer.render(settings, 0, RenderOptions{});
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const double z_s = kFocalMm + 130 * 0.001;
  double largest = 0;
  for (int c = 0; c < 3; ++c) {
    const double f_c = kFocalMm + shift_mm[c];
    const double z_i = image_distance(f_c, 1000.0);
    const double coc_px = kFocalMm / 2.0 * std::fabs(z_s - z_i) / z_i / kPitchMm;
    largest = std::max(largest, coc_px);
    const json& ch = frame->truth["channels"][kChannelNames[c]];
    EXPECT_NEAR(ch["focal_mm"].get<double>(), f_c, 1e-12);
    EXPECT_NEAR(ch["focus_shift_mm"].get<double>(), shift_mm[c], 1e-15);
    EXPECT_NEAR(ch["focus_distance_m"].get<double>(), image_distance(f_c, z_s) / 1e3, 1e-12);
    EXPECT_NEAR(ch["targets"][0]["image_distance_mm"].get<double>(), z_i, 1e-9);
    EXPECT_NEAR(ch["targets"][0]["coc_px"]["at_origin"].get<double>(), coc_px, 1e-9)
        << kChannelNames[c];
    // k = 4 + CoC / 2.5 lens strata per side (docs/BENCHMARKS.md), for this channel's CoC.
    const int grid = std::clamp(static_cast<int>(std::lround(4 + coc_px / 2.5)), 4, 16);
    EXPECT_EQ(ch["aperture_samples"].get<int>(), grid * grid) << kChannelNames[c];
  }
  EXPECT_NEAR(frame->truth["render"]["max_coc_px"].get<double>(), largest, 1e-9);
}

TEST(ColourRender, AChannelFocusedBeyondInfinityBlursEvenAtInfinity) {
  // Lens focused at infinity (z_s = f): R (f_R = f + 0.02 mm > z_s) cannot focus there;
  // a far object's R image lies 0.02 mm behind the sensor, G's on it.
  Renderer renderer = testing::make_renderer(testing::colour_camera_json(64, 64),
                                             edge_scene_json(1000.0, 0.1, 0.8));
  RenderSettings settings = renderer.default_settings();
  settings.f_number = 1.4;
  settings.focus_position = 0;
  auto frame = renderer.render(settings, 0, RenderOptions{});
  ASSERT_TRUE(frame.ok()) << frame.error().message;
  const json& r = frame->truth["channels"]["R"];
  const double z_i = image_distance(8.02, 1e6);
  EXPECT_NEAR(r["targets"][0]["coc_px"]["at_origin"].get<double>(),
              kFocalMm / 1.4 * (z_i - kFocalMm) / z_i / kPitchMm, 1e-9);
  EXPECT_LT(r["focus_distance_m"].get<double>(), 0) << "a virtual plane of focus behind the lens";
  EXPECT_GT(r["aperture_samples"].get<int>(), 0);
  EXPECT_EQ(frame->truth["channels"]["G"]["focus_distance_m"], nullptr) << "at infinity";
  cv::Scalar mean = cv::mean(frame->image);
  EXPECT_TRUE(std::isfinite(mean[0]));
}

}  // namespace
}  // namespace camlab::mock
