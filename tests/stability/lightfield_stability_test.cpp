// Hard cases of light fields (docs/physics.md, "Light fields"; docs/analysis.md): each
// gives the right answer or a specific error or flag, never a NaN or a quiet wrong
// number. A focus distance behind the lens or inside the focal length; a light field of
// one view; refocusing at the capture's own focus (no shift at all) and far outside the
// sharp range; depth of a flat field and of a plane outside the searched range;
// synthetic f-numbers out of reach.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>

#include <opencv2/core.hpp>

#include "analysis/lightfield/depth.h"
#include "analysis/lightfield/refocus.h"
#include "mock_device/render/lightfield_render.h"

namespace camlab::analysis::lightfield {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

json camera(int views, int size = 48) {
  return {{"name", "light-field stability"},
          {"sensor",
           {{"width_px", size},
            {"height_px", size},
            {"pixel_pitch_um", 4.0},
            {"bit_depth", 12},
            {"black_level_dn", 64},
            {"full_well_e", 20000},
            {"read_noise_e", 2.0},
            {"quantum_efficiency", 0.6}}},
          {"lens",
           {{"focal_mm", 8.0},
            {"f_number_min", 2.0},
            {"f_number_max", 16.0},
            {"focus",
             {{"position_min", 0}, {"position_max", 1000}, {"extension_mm_per_step", 0.001}}}}},
          {"controls",
           {{"exposure_time_absolute", {{"min", 1}, {"max", 333}, {"default", 80}}},
            {"focus_absolute", {{"default", 65}}}}},
          {"lightfield", {{"views", {views, views}}}}};
}

json scene(const char* type, double z_m) {
  json t = {{"type", type},
            {"size_m", {0.5, 0.5}},
            {"dark_reflectance", 0.1},
            {"light_reflectance", 0.8},
            {"pose", {{"position_m", {0.0, 0.0, z_m}}}}};
  if (std::string(type) == "texture") t["feature_m"] = 0.0015 * z_m, t["seed"] = 2;
  return {
      {"illuminance_lux", 1000}, {"background_reflectance", 0.3}, {"targets", json::array({t})}};
}

struct Rendered {
  LightField lf;
  mock::RenderedFrame thin;  // the thin-lens frame of the same settings
};

Rendered render(const json& camera_json, const json& scene_json, bool noise = false) {
  auto c = mock::parse_camera_spec(camera_json);
  auto s = mock::parse_scene_spec(scene_json);
  if (!c || !s) throw std::runtime_error(!c ? c.error().message : s.error().message);
  auto renderer = mock::Renderer::create(std::move(*c), std::move(*s));
  if (!renderer) throw std::runtime_error(renderer.error().message);
  mock::RenderOptions options;
  options.noise = noise;
  const mock::RenderSettings settings = renderer->default_settings();
  auto frame = mock::render_light_field(*renderer, settings, 0, options);
  if (!frame) throw std::runtime_error(frame.error().message);
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_lf_stability_" + std::to_string(::getpid()) + "_" +
                                   ::testing::UnitTest::GetInstance()->current_test_info()->name());
  fs::remove_all(dir);
  if (Status ok = mock::write_light_field(*frame, *renderer, dir, options); !ok)
    throw std::runtime_error(ok.error().message);
  auto lf = load_light_field(dir);
  fs::remove_all(dir);
  if (!lf) throw std::runtime_error(lf.error().message);
  auto thin = renderer->render(settings, 0, options);
  if (!thin) throw std::runtime_error(thin.error().message);
  return {std::move(*lf), std::move(*thin)};
}

bool finite(const cv::Mat& m) { return cv::checkRange(m, true, nullptr, -1e30, 1e30); }

TEST(LightFieldStability, FocusDistancesWithoutARealImageAreRefused) {
  const Rendered r = render(camera(3), scene("texture", 0.8));
  struct Case {
    double focus_m;
    ErrorCode code;
    const char* says;
  };
  for (const Case& c : {Case{-1.0, ErrorCode::kOutOfRange, "behind the lens"},
                        Case{0.0, ErrorCode::kOutOfRange, "behind the lens"},
                        Case{0.008, ErrorCode::kNoRealImage, "focal length (0.008 m)"},
                        Case{0.005, ErrorCode::kNoRealImage, "no real image"},
                        Case{std::nan(""), ErrorCode::kOutOfRange, "focus_m = nan"}}) {
    auto out = refocus(r.lf, c.focus_m);
    ASSERT_FALSE(out.ok()) << c.focus_m;
    EXPECT_EQ(out.error().code, c.code) << out.error().message;
    EXPECT_NE(out.error().message.find(c.says), std::string::npos) << out.error().message;
  }
  // Infinity is a focus distance: the sensor at f.
  auto far = refocus(r.lf, std::numeric_limits<double>::infinity());
  ASSERT_TRUE(far.ok());
  EXPECT_DOUBLE_EQ(far->lens_to_sensor_mm, 8.0);
  EXPECT_TRUE(finite(far->image));
}

