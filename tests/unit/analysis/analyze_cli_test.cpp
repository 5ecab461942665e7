// `camlab analyze` end to end: the built CLI on virtual-camera captures (JSON output
// checked against the truth, report and plot files written) and its error contract
// ("camlab analyze: <message>" on stderr, exit status 2).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <numbers>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "../../integration/cli_runner.h"
#include "analysis/analysis_summary.h"
#include "capture_fixture.h"
#include "mock_device/render/render_capture.h"
#include "sfr_edges.h"

namespace camlab::analysis {
namespace {

nlohmann::json camera_json() {
  return {{"name", "cli test"},
          {"sensor",
           {{"width_px", 160},
            {"height_px", 160},
            {"pixel_pitch_um", 6.0},
            {"bit_depth", 12},
            {"black_level_dn", 64},
            {"full_well_e", 20000},
            {"read_noise_e", 2.0}}},
          {"lens",
           {{"focal_mm", 8.0},
            {"model", "LENSMODEL_PINHOLE"},
            {"f_number_min", 1.4},
            {"focus",
             {{"position_min", 0}, {"position_max", 2000}, {"extension_mm_per_step", 0.001}}}}},
          {"timing", {{"frame_interval_us", 100000}}},
          {"controls", {{"exposure_time_absolute", {{"min", 1}, {"max", 1000}, {"default", 30}}}}}};
}

TEST(AnalyzeCli, DefocusJsonReportAndPlots) {
  auto renderer =
      testing::make_renderer(camera_json(), {{"illuminance_lux", 1000},
                                             {"targets",
                                              {{{"type", "slanted_edge"},
                                                {"name", "edge"},
                                                {"size_m", {0.03, 0.03}},
                                                {"angle_deg", 5},
                                                {"pose", {{"position_m", {0.0, 0.0, 0.35}}}}}}}});
  const auto dir = testing::fresh_dir("cli_defocus");
  std::vector<mock::RenderSettings> settings;
  for (double n : {2.0, 4.0, 8.0})
    settings.push_back({std::round(27.0 * n * n / 4) * 100.0, 1.0, n, 0});
  testing::render_frames(renderer, dir, settings, 5);
  const auto plots = dir.string() + "_plots", report = dir.string() + "_report.json";
  const auto run = camlab::testing::run_cli("analyze defocus " + dir.string() + " --json --plots " +
                                            plots + " --report " + report);
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  EXPECT_EQ(j["sweep"], "f_number");
  const auto& aperture = j["targets"][0]["coc_vs_aperture"];
  // Thin lens, focused at infinity: k = f^2 / z_o / pitch = 30.48 px.
  EXPECT_NEAR(aperture["k_px"].get<double>(), 64.0 / 350.0 / 6e-3, 0.02 * 30.48);
  EXPECT_NEAR(aperture["k_relative_to_thin_lens"].get<double>(), 0.0, 0.02);
  std::ifstream file(report);
  EXPECT_EQ(nlohmann::json::parse(file), j);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(plots) / "coc_vs_n.png"));
  // Text output names the fit.
  const auto text = camlab::testing::run_cli("analyze defocus " + dir.string());
  EXPECT_NE(text.out.find("C x N = k"), std::string::npos);
  std::filesystem::remove_all(dir);
  std::filesystem::remove_all(plots);
  std::filesystem::remove(report);
}

