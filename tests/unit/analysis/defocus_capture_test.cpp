// End to end on virtual-camera captures with known truth: an aperture series (C x N
// constant, k against the thin lens, each frame against the renderer's predicted CoC)
// and a focus sweep with an in-focus baseline blur (V-curve best focus against the
// position that images the target's distance).
#include "analysis/defocus/defocus_report.h"

#include <cmath>
#include <cstdio>
#include <filesystem>

#include <gtest/gtest.h>

#include "capture_fixture.h"
#include "image/capture_folder.h"
#include "optics/optics.h"

namespace camlab::analysis {
namespace {

// f = 8 mm, 6 um pixels (the Airy disk at f/11 is 2.46 px), 12 bits, focus 1 um/step.
nlohmann::json camera_json(double baseline_sigma_px) {
  return {
      {"name", "analysis test"},
      {"sensor",
       {{"width_px", 192},
        {"height_px", 192},
        {"pixel_pitch_um", 6.0},
        {"bit_depth", 12},
        {"black_level_dn", 64},
        {"full_well_e", 20000},
        {"read_noise_e", 2.0},
        {"quantum_efficiency", 0.6}}},
      {"lens",
       {{"focal_mm", 8.0},
        {"model", "LENSMODEL_PINHOLE"},
        {"f_number_min", 1.4},
        {"f_number_max", 22.0},
        {"baseline_blur_sigma_px", baseline_sigma_px},
        {"focus",
         {{"position_min", 0}, {"position_max", 2000}, {"extension_mm_per_step", 0.001}}}}},
      {"timing", {{"frame_interval_us", 100000}}},
      {"controls", {{"exposure_time_absolute", {{"min", 1}, {"max", 1000}, {"default", 100}}}}},
  };
}

nlohmann::json edge_scene_json(double distance_m) {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", 0.18},
          {"targets",
           {{{"type", "slanted_edge"},
             {"name", "edge"},
             {"size_m", {0.035, 0.035}},
             {"angle_deg", 5},
             {"dark_reflectance", 0.1},
             {"light_reflectance", 0.8},
             {"pose", {{"position_m", {0.0, 0.0, distance_m}}}}}}}};
}

// Exposure for a light level near 60% of the well at f-number n (signal ~ T / N^2).
double exposure_us_for(double n) { return std::round(27.0 * (n / 2.0) * (n / 2.0)) * 100.0; }

TEST(DefocusCapture, ApertureSeriesKeepsCTimesNConstant) {
  auto renderer = testing::make_renderer(camera_json(0.0), edge_scene_json(0.35));
  const auto dir = testing::fresh_dir("aperture");
  std::vector<mock::RenderSettings> settings;
  for (double n : {2.0, 2.8, 4.0, 5.6, 8.0, 11.0})
    settings.push_back({exposure_us_for(n), 1.0, n, 0});  // focused at infinity
  testing::render_frames(renderer, dir, settings, 3);

  DefocusOptions options;
  options.threads = 2;
  auto report = analyze_defocus(dir, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->sweep, "f_number");
  ASSERT_EQ(report->targets.size(), 1u);
  const TargetDefocus& t = report->targets[0];
  ASSERT_TRUE(t.aperture.has_value()) << t.aperture_error;
  EXPECT_EQ(t.aperture->used_count, 6);  // f/11: 2.8 px, above its 2.46 px Airy floor
  // C x N constant within 2% across f/2..f/11.
  EXPECT_LT(t.aperture->max_abs_cn_deviation, 0.02);
  for (const FrameEdge& fe : t.frames) {
    ASSERT_TRUE(fe.truth_coc_px.has_value());
    EXPECT_EQ(fe.edge.status, kEdgeOk) << fe.edge.message;
    EXPECT_NEAR(fe.edge.diameter_px, *fe.truth_coc_px, std::max(0.1, 0.02 * *fe.truth_coc_px))
        << "f/" << fe.f_number;
  }
  // Thin lens: s = infinity, C N = f^2 / z_o, i.e. 8^2 / 350 mm / 6 um = 30.48 px.
  ASSERT_TRUE(t.thin_lens_k_px.has_value());
  EXPECT_NEAR(*t.thin_lens_k_px, 64.0 / 350.0 / 6e-3, 1e-6);
  EXPECT_NEAR(t.aperture->k_px / *t.thin_lens_k_px, 1.0, 0.01);
  // Implied defocus |z_s - z_i| / z_i = k pitch / f = f / z_o for s = infinity... to first
  // order: z_i = f z_o / (z_o - f), (z_i - f) / z_i = f / z_o.
  EXPECT_NEAR(t.implied_defocus, 8.0 / 350.0, 0.01 * 8.0 / 350.0);
  const nlohmann::json j = to_json(*report);
  EXPECT_EQ(j["targets"][0]["coc_vs_aperture"]["frames_used"], 6);
  std::filesystem::remove_all(dir);
}

TEST(DefocusCapture, FocusSweepVCurveFindsTheTargetsFocusThroughBaselineBlur) {
  auto renderer = testing::make_renderer(camera_json(0.8), edge_scene_json(0.35));
  const auto dir = testing::fresh_dir("vcurve");
  std::vector<mock::RenderSettings> settings;
  for (int p = 127; p <= 247; p += 10) settings.push_back({exposure_us_for(2.0), 1.0, 2.0, p});
  testing::render_frames(renderer, dir, settings, 4);

  DefocusOptions options;
  options.threads = 2;
  options.acceptable_coc_px = 2.0;
  auto report = analyze_defocus(dir, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  EXPECT_EQ(report->sweep, "focus_position");
  EXPECT_NEAR(report->baseline_sigma_px, 0.8, 1e-12);
  const TargetDefocus& t = report->targets[0];
  ASSERT_TRUE(t.v_curve.has_value()) << t.v_curve_error;
  // The target at 350 mm images at z_i = f z_o / (z_o - f) = 8.18713 mm: p0 = 187.13.
  const double zi_mm = 8.0 * 350.0 / 342.0;
  const double p0 = (zi_mm - 8.0) / 0.001;
  EXPECT_FALSE(t.v_curve->p0_at_end);
  EXPECT_NEAR(t.v_curve->best_position, p0, std::max(0.5, 3 * t.v_curve->best_position_sigma));
  EXPECT_LT(t.v_curve->best_position_sigma, 0.5);
  // Slope A / z_i with A = 4 mm.
  ASSERT_TRUE(t.aperture_over_zi.has_value());
  EXPECT_NEAR(*t.aperture_over_zi, 4.0 / zi_mm, 0.02 * 4.0 / zi_mm);
  ASSERT_TRUE(t.best_focus_distance_m.has_value());
  EXPECT_NEAR(*t.best_focus_distance_m, 0.35, 0.005);
  // DOF for c = 2 px = 12 um around the measured focus: compare with the optics formula
  // at the true distance.
  auto dof = optics::depth_of_field(8.0, 2.0, 350.0, 0.012);
  ASSERT_TRUE(dof.ok());
  ASSERT_TRUE(t.dof_near_m && t.dof_far_m);
  EXPECT_NEAR(*t.dof_near_m, dof->near_mm * 1e-3, 0.003);
  EXPECT_NEAR(*t.dof_far_m, dof->far_mm * 1e-3, 0.003);
  // Frames near focus read at the baseline; every frame away from it is measured close
  // to the renderer's predicted CoC even with the 0.8 px Gaussian on top.
  int at_baseline = 0;
  for (const FrameEdge& fe : t.frames) {
    if (fe.edge.status == kEdgeAtBaseline) ++at_baseline;
    if (fe.edge.status == kEdgeOk && *fe.truth_coc_px > 1.5) {
      EXPECT_NEAR(fe.edge.diameter_px, *fe.truth_coc_px, std::max(0.1, 0.03 * *fe.truth_coc_px))
          << "position " << fe.focus_position;
    }
  }
  EXPECT_GE(at_baseline, 1);
  std::filesystem::remove_all(dir);
}

// The same aperture series without truth (as from a real camera): the edges are found
// automatically, and the one at the target's edge gives the same C x N.
TEST(DefocusCapture, EdgesFoundWithoutTruthGiveTheSameK) {
  auto renderer = testing::make_renderer(camera_json(0.0), edge_scene_json(0.35));
  const auto with_truth = testing::fresh_dir("found_truth"),
             bare = testing::fresh_dir("found_bare");
  std::vector<mock::RenderSettings> settings;
  for (double n : {2.0, 4.0, 8.0}) settings.push_back({exposure_us_for(n), 1.0, n, 0});
  testing::render_frames(renderer, with_truth, settings, 3);
  testing::render_frames(renderer, bare, settings, 3, true, false);
  DefocusOptions options;
  options.threads = 2;
  auto truth_report = analyze_defocus(with_truth, options);
  auto bare_report = analyze_defocus(bare, options);
  ASSERT_TRUE(truth_report.ok() && bare_report.ok());
  const TargetDefocus& t = truth_report->targets[0];
  ASSERT_TRUE(t.aperture.has_value());
  // The truth's edge middle: the detected edge whose fitted line passes nearest to it.
  image::CaptureFolder folder = *image::CaptureFolder::open(with_truth);
  const auto mid = (*folder.load_sidecar(0)).truth["targets"][0]["edge_px"]["middle"];
  const double mx = mid[0], my = mid[1];
  const TargetDefocus* match = nullptr;
  double best = 1e9;
  for (const TargetDefocus& b : bare_report->targets) {
    const EdgeMeasurement& m = b.frames[0].edge;
    if (!m.measured()) continue;
    const double nx = -std::sin(m.fit.angle_rad), ny = std::cos(m.fit.angle_rad);
    const double along = std::hypot(m.fit.line.x_px - mx, m.fit.line.y_px - my);
    const double across = std::fabs((mx - m.fit.line.x_px) * nx + (my - m.fit.line.y_px) * ny);
    if (along < 30 && across < best) {
      best = across;
      match = &b;
    }
  }
  ASSERT_NE(match, nullptr) << bare_report->targets.size() << " edges found";
  EXPECT_LT(best, 0.5);
  ASSERT_TRUE(match->aperture.has_value()) << match->aperture_error;
  EXPECT_NEAR(match->aperture->k_px / t.aperture->k_px, 1.0, 0.01);
  EXPECT_FALSE(match->thin_lens_k_px.has_value());  // no distances without truth
  std::filesystem::remove_all(with_truth);
  std::filesystem::remove_all(bare);
}

TEST(DefocusCapture, FolderWithoutEdgesIsASpecificError) {
  auto renderer =
      testing::make_renderer(camera_json(0.0), {{"targets",
                                                 {{{"type", "uniform"},
                                                   {"size_m", {1.0, 1.0}},
                                                   {"pose", {{"position_m", {0.0, 0.0, 1.0}}}}}}}});
  const auto dir = testing::fresh_dir("noedge");
  testing::render_frames(renderer, dir, {{10000, 1.0, 4.0, 0}}, 1, false);
  auto report = analyze_defocus(dir, {});
  ASSERT_FALSE(report.ok());
  EXPECT_EQ(report.error().code, "no_edge_geometry");
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace camlab::analysis