TEST(LightFieldStability, OneViewIsTheThinLensAndCannotBeRefocused) {
  const Rendered r = render(camera(1), scene("texture", 0.8));
  ASSERT_EQ(r.lf.views.size(), 1u);
  // The one view is the whole aperture: the thin-lens frame, to the cubature's and the
  // rounding's error.
  cv::Mat thin;
  r.thin.image.convertTo(thin, CV_32F, 1.0, -64);
  EXPECT_LT(cv::norm(r.lf.views[0], thin, cv::NORM_L2) / std::sqrt(48.0 * 48.0), 2.0);  // DN RMS
  auto out = refocus(r.lf, 1.2);
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.error().code, ErrorCode::kUnsupported);
  EXPECT_NE(out.error().message.find("one view (1 x 1)"), std::string::npos);
  auto depth = estimate_depth(r.lf, {});
  ASSERT_FALSE(depth.ok());
  EXPECT_EQ(depth.error().code, ErrorCode::kUnsupported);
}

TEST(LightFieldStability, RefocusAtTheCapturesFocusIsTheThinLensFrame) {
  // No shift and no magnification: the area-weighted mean of the views, which is the
  // thin-lens integral (every path of the renderer agrees on it), to the rounding.
  const Rendered r = render(camera(5), scene("slanted_edge", 0.7));
  auto out = refocus(r.lf, r.lf.description.optics.focus_distance_m);
  ASSERT_TRUE(out.ok());
  EXPECT_NEAR(out->magnification, 1, 1e-12);
  EXPECT_EQ(out->view_step_px, 0);
  EXPECT_TRUE(out->warnings.empty());
  cv::Mat thin;
  r.thin.image.convertTo(thin, CV_32F, 1.0, -64);
  double worst = 0;
  cv::minMaxLoc(cv::abs(out->image - thin), nullptr, &worst);
  EXPECT_LT(worst, 1.5);  // DN: each view rounded once, the frame once
}

TEST(LightFieldStability, RefocusFarOutsideTheSharpRangeSaysSo) {
  const Rendered r = render(camera(5), scene("texture", 0.7));
  auto out = refocus(r.lf, 0.12);
  ASSERT_TRUE(out.ok());
  EXPECT_GT(out->view_step_px, 1);
  ASSERT_EQ(out->warnings.size(), 1u);
  EXPECT_NE(out->warnings[0].find("refocuses sharply between"), std::string::npos);
  EXPECT_GT(out->sharp_range_m[0], 0.12);
  EXPECT_TRUE(finite(out->image));
}

TEST(LightFieldStability, FlatFieldHasNoDepthAndSaysSo) {
  const Rendered r = render(camera(5), scene("uniform", 0.7), true);
  auto depth = estimate_depth(r.lf, {});
  ASSERT_TRUE(depth.ok());
  EXPECT_EQ(depth->ok_share, 0);
  EXPECT_EQ(cv::countNonZero(depth->depth_m), 0);  // no number where none is defined
  EXPECT_TRUE(finite(depth->confidence));
  ASSERT_FALSE(depth->warnings.empty());
  EXPECT_NE(depth->warnings[0].find("no texture"), std::string::npos);
}

TEST(LightFieldStability, PlaneOutsideTheSearchedRangeIsFlaggedNotExtrapolated) {
  // A textured plane at 0.45 m searched from 0.8 to 3 m.
  const Rendered r = render(camera(5), scene("texture", 0.45), true);
  DepthOptions options;
  options.near_m = 0.8;
  options.far_m = 3.0;
  auto depth = estimate_depth(r.lf, options);
  ASSERT_TRUE(depth.ok());
  EXPECT_GT(depth->out_of_range_share, 0.8);
  EXPECT_LT(depth->ok_share, 0.02);
  for (int y = 0; y < depth->depth_m.rows; ++y)
    for (int x = 0; x < depth->depth_m.cols; ++x) {
      const float z = depth->depth_m.at<float>(y, x);
      // Nothing measured may pretend to lie inside the range it is not in.
      if (z > 0) {
        EXPECT_LT(std::fabs(z - 0.45), 0.45 * 0.2) << x << " " << y;
      }
    }
  bool warned = false;
  for (const auto& w : depth->warnings) warned |= w.find("widen it") != std::string::npos;
  EXPECT_TRUE(warned);
}

TEST(LightFieldStability, SyntheticApertureOutOfReach) {
  const Rendered r = render(camera(4), scene("texture", 0.8));
  for (double n : {1.9, 100.0}) {
    auto out = refocus(r.lf, 1.0, n);
    ASSERT_FALSE(out.ok()) << n;
    EXPECT_EQ(out.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(out.error().message.find("f_number = "), std::string::npos);
  }
}

}  // namespace
}  // namespace camlab::analysis::lightfield