TEST(AnalyzeCli, ExposureAndFocusRunOnTheirCaptures) {
  auto renderer =
      testing::make_renderer(camera_json(), {{"illuminance_lux", 1000},
                                             {"targets",
                                              {{{"type", "texture"},
                                                {"size_m", {0.5, 0.5}},
                                                {"feature_m", 0.0006},
                                                {"pose", {{"position_m", {0.0, 0.0, 0.5}}}}}}}});
  const auto dir = testing::fresh_dir("cli_focus");
  mock::RenderCaptureRequest req;
  req.out_dir = dir;
  req.base = renderer.default_settings();
  req.base.f_number = 2.0;
  req.sweep = mock::Sweep{"focus_position", {100, 110, 120, 130, 140, 150, 160}};
  ASSERT_TRUE(mock::render_capture(renderer, req).ok());
  const auto focus =
      camlab::testing::run_cli("analyze focus " + dir.string() + " --json --region 80");
  ASSERT_EQ(focus.exit_code, 0) << focus.err;
  const auto j = nlohmann::json::parse(focus.out);
  // z_i - f for 0.5 m: 8 * 500 / 492 - 8 mm = 130.08 steps.
  ASSERT_EQ(j["regions"].size(), 4u);
  for (const auto& r : j["regions"]) {
    EXPECT_EQ(r["status"], "ok");
    EXPECT_NEAR(r["best_position"].get<double>(), 130.08, 1.0);
  }
  // The same folder has one exposure: an exposure analysis of it is refused, naming the
  // capture it needs and what this one sweeps (it answered "0.000% over 0 settings", exit 0).
  const auto exposure = camlab::testing::run_cli("analyze exposure " + dir.string() + " --json");
  EXPECT_EQ(exposure.exit_code, 2) << exposure.out;
  const auto refused = nlohmann::json::parse(exposure.out)["error"];
  EXPECT_EQ(refused["code"], "invalid_argument");
  EXPECT_NE(refused["message"].get<std::string>().find("needs a bracket"), std::string::npos);
  EXPECT_NE(refused["message"].get<std::string>().find("focus_position"), std::string::npos);
  std::filesystem::remove_all(dir);
}

