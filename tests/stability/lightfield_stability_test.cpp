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
#include "lightfield_specs.h"
#include "mock_device/render/lightfield_render.h"

namespace camlab::analysis::lightfield {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

// The example light-field camera's optics at 48 x 48 px, a perfect lens.
json camera(int views) { return testing::lightfield_camera_json(48, 48, views, "none", 0.0); }

// One target filling the view at z_m, before a background of 0.3.
json scene(const char* type, double z_m) {
  json s = testing::lightfield_scene(
      json::array({testing::lightfield_target(type, "target", 0.5, 0.0, 0.0, z_m)}));
  s["background_reflectance"] = 0.3;
  return s;
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
