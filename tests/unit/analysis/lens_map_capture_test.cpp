// The lens map of a virtual lens whose best-focus surface is tilted and curved
// (lens.field_focus): the renderer's rays focus each pixel through the surface, the lens
// map finds it again from a focus x aperture grid (15 focus positions x 5 f-numbers, as a
// lens-map capture would take), and both are held to the spec's numbers.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>

#include "analysis/lensmap/lens_map.h"
#include "capture_fixture.h"
#include "lens_map_sweep.h"
#include "mock_device/render/render_capture.h"

namespace camlab::analysis {
namespace {
namespace lens_map_capture_test {

nlohmann::json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  return nlohmann::json::parse(in);
}

// A lens-map capture of the example chart (squares on a plane 1 m away) into `dir`: the
// f-numbers x 15 focus positions 7 steps apart (15 to 113), 1 ms exposures. Returns the
// frame count, or -1 with the failure added.
int render_lens_map_capture(const nlohmann::json& camera, const std::filesystem::path& dir,
                            const std::vector<double>& f_numbers, uint64_t seed) {
  const nlohmann::json scene =
      read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/scene_lensmap_chart.json");
  auto renderer = testing::make_renderer(camera, scene);
  auto rendered =
      mock::render_capture(renderer, testing::lens_map_sweep(renderer, dir, f_numbers, seed));
  EXPECT_TRUE(rendered.ok()) << rendered.error().message;
  return rendered.ok() ? rendered->frames : -1;
}

TEST(LensMapCapture, TiltedCurvedFocusSurfaceOfTheVirtualLensIsFoundAtEveryAperture) {
  // The example 8 mm lens (4 um pixels, 640 x 480: half diagonal 1.6 mm; 1 um of lens
  // travel a focus step) with its best-focus surface rising 0.4 deg to the right, falling
  // 0.25 deg downward, and 15 um closer to the lens at the corners.
  nlohmann::json camera = read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_640x480.json");
  const double tilt_x_deg = 0.4, tilt_y_deg = -0.25, sag_um = -15;
  camera["lens"]["field_focus"] = {
      {"tilt_x_deg", tilt_x_deg}, {"tilt_y_deg", tilt_y_deg}, {"curvature_sag_um", sag_um}};
  const auto dir = testing::fresh_dir("lens_map_capture");
  ASSERT_EQ(render_lens_map_capture(camera, dir, {1.4, 2, 2.8, 4, 5.6}, 3), 75);

  // The frames' truth records the surface the renderer used.
  const auto first = read_json(dir / "frame_000000.json");
  ASSERT_TRUE(first["truth"].contains("field_focus")) << first["truth"].dump();
  EXPECT_EQ(first["truth"]["field_focus"]["curvature_sag_um"].get<double>(), sag_um);

  auto map = analyze_lens_map(dir, LensMapOptions{});
  ASSERT_TRUE(map.ok()) << map.error().message;
  const auto& surfaces = map->report["surfaces"];
  ASSERT_EQ(surfaces.size(), 5u);

  // The truth in focus steps: the thin lens's position for the chart at 1 m on the axis,
  // the surface's offsets at the half diagonal (tilt) and the corner (sag) over 1 um a step.
  const double f_mm = 8, d_mm = 1000, step_mm = 0.001, half_diagonal_mm = 1.6;
  const double axis = (f_mm * d_mm / (d_mm - f_mm) - f_mm) / step_mm;
  const double rad = std::numbers::pi / 180;
  const double truth_tilt_x = std::tan(tilt_x_deg * rad) * half_diagonal_mm / step_mm;
  const double truth_tilt_y = std::tan(tilt_y_deg * rad) * half_diagonal_mm / step_mm;
  const double truth_sag = sag_um * 1e-3 / step_mm;
  const double sweep_step = testing::kLensMapSweepStep;
  for (const auto& s : surfaces) {
    const double n = s["f_number"].get<double>();
    const double sag = s["curvature_at_corner"].get<double>();
    const double astigmatism = s["astigmatism_at_corner"].get<double>();
    const auto& se = s["standard_errors"];
    std::printf(
        "f/%.1f: %d edges, axis %.3f +- %.3f (truth %.3f), tilt %.3f +- %.3f, %.3f +- %.3f "
        "(truth %.3f %.3f), sag %.3f +- %.3f (truth %.3f, %+.1f%%), astigmatism %.3f +- %.3f "
        "(truth 0), %.4f %.4f deg, rms %.3f\n",
        n, s["edges_used"].get<int>(), s["centre_focus"].get<double>(),
        se["centre_focus"].get<double>(), axis, s["tilt_x_per_half_diagonal"].get<double>(),
        se["tilt_x_per_half_diagonal"].get<double>(), s["tilt_y_per_half_diagonal"].get<double>(),
        se["tilt_y_per_half_diagonal"].get<double>(), truth_tilt_x, truth_tilt_y, sag,
        se["curvature_at_corner"].get<double>(), truth_sag, 100 * (sag / truth_sag - 1),
        astigmatism, se["astigmatism_at_corner"].get<double>(),
        s["at_sensor"]["tilt_x_deg"].get<double>(), s["at_sensor"]["tilt_y_deg"].get<double>(),
        s["rms_residual"].get<double>());
    EXPECT_GE(s["edges_used"].get<int>(), 36) << n;
    // Each number within 4 of its stated standard errors of the truth (the errors are the
    // edges' scatter about the surface, so this checks that they are honest), and within
    // the issue's bounds at every f-number: sag within 5%, tilt within 0.05 deg and
    // astigmatism within 0.05 of the sweep's step. The capture holds the exposure across
    // the stops (lens_map_sweep.h); over 24 seeds the astigmatism's rms error is
    // 0.007-0.025 of a step, 119 of 120 within 0.05 (lens_map_bench).
    const auto& sigma = s["standard_errors"];
    auto check = [&](const char* what, double measured, double truth, double stated, double bound) {
      EXPECT_NEAR(measured, truth, 4 * stated) << what << " at f/" << n;
      EXPECT_NEAR(measured, truth, bound) << what << " at f/" << n;
    };
    check("axis", s["centre_focus"].get<double>(), axis, sigma["centre_focus"].get<double>(), 0.5);
    check("sag", sag, truth_sag, sigma["curvature_at_corner"].get<double>(),
          0.05 * std::fabs(truth_sag));
    check("tilt x", s["tilt_x_per_half_diagonal"].get<double>(), truth_tilt_x,
          sigma["tilt_x_per_half_diagonal"].get<double>(), 1e9);
    check("tilt y", s["tilt_y_per_half_diagonal"].get<double>(), truth_tilt_y,
          sigma["tilt_y_per_half_diagonal"].get<double>(), 1e9);
    check("astigmatism", astigmatism, 0, sigma["astigmatism_at_corner"].get<double>(),
          0.05 * sweep_step);
    const auto& at_sensor = s["at_sensor"];
    EXPECT_NEAR(at_sensor["tilt_x_deg"].get<double>(), tilt_x_deg, 0.05) << n;
    EXPECT_NEAR(at_sensor["tilt_y_deg"].get<double>(), tilt_y_deg, 0.05) << n;
    EXPECT_NEAR(at_sensor["curvature_um"].get<double>(), sag_um, 0.05 * std::fabs(sag_um)) << n;
  }
  std::filesystem::remove_all(dir);
}

// An astigmatic lens: the sagittal surface 8 um beyond the meridional at the corner (about
// the same medial surface). Every edge's best focus mixes the two by its orientation; the
// lens map finds them apart.
TEST(LensMapCapture, AstigmatismOfTheVirtualLensIsTheSurfacesDistanceAtTheCorner) {
  nlohmann::json camera = read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_640x480.json");
  const double astigmatism_um = 8, sag_um = -15;
  camera["lens"]["field_focus"] = {{"curvature_sag_um", sag_um},
                                   {"astigmatism_um", astigmatism_um}};
  const auto dir = testing::fresh_dir("lens_map_astigmatism");
  ASSERT_EQ(render_lens_map_capture(camera, dir, {1.4, 2.8}, 5), 30);
  auto map = analyze_lens_map(dir, LensMapOptions{});
  ASSERT_TRUE(map.ok()) << map.error().message;
  ASSERT_EQ(map->report["surfaces"].size(), 2u);
  for (const auto& s : map->report["surfaces"]) {
    const double n = s["f_number"].get<double>();
    const double measured = s["at_sensor"]["astigmatism_um"].get<double>();
    const double sigma = s["at_sensor"]["standard_errors"]["astigmatism_um"].get<double>();
    const double curvature = s["at_sensor"]["curvature_um"].get<double>();
    std::printf(
        "f/%.1f: astigmatism %.3f +- %.3f um (truth %.1f), curvature %.3f um (truth %.1f)\n", n,
        measured, sigma, astigmatism_um, curvature, sag_um);
    EXPECT_NEAR(measured, astigmatism_um, 4 * sigma) << n;
    EXPECT_NEAR(measured, astigmatism_um, 0.1 * astigmatism_um) << n;
    EXPECT_NEAR(curvature, sag_um, 0.05 * std::fabs(sag_um)) << n;
  }
  // Both f-numbers together, each weighted by its error: tighter than either, and the two
  // agree (the renderer's astigmatism, as a lens's third-order one, does not change with
  // the stop).
  const auto& pooled = map->report["astigmatism_all_f_numbers"];
  ASSERT_TRUE(pooled.is_object()) << map->report.dump(1).substr(0, 2000);
  const double measured = pooled["astigmatism_um"].get<double>();
  const double sigma = pooled["standard_error_um"].get<double>();
  std::printf("all f-numbers: astigmatism %.3f +- %.3f um, chi2 %.2f\n", measured, sigma,
              pooled["chi2"].get<double>());
  EXPECT_NEAR(measured, astigmatism_um, 4 * sigma);
  EXPECT_TRUE(pooled["f_numbers_agree"].get<bool>()) << pooled.dump();
  for (const auto& s : map->report["surfaces"])
    EXPECT_LT(sigma, s["at_sensor"]["standard_errors"]["astigmatism_um"].get<double>());
  EXPECT_NE(map->text.find("all f-numbers: astigmatism"), std::string::npos) << map->text;
  std::filesystem::remove_all(dir);
}

// Longitudinal colour on the colour example camera (RGGB raw frames): R focuses 0.02 mm
// behind the nominal 8 mm lens and B 0.015 mm in front of it, so at 1 m R's best focus is
// z_i,R - z_i,G = 20.32 steps beyond green's and B's 15.24 short of it. With lateral
// colour added (R's image 0.8 px outward of G's at the corner, B's 0.5 px inward), each
// channel's edges move across their lines by that scale.
TEST(LensMapCapture, LongitudinalAndLateralColourAreEachChannelsAgainstGreens) {
  nlohmann::json camera =
      read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_colour_640x480.json");
  const double lateral_r_px = 0.8, lateral_b_px = -0.5;
  camera["lens"]["lateral_colour_px"] = {lateral_r_px, 0.0, lateral_b_px};
  const auto dir = testing::fresh_dir("lens_map_colour");
  ASSERT_EQ(render_lens_map_capture(camera, dir, {2, 2.8}, 4), 30);
  auto map = analyze_lens_map(dir, LensMapOptions{});
  ASSERT_TRUE(map.ok()) << map.error().message;

  const double d_mm = 1000, step_mm = 0.001, sweep_step = testing::kLensMapSweepStep;
  auto image_mm = [&](double f_mm) { return f_mm * d_mm / (d_mm - f_mm); };
  const double truth_r = (image_mm(8.02) - image_mm(8.0)) / step_mm;
  const double truth_b = (image_mm(7.985) - image_mm(8.0)) / step_mm;
  ASSERT_EQ(map->report["surfaces"].size(), 2u);
  for (const auto& s : map->report["surfaces"]) {
    const double n = s["f_number"].get<double>();
    ASSERT_TRUE(s.contains("channels")) << n;
    ASSERT_EQ(s["channels"].size(), 3u);
    for (const auto& c : s["channels"]) {
      const std::string name = c["channel"].get<std::string>();
      if (name == "G") {
        EXPECT_TRUE(c["focus_minus_green"].is_null());
        continue;
      }
      const double truth = name == "R" ? truth_r : truth_b;
      const double measured = c["focus_minus_green"].get<double>();
      const double sigma = c["focus_minus_green_standard_error"].get<double>();
      std::printf("f/%.1f %s: best focus minus green %.3f +- %.3f (truth %.3f), %d edges\n", n,
                  name.c_str(), measured, sigma, truth, c["edges_paired"].get<int>());
      EXPECT_GE(c["edges_paired"].get<int>(), 30) << name << " f/" << n;
      EXPECT_NEAR(measured, truth, 4 * sigma) << name << " f/" << n;
      // Within 0.02 of the sweep's step, the issue's bound (over 24 seeds the rms error is
      // 0.004-0.011 of it, 95 of 96 within 0.02; lens_map_bench, docs/analysis.md).
      EXPECT_NEAR(measured, truth, 0.02 * sweep_step) << name << " f/" << n;
      EXPECT_NEAR(s["at_sensor"]["longitudinal_colour_um"][name].get<double>(),
                  truth * step_mm * 1e3, 1e-9 + 1e3 * step_mm * 8 * sigma);
      // Lateral colour: within 4 standard errors and 0.02 px (the issue's bound).
      const double lateral_truth = name == "R" ? lateral_r_px : lateral_b_px;
      const double lateral = c["lateral_colour_px_at_corner"].get<double>();
      const double lateral_sigma = c["lateral_colour_px_standard_error"].get<double>();
      std::printf("f/%.1f %s: lateral colour %.4f +- %.4f px at the corner (truth %.1f), %d fits\n",
                  n, name.c_str(), lateral, lateral_sigma, lateral_truth,
                  c["lateral_samples"].get<int>());
      EXPECT_NEAR(lateral, lateral_truth, 4 * lateral_sigma) << name << " f/" << n;
      EXPECT_NEAR(lateral, lateral_truth, 0.02) << name << " f/" << n;
      EXPECT_GE(c["lateral_samples"].get<int>(), 300) << name << " f/" << n;
    }
  }
  std::filesystem::remove_all(dir);
}

}  // namespace lens_map_capture_test
}  // namespace
}  // namespace camlab::analysis