// The first click (the review): the README's camera and scene with a plain doubling bracket,
// 1 to 16 ms x 2. The bright side of the edges clips at 16 ms; that setting is left out and
// named, and K comes within 2% of the spec (it read 56% low with a tight error bar), the
// linearity within 0.5% on the settings kept. Without 16 ms nothing clips: a bound on the
// saturation capacity, no capacity.
TEST(AnalyzeCli, TheReadmeBracketLeavesItsClippedSettingOutAndNamesIt) {
  const auto dir = testing::fresh_dir("cli_readme_bracket");
  const std::string render = "render --camera " CAMLAB_SOURCE_DIR
                             "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
                             "/mock_device/examples/scene_slanted_edges.json --repeats 2 --quiet";
  ASSERT_EQ(camlab::testing::run_cli(
                render + " --sweep exposure_us=1000,2000,4000,8000,16000 --out " + dir.string())
                .exit_code,
            0);
  const auto run = camlab::testing::run_cli("analyze exposure " + dir.string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto j = nlohmann::json::parse(run.out);
  const auto& pt = j["photon_transfer"];
  ASSERT_TRUE(pt.contains("system_gain_dn_per_e")) << pt.dump();
  EXPECT_NEAR(pt["system_gain_dn_per_e"].get<double>() / pt["expected_gain_dn_per_e"].get<double>(),
              1.0, 0.02)
      << pt.dump();
  EXPECT_TRUE(pt["saturation_reached"].get<bool>());
  EXPECT_LT(j["linearity"]["max_abs_error_pct"].get<double>(), 0.5);
  bool named = false;
  for (const auto& why : j["left_out"])
    named |= why.get<std::string>().rfind("16000 us", 0) == 0 &&
             why.get<std::string>().find("saturated") != std::string::npos;
  EXPECT_TRUE(named) << j["left_out"].dump();
  std::filesystem::remove_all(dir);

  ASSERT_EQ(camlab::testing::run_cli(render + " --sweep exposure_us=1000,2000,4000,8000 --out " +
                                     dir.string())
                .exit_code,
            0);
  const auto short_run = camlab::testing::run_cli("analyze exposure " + dir.string() + " --json");
  ASSERT_EQ(short_run.exit_code, 0) << short_run.err;
  const auto s = nlohmann::json::parse(short_run.out)["photon_transfer"];
  EXPECT_FALSE(s["saturation_reached"].get<bool>()) << s.dump();
  EXPECT_TRUE(s["saturation_capacity_e"].is_null()) << s.dump();
  EXPECT_TRUE(s["saturation_capacity_lower_bound_e"].is_number()) << s.dump();
  std::filesystem::remove_all(dir);
}

// The diffraction floor only where the frames can show diffraction: the virtual camera
// does not render it, and its aperture series (the README's, f/2 to f/11.3 in stops) had 26
// of 48 rows flagged below_diffraction_floor. A lens spec that says it diffracts (or a real
// camera, with no spec) keeps the floor.
TEST(AnalyzeCli, TheDiffractionFloorOnlyWhereTheFramesCanShowIt) {
  const auto dir = testing::fresh_dir("cli_diffraction");
  ASSERT_EQ(camlab::testing::run_cli(
                "render --camera " CAMLAB_SOURCE_DIR
                "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
                "/mock_device/examples/scene_slanted_edges.json --sweep "
                "f_number=2:11.4:stops --quiet --out " +
                dir.string())
                .exit_code,
            0);
  auto below_floor = [&] {
    const auto run = camlab::testing::run_cli("analyze defocus " + dir.string() + " --json");
    EXPECT_EQ(run.exit_code, 0) << run.err;
    int n = 0;
    const auto report = nlohmann::json::parse(run.out);
    for (const auto& t : report["targets"])
      for (const auto& f : t["frames"]) n += f["status"] == "below_diffraction_floor";
    return n;
  };
  EXPECT_EQ(below_floor(), 0);
  nlohmann::json manifest;
  {
    std::ifstream in(dir / "manifest.json");
    manifest = nlohmann::json::parse(in);
  }
  manifest["source"]["camera_spec"]["lens"]["diffraction"] = true;
  std::ofstream(dir / "manifest.json", std::ios::trunc) << manifest.dump();
  EXPECT_GT(below_floor(), 0);
  std::filesystem::remove_all(dir);
}

// `analyze sfr` on a 16-bit PNG of an edge drawn by sfr_edges.h (Gaussian sigma 0.8 px,
// 5 deg off the columns, no noise): the edge is found, its MTF50 is the closed form's to
// 1%, in lp/mm with the pitch, and it is sagittal (it runs along the radius from the
// centre) or, measured about the centre, axial; an image without edges is refused with the
// reason.
TEST(AnalyzeCli, SfrOfAnEdgeDrawnHereIsItsClosedForm) {
  using namespace sfr_edges;
  const auto dir = testing::fresh_dir("cli_sfr");
  std::filesystem::create_directories(dir);
  const Optics optics{false, 0.8};
  cv::Mat edge = draw_edge(optics, 5.0, false, 1, 0), edge16;
  edge.convertTo(edge16, CV_16U);
  ASSERT_TRUE(cv::imwrite((dir / "edge.png").string(), edge16));
  const auto run = camlab::testing::run_cli("analyze sfr " + (dir / "edge.png").string() +
                                            " --pixel-um 2 --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  const double truth = true_mtf50(optics, 5.0);
  int measured = 0;
  for (const auto& e : report["edges"]) {
    if (e["status"] != "ok") continue;
    ++measured;
    EXPECT_NEAR(e["slant_deg"].get<double>(), 5.0, 0.1);
    EXPECT_NEAR(e["mtf50_cy_px"].get<double>(), truth, 0.01 * truth) << e.dump();
    EXPECT_NEAR(e["mtf50_lp_mm"].get<double>(), 500 * e["mtf50_cy_px"].get<double>(), 1e-9);
    // The edge runs through the image's centre: along the radius wherever it is measured,
    // axial where the part measured is centred within 5% of the half diagonal of it (the
    // whole edge, grown along its line, is).
    const double off_centre = std::hypot(e["centre_px"][0].get<double>() - 0.5 * (kSize - 1),
                                         e["centre_px"][1].get<double>() - 0.5 * (kSize - 1));
    EXPECT_EQ(e["field"], off_centre < 0.05 * kSize / std::sqrt(2.0) ? "axial" : "sagittal")
        << off_centre;
  }
  // The finder may hand over the edge in two collinear pieces; each is measured.
  EXPECT_GE(measured, 1) << run.out;
  // The text's summary line is the summary's own words (written twice: sfr/ cannot
  // include analysis_summary.h).
  const auto text = camlab::testing::run_cli("analyze sfr " + (dir / "edge.png").string());
  EXPECT_NE(text.out.find(analysis::summary_text(report["summary"])), std::string::npos)
      << text.out << "\n"
      << report["summary"].dump();

  // The same edge as a camera or an editor writes an 8-bit file: sRGB-encoded. Read as
  // such (the default for 8 bits) it is the closed form again (0.3% when written); read as
  // linear, its ESF is bent and MTF50 comes out 1.6% low at this 5:1 contrast (more at
  // higher contrast), which is why the default is not linear.
  cv::Mat encoded(edge.size(), CV_8U);
  for (int y = 0; y < edge.rows; ++y)
    for (int x = 0; x < edge.cols; ++x) {
      const double v = edge.at<float>(y, x) / 1000.0;  // the drawn light level is 1000
      const double code = v <= 0.0031308 ? 12.92 * v : 1.055 * std::pow(v, 1 / 2.4) - 0.055;
      encoded.at<uint8_t>(y, x) = cv::saturate_cast<uint8_t>(std::lround(255 * code));
    }
  ASSERT_TRUE(cv::imwrite((dir / "edge_srgb.png").string(), encoded));
  for (const char* transfer : {"auto", "linear"}) {
    const auto srgb = camlab::testing::run_cli("analyze sfr " + (dir / "edge_srgb.png").string() +
                                               " --json --transfer " + transfer);
    ASSERT_EQ(srgb.exit_code, 0) << srgb.err;
    const auto r = nlohmann::json::parse(srgb.out);
    EXPECT_EQ(r["transfer"]["encoding"], std::string(transfer) == "auto" ? "srgb" : "linear");
    int read = 0;
    for (const auto& e : r["edges"]) {
      if (e["status"] != "ok") continue;
      ++read;
      const double error = e["mtf50_cy_px"].get<double>() / truth - 1;
      std::printf("8-bit sRGB file read as %s: MTF50 %+.2f%%\n", transfer, 100 * error);
      if (std::string(transfer) == "auto")
        EXPECT_NEAR(error, 0, 0.01) << e.dump();
      else
        EXPECT_LT(error, -0.01) << e.dump();
    }
    EXPECT_GE(read, 1) << srgb.out;
  }

  cv::imwrite((dir / "flat.png").string(), cv::Mat(120, 120, CV_8U, cv::Scalar(90)));
  const auto flat = camlab::testing::run_cli("analyze sfr " + (dir / "flat.png").string());
  EXPECT_EQ(flat.exit_code, 2);
  EXPECT_NE(flat.err.find("no straight edge"), std::string::npos) << flat.err;
  std::filesystem::remove_all(dir);
}

// `analyze sfr` on a capture folder: the README's aperture series (f/2 to f/11.3 in full
// stops) of slanted edges at 0.4-2 m, focused at one of them. Each edge keeps its place in
// every frame; the defocused edges sharpen as the aperture closes (their blur ~ 1/N), and
// the pixel pitch comes from the capture's camera spec.
TEST(AnalyzeCli, SfrOfAnApertureSeriesRisesWithTheFNumber) {
  const auto dir = testing::fresh_dir("cli_sfr_series");
  const auto render = camlab::testing::run_cli(
      "render --camera " CAMLAB_SOURCE_DIR
      "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
      "/mock_device/examples/scene_slanted_edges.json --sweep f_number=2:11.4:stops --quiet "
      "--out " +
      dir.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const auto run = camlab::testing::run_cli("analyze sfr " + dir.string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  const auto& frames = report["frames"];
  ASSERT_EQ(frames.size(), 6u);
  EXPECT_GT(report["pixel_pitch_um"].get<double>(), 0);
  int compared = 0, sharpened = 0;
  for (size_t e = 0; e < frames[0]["edges"].size(); ++e) {
    const auto& open = frames[0]["edges"][e];
    const auto& closed = frames[5]["edges"][e];
    ASSERT_EQ(open["name"], closed["name"]);
    if (open["status"] != "ok" || closed["status"] != "ok") continue;
    ++compared;
    const double at_f2 = open["mtf50_cy_px"], at_f11 = closed["mtf50_cy_px"];
    EXPECT_GT(at_f11, at_f2 - 0.03) << open["name"];
    sharpened += at_f11 > 1.5 * at_f2 ? 1 : 0;
    EXPECT_TRUE(open.contains("mtf50_lp_mm"));
  }
  EXPECT_GE(compared, 4) << run.out.substr(0, 2000);
  EXPECT_GE(sharpened, 2);
  std::filesystem::remove_all(dir);
}

// The virtual camera's slanted star (mock_device/examples/scene_slanted_star.json: two
// squares turned 5 and 50 deg, 16 sides at four orientations, ISO 12233:2023's extra
// orientations among them) out of focus at f/1.4: each side's MTF50 against the closed-form
// truth of the thin lens's blur disk (its diameter from the frame's truth) times the pixel's
// area along the side's normal, sinc(f cos a) sinc(f sin a). Within 1.1% on every side when
// written; 14 of 16 measured (the finder's two stray lines are no_edge).
TEST(AnalyzeCli, SfrOfEverySideOfASlantedStarIsTheBlurDisksTruth) {
  const auto dir = testing::fresh_dir("cli_sfr_star");
  const auto render = camlab::testing::run_cli(
      "render --camera " CAMLAB_SOURCE_DIR
      "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
      "/mock_device/examples/scene_slanted_star.json --set f_number=1.4 --set focus_position=88 "
      "--set exposure_us=1000 --quiet --out " +
      dir.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  std::ifstream sidecar(dir / "frame_000000.json");
  const auto truth = nlohmann::json::parse(sidecar)["truth"];
  const double disk_px = truth["targets"][0]["coc_px"]["at_origin"].get<double>();
  ASSERT_GT(disk_px, 3);
  const auto run = camlab::testing::run_cli("analyze sfr " + dir.string() + " --json");
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  int near_axis = 0, near_diagonal = 0;
  for (const auto& e : report["frames"][0]["edges"]) {
    if (e["status"] != "ok") continue;
    const double slant = e["slant_deg"].get<double>() * std::numbers::pi / 180;
    auto system = [&](double f) {
      const double x = std::numbers::pi * disk_px * f;
      auto box = [](double u) {
        return std::fabs(u) < 1e-12 ? 1.0 : std::sin(std::numbers::pi * u) / (std::numbers::pi * u);
      };
      return 2 * std::cyl_bessel_j(1.0, x) / x * box(f * std::cos(slant)) *
             box(f * std::sin(slant));
    };
    double lo = 1e-6, hi = 0.5;
    for (int k = 0; k < 60; ++k) (system(0.5 * (lo + hi)) > 0.5 ? lo : hi) = 0.5 * (lo + hi);
    EXPECT_NEAR(e["mtf50_cy_px"].get<double>() / lo, 1, 0.03)
        << e["name"] << ", slant " << e["slant_deg"] << " deg";
    (e["slant_deg"].get<double>() < 20 ? near_axis : near_diagonal) += 1;
  }
  EXPECT_GE(near_axis, 5);
  EXPECT_GE(near_diagonal, 5);
  std::filesystem::remove_all(dir);
}

// `camlab analyze lensmap` on the virtual camera's thin lens: a focus sweep of the lens-map
// chart (squares on one plane 1 m away, across the field) at f/1.4. A thin lens focuses a
// plane square to the axis on a plane: best focus everywhere at the position that puts the
// lens v = f d / (d - f) from the sensor, no tilt, no curvature, no astigmatism.
TEST(AnalyzeCli, LensmapOfTheThinLensIsAFlatSurfaceAtItsFocusForTheChart) {
  const auto dir = testing::fresh_dir("cli_lensmap");
  const auto render = camlab::testing::run_cli(
      "render --camera " CAMLAB_SOURCE_DIR
      "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
      "/mock_device/examples/scene_lensmap_chart.json --set f_number=1.4 --set exposure_us=1000 "
      "--sweep focus_position=25:105:5 --quiet --out " +
      dir.string());
  ASSERT_EQ(render.exit_code, 0) << render.err;
  const auto plots = dir.parent_path() / "cli_lensmap_plots";
  std::filesystem::remove_all(plots);
  const auto run = camlab::testing::run_cli("analyze lensmap " + dir.string() + " --json --plots " +
                                            plots.string());
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const auto report = nlohmann::json::parse(run.out);
  ASSERT_EQ(report["surfaces"].size(), 1u);
  // The plots: the surface over the imager, MTF50 across the field and the through-focus
  // curves, each a PNG the report lists; every edge's curve is in the report too.
  ASSERT_EQ(report["plots"].size(), 3u) << report["plots"].dump();
  for (const char* name : {"lensmap_surface_f1_4.png", "lensmap_field_mtf50_f1_4.png",
                           "lensmap_through_focus_f1_4.png"}) {
    const cv::Mat png = cv::imread((plots / name).string());
    EXPECT_FALSE(png.empty()) << name;
    EXPECT_GE(png.cols, 400) << name;
  }
  // MTF50 across the field: a point per edge measured (the thin lens is in focus over the
  // whole flat chart at its axis' best focus, so every edge is sharp there).
  std::ifstream field_json(plots / "lensmap_field_mtf50_f1_4.json");
  const auto field = nlohmann::json::parse(field_json);
  size_t points = 0;
  for (const auto& series : field["series"])
    for (const auto& mtf50 : series["y"]) {
      ++points;
      EXPECT_GT(mtf50.get<double>(), 0.3) << series["label"];
    }
  EXPECT_GE(points, 30u);
  std::filesystem::remove_all(plots);
  for (const auto& edge : report["surfaces"][0]["edges"]) {
    if (edge["status"] != "ok") continue;
    EXPECT_GE(edge["through_focus_mtf50"].size(), 5u) << edge.dump();
    EXPECT_LE(edge["through_focus_mtf50"].size(), 17u) << edge.dump();
  }
  const auto& s = report["surfaces"][0];
  // The camera spec's 8 mm lens, 0.001 mm a focus step; the chart at 1000 mm.
  const double f_mm = 8, d_mm = 1000, step_mm = 0.001;
  const double truth_position = (f_mm * d_mm / (d_mm - f_mm) - f_mm) / step_mm;  // 64.52
  std::printf(
      "best focus on the axis %.3f (thin lens %.3f), tilt %.3f %.3f, curvature %.3f, "
      "astigmatism %.3f, %d edges\n",
      s["centre_focus"].get<double>(), truth_position, s["tilt_x_per_half_diagonal"].get<double>(),
      s["tilt_y_per_half_diagonal"].get<double>(), s["curvature_at_corner"].get<double>(),
      s["astigmatism_at_corner"].get<double>(), s["edges_used"].get<int>());
  EXPECT_GE(s["edges_used"].get<int>(), 20);
  EXPECT_NEAR(s["centre_focus"].get<double>(), truth_position, 0.3);
  EXPECT_NEAR(s["tilt_x_per_half_diagonal"].get<double>(), 0, 0.3);
  EXPECT_NEAR(s["tilt_y_per_half_diagonal"].get<double>(), 0, 0.3);
  EXPECT_NEAR(s["curvature_at_corner"].get<double>(), 0, 0.3);
  EXPECT_NEAR(s["astigmatism_at_corner"].get<double>(), 0, 0.3);
  ASSERT_TRUE(s.contains("at_sensor"));  // the capture's camera spec gives step and pitch
  EXPECT_NEAR(s["at_sensor"]["curvature_um"].get<double>(), 0, 0.3);
  std::filesystem::remove_all(dir);

  // One frame is no focus sweep: refused before any work, saying what is needed.
  const auto single = camlab::testing::run_cli(
      "render --camera " CAMLAB_SOURCE_DIR
      "/mock_device/examples/camera_640x480.json --scene " CAMLAB_SOURCE_DIR
      "/mock_device/examples/scene_lensmap_chart.json --quiet --out " +
      dir.string());
  ASSERT_EQ(single.exit_code, 0) << single.err;
  const auto refused = camlab::testing::run_cli("analyze lensmap " + dir.string());
  EXPECT_EQ(refused.exit_code, 2);
  EXPECT_NE(refused.err.find("needs a focus sweep"), std::string::npos) << refused.err;
  std::filesystem::remove_all(dir);
}

// Per colour channel on the RGGB example camera (raw mosaic frames), each channel on its
// own sites: without longitudinal colour the three agree on every defocused edge (the
// blur is one disk); with the example's chromatic focus shift (R +0.02 mm, B -0.015 mm)
// they part.
TEST(AnalyzeCli, SfrPerChannelAgreesWithoutChromaticShiftAndPartsWithIt) {
  for (bool shifted : {false, true}) {
    const auto dir = testing::fresh_dir(shifted ? "cli_sfr_colour_shift" : "cli_sfr_colour");
    std::filesystem::create_directories(dir);
    std::ifstream in(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_colour_640x480.json");
    nlohmann::json camera = nlohmann::json::parse(in);
    if (!shifted) camera["lens"]["chromatic_focus_shift_mm"] = {0.0, 0.0, 0.0};
    std::ofstream(dir / "camera.json") << camera.dump();
    const auto render =
        camlab::testing::run_cli("render --camera " + (dir / "camera.json").string() +
                                 " --scene " CAMLAB_SOURCE_DIR
                                 "/mock_device/examples/scene_slanted_edges.json --set "
                                 "f_number=2 --quiet --out " +
                                 (dir / "frames").string());
    ASSERT_EQ(render.exit_code, 0) << render.err;
    const auto run =
        camlab::testing::run_cli("analyze sfr " + (dir / "frames").string() + " --json");
    ASSERT_EQ(run.exit_code, 0) << run.err;
    const auto report = nlohmann::json::parse(run.out);
    int compared = 0, parted = 0;
    for (const auto& e : report["frames"][0]["edges"]) {
      if (e["status"] != "ok" || !e.contains("channels")) continue;
      const auto& c = e["channels"];
      if (c["R"]["status"] != "ok" || c["G"]["status"] != "ok" || c["B"]["status"] != "ok")
        continue;
      const double r = c["R"]["mtf50_cy_px"], g = c["G"]["mtf50_cy_px"], b = c["B"]["mtf50_cy_px"];
      if (g > 0.3) continue;  // near the pixel's own limit the curve is flat and noise decides
      ++compared;
      if (!shifted) {
        EXPECT_NEAR(r / g, 1.0, 0.05) << e.dump().substr(0, 400);
        EXPECT_NEAR(b / g, 1.0, 0.05) << e.dump().substr(0, 400);
        // Each channel's stated standard error accounts for its difference from G: one
        // blur, so only the noise on each channel's own sites parts them.
        const double se_r = c["R"]["mtf50_standard_error_cy_px"],
                     se_g = c["G"]["mtf50_standard_error_cy_px"],
                     se_b = c["B"]["mtf50_standard_error_cy_px"];
        std::printf("R %.4f +- %.4f, G %.4f +- %.4f, B %.4f +- %.4f cycles/px\n", r, se_r, g, se_g,
                    b, se_b);
        EXPECT_GT(se_g, 0);
        EXPECT_LT(std::fabs(r - g), 4 * std::hypot(se_r, se_g));
        EXPECT_LT(std::fabs(b - g), 4 * std::hypot(se_b, se_g));
      }
      parted += std::fabs(r / g - 1) > 0.15 || std::fabs(b / g - 1) > 0.15 ? 1 : 0;
    }
    EXPECT_GE(compared, 2) << run.out.substr(0, 1500);
    if (shifted)
      EXPECT_GE(parted, 1);
    else
      EXPECT_EQ(parted, 0);
    std::filesystem::remove_all(dir);
  }
}

TEST(AnalyzeCli, ErrorsGoToStderrWithStatus2) {
  const auto missing = camlab::testing::run_cli("analyze defocus /nonexistent/capture");
  EXPECT_NE(missing.exit_code, 0);
  const auto dir = testing::fresh_dir("cli_empty");
  std::filesystem::create_directories(dir);
  const auto empty = camlab::testing::run_cli("analyze focus " + dir.string());
  EXPECT_EQ(empty.exit_code, 2);
  EXPECT_EQ(empty.err.rfind("camlab analyze: ", 0), 0u) << empty.err;
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace camlab::analysis
