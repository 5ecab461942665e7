// A tilted and curved best-focus surface (lens.field_focus): the spec's checks, an edge off
// the axis blurred by the thin lens at the surface's offset there (measured with the exact
// pillbox edge model, against the CoC computed here from the optics formulas and against a
// flat-field lens moved by that offset), sharp where the surface says, and a surface of no
// size rendering as the flat lens.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include <opencv2/core.hpp>

#include "analysis/edge/edge_spread.h"
#include "edge_truth.h"
#include "optics/optics.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {
namespace field_focus_test {

// A slanted edge 36 mm right of the axis at 1 m: its image 72 px right of the centre of
// the 256 x 256 test camera (8 mm, 4 um pixels).
nlohmann::json off_axis_edge_scene() {
  return {{"illuminance_lux", 2000},
          {"targets",
           {{{"type", "slanted_edge"},
             {"size_m", {0.04, 0.04}},
             {"angle_deg", 5.0},
             {"dark_reflectance", 0.1},
             {"light_reflectance", 0.7},
             {"pose", {{"position_m", {0.036, 0.0, 1.0}}}}}}}};
}

double measured_diameter_px(const RenderedFrame& frame, double expected_px) {
  const analysis::EdgeLine guess = testing::edge_line_of_truth(frame.truth["targets"][0]);
  analysis::EdgeFitOptions options;
  options.half_width_px = expected_px / 2 + 4;
  options.half_length_px = 25;
  auto fit = analysis::fit_pillbox_edge(frame.image, guess, options);
  EXPECT_TRUE(fit.ok()) << fit.error().message;
  return fit.ok() ? fit->diameter_px : NAN;
}

TEST(FieldFocus, AnEdgeOffTheAxisIsBlurredByTheSurfacesOffsetThereAndSharpWhereItSays) {
  const double tilt_deg = 5, focal_mm = 8, f_number = 1.4, pitch_mm = 0.004, step_mm = 0.001;
  nlohmann::json camera = testing::pinhole_camera_json(256, 256);
  camera["lens"]["field_focus"] = {{"tilt_x_deg", tilt_deg}};
  Renderer renderer = testing::make_renderer(camera, off_axis_edge_scene());
  RenderSettings settings = renderer.default_settings();
  settings.f_number = f_number;
  settings.exposure_us = 3000;
  RenderOptions options;
  options.seed = 5;

  // The lens where a flat-field lens would be sharp on the chart.
  auto z_i = optics::image_distance_mm(focal_mm, 1000);
  ASSERT_TRUE(z_i.ok());
  settings.focus_position = static_cast<int>(std::lround((*z_i - focal_mm) / step_mm));
  auto flat_sharp = renderer.render(settings, 0, options);
  ASSERT_TRUE(flat_sharp.ok()) << flat_sharp.error().message;
  // The surface's offset at the edge's image point, and the thin lens's blur there: a point
  // of the chart images at z_i, the pixel sees the lens as if it sat at z_s - delta.
  const double x_px = flat_sharp->truth["targets"][0]["edge_px"]["middle"][0].get<double>();
  const double delta_mm = std::tan(tilt_deg * std::numbers::pi / 180) * (x_px - 127.5) * pitch_mm;
  const double z_s = focal_mm + settings.focus_position * step_mm;
  const double aperture_mm = focal_mm / f_number;
  const double expected_px = aperture_mm * std::fabs(z_s - delta_mm - *z_i) / *z_i / pitch_mm;
  ASSERT_GT(expected_px, 3.5) << "the tilt must blur the edge measurably";
  const double truth_px = flat_sharp->truth["targets"][0]["coc_px"]["at_origin"].get<double>();
  EXPECT_NEAR(truth_px, expected_px, 0.02 * expected_px) << "the truth is through the surface";
  // Measured, it is the blur of a flat-field lens moved in by the offset: the same edge
  // fit on both (the fit reads this short edge 5% narrow at f/1.4 either way, so the two
  // are compared as measured over predicted).
  const double blurred_px = measured_diameter_px(*flat_sharp, expected_px);
  Renderer flat =
      testing::make_renderer(testing::pinhole_camera_json(256, 256), off_axis_edge_scene());
  RenderSettings moved_in = settings;
  moved_in.focus_position = static_cast<int>(std::lround((z_s - delta_mm - focal_mm) / step_mm));
  auto flat_frame = flat.render(moved_in, 0, options);
  ASSERT_TRUE(flat_frame.ok()) << flat_frame.error().message;
  const double flat_truth_px = flat_frame->truth["targets"][0]["coc_px"]["at_origin"].get<double>();
  const double flat_px = measured_diameter_px(*flat_frame, flat_truth_px);
  EXPECT_NEAR(blurred_px / expected_px, flat_px / flat_truth_px, 0.03)
      << "measured " << blurred_px << " px against the thin lens's " << expected_px
      << " px at the offset; flat lens moved in: " << flat_px << " px against " << flat_truth_px;
  EXPECT_NEAR(blurred_px / expected_px, 1.0, 0.08) << blurred_px << " px";

  // The lens moved out by the offset: sharp again (the pixel's own blur only).
  settings.focus_position = static_cast<int>(std::lround((*z_i + delta_mm - focal_mm) / step_mm));
  auto surface_sharp = renderer.render(settings, 0, options);
  ASSERT_TRUE(surface_sharp.ok()) << surface_sharp.error().message;
  EXPECT_LT(surface_sharp->truth["targets"][0]["coc_px"]["at_origin"].get<double>(), 0.3);
  EXPECT_LT(measured_diameter_px(*surface_sharp, 1.0), 0.8);
}

// Astigmatism: the pencil's radial part focuses on the meridional surface, its tangential
// part on the sagittal one. With the lens where the sagittal surface is sharp at an edge's
// image point, an edge whose normal is tangential (across the radius: only the tangential
// part blurs it) is sharp, and one whose normal is radial is blurred by the thin lens at the
// surfaces' distance, a rho^2 / R^2; moved to the meridional surface, the other way round.
TEST(FieldFocus, AstigmaticPencilsBlurEachEdgeByItsOwnSurface) {
  const double astigmatism_um = 150, focal_mm = 8, f_number = 1.4, pitch_mm = 0.004,
               step_mm = 0.001;
  nlohmann::json camera = testing::pinhole_camera_json(256, 256);
  camera["lens"]["field_focus"] = {{"astigmatism_um", astigmatism_um}};
  auto z_i = optics::image_distance_mm(focal_mm, 1000);
  ASSERT_TRUE(z_i.ok());
  // The edge 36 mm right of the axis (its normal radial) or below it (its normal
  // tangential); both 72 px from the centre.
  const double rho2 =
      std::pow(72 * pitch_mm, 2) / std::pow(0.5 * std::hypot(256, 256) * pitch_mm, 2);
  const double split_mm = astigmatism_um * 1e-3 * rho2;  // sagittal minus meridional
  const double blur_px = focal_mm / f_number * split_mm / *z_i / pitch_mm;
  ASSERT_GT(blur_px, 3.5);
  for (const bool below : {false, true}) {
    nlohmann::json scene = off_axis_edge_scene();
    if (below) scene["targets"][0]["pose"]["position_m"] = {0.0, 0.036, 1.0};
    Renderer renderer = testing::make_renderer(camera, scene);
    for (const int surface : {+1, -1}) {  // the lens at the sagittal, then the meridional
      RenderSettings settings = renderer.default_settings();
      settings.f_number = f_number;
      settings.exposure_us = 3000;
      settings.focus_position =
          static_cast<int>(std::lround((*z_i + surface * 0.5 * split_mm - focal_mm) / step_mm));
      RenderOptions options;
      options.seed = 7;
      auto frame = renderer.render(settings, 0, options);
      ASSERT_TRUE(frame.ok()) << frame.error().message;
      // Radial normal (right of the axis): the meridional focus blurs it; tangential normal
      // (below): the sagittal focus.
      const bool sharp = below ? surface == +1 : surface == -1;
      const double measured = measured_diameter_px(*frame, sharp ? 1.0 : blur_px);
      std::printf("edge %s, lens at the %s surface: %.2f px (thin lens %.2f)\n",
                  below ? "below" : "right", surface > 0 ? "sagittal" : "meridional", measured,
                  sharp ? 0.0 : blur_px);
      if (sharp)
        EXPECT_LT(measured, 1.2) << (below ? "below" : "right");
      else
        EXPECT_NEAR(measured / blur_px, 1.0, 0.1) << (below ? "below" : "right");
    }
  }
}

TEST(FieldFocus, ASurfaceOfNoSizeRendersAsTheFlatLens) {
  // 1e-9 deg of tilt: every pixel's plane of focus is the flat lens's to 1e-13, so the
  // per-pixel paths (uniform, adaptive, the block ranges) must give the same frame.
  nlohmann::json camera = testing::pinhole_camera_json(128, 96);
  nlohmann::json scene = off_axis_edge_scene();
  scene["targets"][0]["pose"]["position_m"] = {0.0, 0.0, 1.0};
  scene["targets"][0]["size_m"] = {0.2, 0.2};
  Renderer flat = testing::make_renderer(camera, scene);
  camera["lens"]["field_focus"] = {{"tilt_y_deg", 1e-9}};
  Renderer tilted = testing::make_renderer(camera, scene);
  RenderSettings settings = flat.default_settings();
  settings.f_number = 2;
  settings.focus_position = 40;  // blurred: the lens is sampled
  for (int aperture_samples : {-1, 64}) {
    RenderOptions options;
    options.noise = false;
    options.aperture_samples = aperture_samples;
    options.pixel_samples = aperture_samples < 0 ? -1 : 16;
    auto a = flat.render(settings, 0, options);
    auto b = tilted.render(settings, 0, options);
    ASSERT_TRUE(a.ok() && b.ok());
    cv::Mat diff;
    cv::absdiff(a->image, b->image, diff);
    double max_dn = 0;
    cv::minMaxLoc(diff, nullptr, &max_dn);
    EXPECT_LE(max_dn, 1) << "aperture samples " << aperture_samples;
    EXPECT_LT(cv::mean(diff)[0], 0.01) << "aperture samples " << aperture_samples;
  }
}

TEST(FieldFocus, TheSpecChecksItsRangesAndLightFieldsRefuseIt) {
  nlohmann::json camera = testing::pinhole_camera_json();
  camera["lens"]["field_focus"] = {
      {"tilt_x_deg", 0.3}, {"tilt_y_deg", -0.2}, {"curvature_sag_um", -12}};
  auto spec = parse_camera_spec(camera);
  ASSERT_TRUE(spec.ok()) << spec.error().message;
  EXPECT_EQ(spec->lens.field_focus.tilt_x_deg, 0.3);
  EXPECT_EQ(spec->lens.field_focus.tilt_y_deg, -0.2);
  EXPECT_EQ(spec->lens.field_focus.curvature_sag_um, -12);
  EXPECT_FALSE(spec->lens.field_focus.flat());

  camera["lens"]["field_focus"]["tilt_x_deg"] = 6;
  spec = parse_camera_spec(camera);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("camera.lens.field_focus.tilt_x_deg"), std::string::npos)
      << spec.error().message;
  camera["lens"]["field_focus"]["tilt_x_deg"] = 0;
  camera["lens"]["field_focus"]["curvature_sag_um"] = 900;  // beyond a tenth of 8 mm
  spec = parse_camera_spec(camera);
  ASSERT_FALSE(spec.ok());
  EXPECT_NE(spec.error().message.find("curvature_sag_um"), std::string::npos)
      << spec.error().message;

  camera["lens"]["field_focus"]["curvature_sag_um"] = -12;
  camera["lightfield"] = {{"views", {3, 3}}};
  spec = parse_camera_spec(camera);
  ASSERT_FALSE(spec.ok());
  EXPECT_EQ(spec.error().code, "unsupported");
  EXPECT_NE(spec.error().message.find("field_focus"), std::string::npos) << spec.error().message;
}

}  // namespace field_focus_test
}  // namespace
}  // namespace camlab::mock
