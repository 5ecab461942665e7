// Light fields of the virtual camera end to end (docs/analysis.md, "Light fields"):
// refocused images against the thin-lens render focused there, the blur camlab analyze
// defocus measures on refocused aperture series against the thin lens for the synthetic
// aperture, depth against the depth truth, decoding against the directly rendered views,
// and a refocused stack read by camlab analyze focus. Each light field is rendered once
// per test, small (the figures at larger sizes are lightfield_bench's).
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <map>

#include <opencv2/imgproc.hpp>

#include "analysis/analyze_folder.h"
#include "analysis/focus/focus_report.h"
#include "analysis/lightfield/depth.h"
#include "analysis/lightfield/lenslet_decode.h"
#include "analysis/lightfield/refocus_capture.h"
#include "capture_fixture.h"
#include "lightfield_measures.h"
#include "lightfield_specs.h"
#include "mock_device/render/lightfield_render.h"
#include "optics/optics.h"

namespace camlab::analysis {
namespace {

using nlohmann::json;
namespace fs = std::filesystem;

using testing::lightfield_camera_json;
using testing::lightfield_scene;
using testing::lightfield_target;

// Renders the light field into a fresh folder and loads it.
lightfield::LightField render_light_field(mock::Renderer& renderer, const fs::path& dir,
                                          mock::RenderSettings settings, bool noise = false) {
  mock::RenderOptions options;
  options.noise = noise;
  auto frame = mock::render_light_field(renderer, settings, 0, options);
  if (!frame) throw std::runtime_error(frame.error().message);
  if (Status s = mock::write_light_field(*frame, renderer, dir, options); !s)
    throw std::runtime_error(s.error().message);
  auto lf = lightfield::load_light_field(dir);
  if (!lf) throw std::runtime_error(lf.error().message);
  return std::move(*lf);
}

TEST(LightFieldCapture, RefocusedEdgesMatchTheThinLensRenderFocusedThere) {
  // Two edges, at 0.8 and 1.3 m, the light field focused at 0.99 m: refocused at each
  // edge's distance (a focus position of the lens), against the thin lens focused there.
  mock::Renderer renderer = testing::make_renderer(
      lightfield_camera_json(128, 64, 9),
      lightfield_scene({lightfield_target("slanted_edge", "near", 0.018, -0.013, 0.0, 0.8),
                        lightfield_target("slanted_edge", "far", 0.03, 0.021, 0.0, 1.3)}));
  const fs::path dir = testing::fresh_dir("lf_refocus");
  const auto lf = render_light_field(renderer, dir, renderer.default_settings());
  for (auto [name, position] : {std::pair{"near", 81}, std::pair{"far", 50}}) {
    mock::RenderSettings focused = renderer.default_settings();
    focused.focus_position = position;
    mock::RenderOptions options;
    options.noise = false;
    auto thin = renderer.render(focused, 0, options);
    ASSERT_TRUE(thin.ok());
    auto r = lightfield::refocus(lf, thin->settings["focus_distance_m"].get<double>());
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_NEAR(r->lens_to_sensor_mm, thin->settings["lens_to_sensor_mm"].get<double>(), 1e-9);
    cv::Mat reference;
    thin->image.convertTo(reference, CV_32F, 1.0, -64);
    const auto d = testing::edge_profile_difference(r->image, reference,
                                                    testing::edge_segment(thin->truth, name), 8);
    ASSERT_GT(d.pixels, 300);
    // docs/BENCHMARKS.md: 0.7-0.8% for 9 x 9 views; most of it is interpolating an edge
    // that is nearly as sharp as a pixel.
    EXPECT_LT(d.rms_over_contrast, 0.01) << name;
    EXPECT_GT(r->view_step_px, 0.15) << name;  // the views were shifted a fifth of a pixel
  }
  fs::remove_all(dir);
}

TEST(LightFieldCapture, DefocusOfRefocusedImagesFollowsTheSyntheticAperture) {
  // One edge filling the view at 0.8 m, the light field focused on it; refocused at 0.55
  // and 1.6 m through f/2 (every view), f/2.8 and f/4 (synthetic apertures), measured by
  // camlab analyze defocus (edges found, no truth in the frames).
  mock::Renderer renderer = testing::make_renderer(
      lightfield_camera_json(160, 120, 9, "none", 0.0),
      lightfield_scene(
          json::array({lightfield_target("slanted_edge", "edge", 1.0, 0.0, 0.0, 0.8)})));
  mock::RenderSettings settings = renderer.default_settings();
  settings.focus_position = 81;  // 0.7926 m
  const fs::path dir = testing::fresh_dir("lf_defocus");
  const auto lf = render_light_field(renderer, dir, settings);
  for (double s_m : {0.55, 1.6}) {
    const fs::path out = testing::fresh_dir("lf_defocus_series");
    auto summary = lightfield::write_refocus_capture(lf, {s_m}, {0, 2.8, 4}, out);
    ASSERT_TRUE(summary.ok()) << summary.error().message;
    auto report = analyze_folder("defocus", out, AnalyzeOptions{});
    ASSERT_TRUE(report.ok()) << report.error().message;
    ASSERT_EQ((*report)["targets"].size(), 1u) << report->dump(2);
    const json& t = (*report)["targets"][0];
    // The thin lens focused at s, for the edge at 0.8 m: C = (f^2 / N) |z - s| / (z (s - f)).
    const double k_px = *optics::circle_of_confusion_mm(8.0, 1.0, s_m * 1e3, 800.0) / 0.004;
    for (const json& f : t["frames"]) {
      ASSERT_EQ(f["status"], "ok") << f.dump();
      const double n = f["f_number"], d = f["diameter_px"];
      EXPECT_NEAR(d / (k_px / n), 1, 0.02) << "s " << s_m << " f/" << n;
    }
    EXPECT_NEAR(t["coc_vs_aperture"]["k_px"].get<double>() / k_px, 1, 0.01) << s_m;
    fs::remove_all(out);
  }
  fs::remove_all(dir);
}

TEST(LightFieldCapture, DepthOfTexturedPlanesWithinAPercent) {
  // Three textured planes side by side, 40 px wide each, the light field focused at
  // 0.99 m, with noise.
  mock::Renderer renderer = testing::make_renderer(
      lightfield_camera_json(144, 64, 9),
      lightfield_scene({lightfield_target("texture", "near", 0.0119, -0.0134, 0.0, 0.6),
                        lightfield_target("texture", "mid", 0.0198, 0.0, 0.0, 1.0),
                        lightfield_target("texture", "far", 0.0317, 0.0357, 0.0, 1.6)}));
  const fs::path dir = testing::fresh_dir("lf_depth");
  const auto lf = render_light_field(renderer, dir, renderer.default_settings(), true);
  auto depth = lightfield::estimate_depth(lf, {});
  ASSERT_TRUE(depth.ok()) << depth.error().message;
  auto folder = image::LightFieldFolder::open(dir);
  const cv::Mat truth = *folder->load_depth_truth();
  // The planes' insides: 6 px from any change of depth (the 7 px window's half and the
  // near plane's largest disparity, 2.6 px, at the outermost view).
  cv::Mat lo, hi;
  cv::erode(truth, lo, cv::Mat::ones(13, 13, CV_8U));
  cv::dilate(truth, hi, cv::Mat::ones(13, 13, CV_8U));
  struct Plane {
    int inside = 0, measured = 0;
    double worst = 0;  // relative error
  };
  std::map<int, Plane> planes;  // by depth in cm
  for (int y = 6; y < truth.rows - 6; ++y)
    for (int x = 6; x < truth.cols - 6; ++x) {
      const float z = truth.at<float>(y, x);
      if (z <= 0 || lo.at<float>(y, x) != hi.at<float>(y, x)) continue;
      Plane& p = planes[static_cast<int>(std::lround(z * 100))];
      ++p.inside;
      if (depth->status.at<uint8_t>(y, x) != lightfield::kDepthOk) continue;
      ++p.measured;
      p.worst = std::max(p.worst, std::fabs(depth->depth_m.at<float>(y, x) / z - 1.0));
    }
  for (int cm : {60, 100, 160}) {
    const Plane& p = planes[cm];
    ASSERT_GT(p.inside, 200) << cm;
    // A texture's weakest spots are left undecided, never given a wrong depth.
    EXPECT_GT(p.measured, 0.97 * p.inside) << cm << " cm";
    EXPECT_LT(p.worst, 0.01) << cm << " cm";
  }
  fs::remove_all(dir);
}

TEST(LightFieldCapture, DecodedLensletImagesAreTheViewsWithinADn) {
  for (auto [grid, views] : {std::pair{"square", 9}, std::pair{"hex", 10}}) {
    json camera = lightfield_camera_json(48, 32, views, grid);
    camera["lightfield"]["lenslet_margin_px"] = 2;
    mock::Renderer renderer = testing::make_renderer(
        camera,
        lightfield_scene({lightfield_target("texture", "t", 0.03, 0.0, 0.0, 0.7),
                          lightfield_target("slanted_edge", "e", 0.02, 0.004, 0.003, 1.2)}));
    const fs::path dir = testing::fresh_dir("lf_decode"), out = testing::fresh_dir("lf_decoded");
    render_light_field(renderer, dir, renderer.default_settings());
    auto decoded = lightfield::decode_lenslet_folder(dir, out, {});
    ASSERT_TRUE(decoded.ok()) << decoded.error().message;
    auto direct = image::LightFieldFolder::open(dir);
    auto back = image::LightFieldFolder::open(out);
    ASSERT_TRUE(back.ok());
    EXPECT_EQ(back->description().lattice.layout, grid);
    double sq = 0;
    long n = 0;
    for (size_t k = 0; k < back->description().views.size(); ++k) {
      const auto& v = back->description().views[k];
      size_t j = 0;
      while (direct->description().views[j].u_index != v.u_index ||
             direct->description().views[j].v_index != v.v_index)
        ++j;
      cv::Mat a, b;
      direct->load_view(static_cast<int>(j))->convertTo(a, CV_64F);
      back->load_view(static_cast<int>(k))->convertTo(b, CV_64F);
      ASSERT_EQ(a.size(), b.size());
      const cv::Mat diff = a - b;
      sq += diff.dot(diff);
      n += static_cast<long>(diff.total());
    }
    EXPECT_GT(back->description().views.size(), 60u) << grid;
    EXPECT_LT(std::sqrt(sq / n), 1.0) << grid;  // DN RMS
    fs::remove_all(dir);
    fs::remove_all(out);
  }
}

TEST(LightFieldCapture, RefocusedStackIsAFocusStack) {
  mock::Renderer renderer = testing::make_renderer(
      lightfield_camera_json(96, 64, 9),
      lightfield_scene(json::array({lightfield_target("texture", "t", 0.1, 0.0, 0.0, 0.75)})));
  const fs::path dir = testing::fresh_dir("lf_stack"), out = testing::fresh_dir("lf_stack_out");
  const auto lf = render_light_field(renderer, dir, renderer.default_settings(), true);
  auto sweep = lightfield::focus_sweep_m(0.5, 2.0, 13);
  ASSERT_TRUE(sweep.ok());
  auto summary = lightfield::write_refocus_capture(lf, *sweep, {}, out);
  ASSERT_TRUE(summary.ok()) << summary.error().message;
  auto report = analyze_focus(out, FocusStackOptions{});
  ASSERT_TRUE(report.ok()) << report.error().message;
  int ok = 0;
  for (const auto& region : report->regions) {
    if (region.focus.status != kFocusOk || !region.distance_m) continue;
    ++ok;
    // Depth from focus after capture: 13 frames, 0.5 dioptre apart (docs/BENCHMARKS.md).
    EXPECT_NEAR(*region.distance_m / 0.75, 1, 0.03);
  }
  EXPECT_GE(ok, 4);
  fs::remove_all(dir);
  fs::remove_all(out);
}

}  // namespace
}  // namespace camlab::analysis
