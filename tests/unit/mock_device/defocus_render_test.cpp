// Thin-lens defocus in the renderer against the thin-lens CoC: a slanted edge rendered
// out of focus, measured with the exact pillbox edge model, has the predicted diameter.
#include <gtest/gtest.h>

#include <cmath>

#include "analysis/edge/edge_spread.h"
#include "edge_truth.h"
#include "optics/optics.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

nlohmann::json edge_scene_json(double distance_m) {
  return {{"illuminance_lux", 2000},
          {"targets",
           {{{"type", "slanted_edge"},
             {"size_m", {1.0, 1.0}},
             {"angle_deg", 5.0},
             {"dark_reflectance", 0.1},
             {"light_reflectance", 0.7},
             {"pose", {{"position_m", {0.0, 0.0, distance_m}}}}}}}};
}

// Focus distance (mm) that gives a CoC of coc_mm for an object at object_mm, focusing
// in front of the object: from C z_o (s - f) = A f (z_o - s).
double focus_for_coc_mm(double focal_mm, double f_number, double object_mm, double coc_mm) {
  const double aperture_mm = focal_mm / f_number;
  return focal_mm * object_mm * (aperture_mm + coc_mm) /
         (coc_mm * object_mm + aperture_mm * focal_mm);
}

class DefocusRender : public ::testing::TestWithParam<double> {};

TEST_P(DefocusRender, MeasuredBlurDiameterMatchesTheThinLensCoc) {
  const double target_px = GetParam();
  const double object_m = 1.0, f_number = 2.0, focal_mm = 8.0, pitch_mm = 0.004;
  Renderer renderer =
      testing::make_renderer(testing::pinhole_camera_json(256, 256), edge_scene_json(object_m));
  const double focus_mm =
      focus_for_coc_mm(focal_mm, f_number, object_m * 1e3, target_px * pitch_mm);
  auto z_s = optics::lens_to_sensor_mm(focal_mm, focus_mm);
  ASSERT_TRUE(z_s.ok());
  RenderSettings settings = renderer.default_settings();
  settings.f_number = f_number;
  settings.exposure_us = 3000;
  settings.focus_position = static_cast<int>(std::lround((*z_s - focal_mm) / 0.001));
  RenderOptions options;
  options.seed = 11;
  auto frame = renderer.render(settings, 0, options);
  ASSERT_TRUE(frame.ok()) << frame.error().message;

  const auto& target = frame->truth["targets"][0];
  const double predicted_px = target["coc_px"]["at_origin"].get<double>();
  ASSERT_NEAR(predicted_px, target_px, 0.05 * target_px) << "focus quantisation moved the CoC";
  // The truth's own CoC must be the optics module's, from the settings in effect.
  auto coc_mm = optics::circle_of_confusion_mm(
      focal_mm, f_number, frame->settings["focus_distance_m"].get<double>() * 1e3, object_m * 1e3);
  ASSERT_TRUE(coc_mm.ok());
  EXPECT_NEAR(predicted_px, *coc_mm / pitch_mm, 1e-9);

  const analysis::EdgeLine guess = testing::edge_line_of_truth(target);
  analysis::EdgeFitOptions fit_options;
  fit_options.half_width_px = predicted_px / 2 + 10;
  fit_options.half_length_px = 100;
  auto fit = analysis::fit_pillbox_edge(frame->image, guess, fit_options);
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_NEAR(fit->diameter_px / predicted_px, 1.0, 0.03)
      << "measured " << fit->diameter_px << " px, thin lens " << predicted_px << " px";
}

INSTANTIATE_TEST_SUITE_P(BlurDiameters, DefocusRender,
                         ::testing::Values(2.0, 3.0, 5.0, 8.0, 12.0, 18.0, 24.0, 30.0),
                         [](const auto& info) {
                           return "D" + std::to_string(static_cast<int>(info.param)) + "px";
                         });

TEST(DefocusRenderPolicy, InFocusTargetsAreNotApertureSampled) {
  Renderer renderer =
      testing::make_renderer(testing::pinhole_camera_json(64, 64), edge_scene_json(1.0));
  RenderSettings settings = renderer.default_settings();
  auto z_s = optics::lens_to_sensor_mm(8.0, 1000.0);
  settings.focus_position = static_cast<int>(std::lround((*z_s - 8.0) / 0.001));
  auto frame = renderer.render(settings, 0, RenderOptions{});
  ASSERT_TRUE(frame.ok());
  EXPECT_LT(frame->stats.max_coc_px, 0.1);
  EXPECT_EQ(frame->stats.aperture_samples, 0) << "a negligible CoC must not cost lens samples";
  settings.focus_position = 0;  // focus at infinity: 1 m is now 4 px out of focus at f/4
  frame = renderer.render(settings, 0, RenderOptions{});
  ASSERT_TRUE(frame.ok());
  EXPECT_GT(frame->stats.aperture_samples, 0);
}

}  // namespace
}  // namespace camlab::mock
