// The lens map (src/analysis/lensmap/lens_map.h) against a focus sweep drawn by a
// generator that shares nothing with the SFR, the edge finder or the renderer: dark squares
// across the field whose sides run along and across the radius, each side blurred by a
// Gaussian whose width follows a known best-focus surface (tilted, curved, and with the
// sagittal and meridional surfaces apart), evaluated in closed form (a Gaussian-blurred
// square is a product of two error-function steps in the square's own axes) at 2 x 2
// points a pixel, with noise.
#include <array>
#include <cmath>
#include <filesystem>
#include <numbers>
#include <random>
#include <vector>

#include <gtest/gtest.h>

#include "analysis/lensmap/lens_map.h"
#include "analysis/lensmap/stop_exposure.h"
#include "fresh_dir.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {
namespace lens_map_test {

constexpr int kWidth = 1200, kHeight = 960;
constexpr double kHalfSide = 50;  // px, of each square

// The truth: best focus (in focus steps) for the blur across meridional edges (sides at a
// right angle to the radius) and across sagittal ones (sides along the radius).
struct Surface {
  double centre = 7, tilt_x = 0.6, tilt_y = -0.4;
  double curvature_meridional = 1.5, curvature_sagittal = 2.1;
  double sigma0_px = 1.0;    // the lens's blur in focus
  double px_per_step = 0.8;  // defocus blur growth
  double at(double u, double v, bool sagittal) const {
    const double c = sagittal ? curvature_sagittal : curvature_meridional;
    return centre + tilt_x * u + tilt_y * v + c * (u * u + v * v);
  }
  double sigma_px(double step, double best) const {
    const double d = px_per_step * (step - best);
    return std::sqrt(sigma0_px * sigma0_px + d * d);
  }
};

double phi(double x) { return 0.5 * std::erfc(-x / std::numbers::sqrt2); }

cv::Mat draw_frame(const Surface& truth, double step, unsigned seed) {
  const double cx = 0.5 * (kWidth - 1), cy = 0.5 * (kHeight - 1);
  const double half_diagonal = 0.5 * std::hypot(kWidth, kHeight);
  const double light = 3000, dark = 600;
  cv::Mat image(kHeight, kWidth, CV_64F, cv::Scalar(light));
  // A 4 x 4 grid, no square on an axis through the centre (its sides would be near the
  // pixel axes, which the SFR flags).
  for (double ox : {-450.0, -150.0, 150.0, 450.0})
    for (double oy : {-390.0, -130.0, 130.0, 390.0}) {
      const double sx = cx + ox, sy = cy + oy;
      const double r = std::hypot(ox, oy);
      const double rx = ox / r, ry = oy / r;  // radial unit vector; tangential (-ry, rx)
      const int reach = static_cast<int>(kHalfSide * std::numbers::sqrt2 + 40);
      for (int y = std::max(0, static_cast<int>(sy) - reach);
           y <= std::min(kHeight - 1, static_cast<int>(sy) + reach); ++y)
        for (int x = std::max(0, static_cast<int>(sx) - reach);
             x <= std::min(kWidth - 1, static_cast<int>(sx) + reach); ++x) {
          const double u = (x - cx) / half_diagonal, v = (y - cy) / half_diagonal;
          // Across a meridional side the blur is along the radius; across a sagittal one,
          // along the tangent.
          const double sigma_r = truth.sigma_px(step, truth.at(u, v, false));
          const double sigma_t = truth.sigma_px(step, truth.at(u, v, true));
          double cover = 0;
          for (double dy : {-0.25, 0.25})
            for (double dx : {-0.25, 0.25}) {
              const double px = x + dx - sx, py = y + dy - sy;
              const double a = px * rx + py * ry, b = -px * ry + py * rx;
              cover += (phi((kHalfSide - a) / sigma_r) - phi((-kHalfSide - a) / sigma_r)) *
                       (phi((kHalfSide - b) / sigma_t) - phi((-kHalfSide - b) / sigma_t));
            }
          image.at<double>(y, x) -= (light - dark) * cover / 4;
        }
    }
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, (light - dark) / 200);  // contrast-to-noise 200
  cv::Mat out(kHeight, kWidth, CV_16U);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      out.at<uint16_t>(y, x) = cv::saturate_cast<uint16_t>(image.at<double>(y, x) + noise(rng));
  return out;
}

// A focus sweep 0..14 at one f-number into a capture folder; `source` describes the camera.
std::filesystem::path write_sweep(const Surface& truth, const std::string& name,
                                  const nlohmann::json& source) {
  const auto dir = testing::fresh_dir(name);
  auto writer =
      image::CaptureFolderWriter::create(dir, "focus_stack", source, nlohmann::json::object());
  EXPECT_TRUE(writer.ok());
  for (int step = 0; step <= 14; ++step) {
    image::FrameSidecar side;
    side.sequence = static_cast<uint64_t>(step);
    side.clock = "virtual";
    side.pixel_format = "Y16";
    side.bit_depth = 12;
    side.settings = {{"focus_position", step}, {"f_number", 2.8}};
    side.labels = {{"sweep_index", step}};
    EXPECT_TRUE(
        writer->add_frame(draw_frame(truth, step, 17u + static_cast<unsigned>(step)), side).ok());
  }
  EXPECT_TRUE(writer->finish().ok());
  return dir;
}

TEST(LensMap, BestFocusSurfaceIsTheTruthsTiltCurvatureAndAstigmatism) {
  const Surface truth;
  const auto dir = write_sweep(truth, "lensmap", {{"backend", "unknown"}});
  auto map = analyze_lens_map(dir, LensMapOptions{});
  ASSERT_TRUE(map.ok()) << map.error().message;
  std::printf("%s", map->text.c_str());
  const auto& surfaces = map->report["surfaces"];
  ASSERT_EQ(surfaces.size(), 1u);
  const auto& s = surfaces[0];
  EXPECT_EQ(s["f_number"].get<double>(), 2.8);
  // 16 squares, 4 sides each: nearly every side measured (a side the finder cut short or
  // placed by a corner can be flagged or left off the surface).
  EXPECT_GE(s["edges_used"].get<int>(), 54) << s.dump();
  // Each edge's best focus against the truth at its centre, for its class.
  const double cx = 0.5 * (kWidth - 1), cy = 0.5 * (kHeight - 1);
  const double half_diagonal = 0.5 * std::hypot(kWidth, kHeight);
  double worst = 0;
  for (const auto& e : s["edges"]) {
    if (e["status"] != "ok") continue;
    const std::string field = e["field"];
    if (field != "sagittal" && field != "meridional") continue;
    const double u = (e["centre_px"][0].get<double>() - cx) / half_diagonal;
    const double v = (e["centre_px"][1].get<double>() - cy) / half_diagonal;
    worst = std::max(
        worst, std::fabs(e["best_focus"].get<double>() - truth.at(u, v, field == "sagittal")));
  }
  std::printf(
      "worst edge best focus error %.4f steps; curvature sagittal %.4f (truth %.1f), "
      "meridional %.4f (truth %.1f)\n",
      worst, s["curvature_sagittal_at_corner"].get<double>(), truth.curvature_sagittal,
      s["curvature_meridional_at_corner"].get<double>(), truth.curvature_meridional);
  EXPECT_LT(worst, 0.1);
  EXPECT_NEAR(s["tilt_x_per_half_diagonal"].get<double>(), truth.tilt_x, 0.02);
  EXPECT_NEAR(s["tilt_y_per_half_diagonal"].get<double>(), truth.tilt_y, 0.02);
  // Field curvature within 5%, the astigmatic difference within 0.05 focus step.
  EXPECT_NEAR(s["curvature_sagittal_at_corner"].get<double>(), truth.curvature_sagittal,
              0.05 * truth.curvature_sagittal);
  EXPECT_NEAR(s["curvature_meridional_at_corner"].get<double>(), truth.curvature_meridional,
              0.05 * truth.curvature_meridional);
  EXPECT_NEAR(s["astigmatism_at_corner"].get<double>(),
              truth.curvature_sagittal - truth.curvature_meridional, 0.05);
  EXPECT_FALSE(s.contains("at_sensor"));  // no lens extension or pixel pitch known
  std::filesystem::remove_all(dir);
}

// With the camera's focus step and pixel pitch, the surface is also at the sensor: the
// tilt in degrees is the focus difference across the field over the field's size.
TEST(LensMap, TheCamerasFocusStepAndPixelPitchGiveMicrometresAndDegrees) {
  Surface truth;
  truth.curvature_sagittal = truth.curvature_meridional = 1.8;
  const nlohmann::json source = {{"backend", "virtual"},
                                 {"camera_spec",
                                  {{"sensor", {{"pixel_pitch_um", 3.0}}},
                                   {"lens", {{"focus", {{"extension_mm_per_step", 0.01}}}}}}}};
  const auto dir = write_sweep(truth, "lensmap_units", source);
  auto map = analyze_lens_map(dir, LensMapOptions{});
  ASSERT_TRUE(map.ok()) << map.error().message;
  const auto& s = map->report["surfaces"][0];
  std::printf("%s", map->text.c_str());
  std::printf("curvature sagittal %.4f meridional %.4f (truth 1.8 both)\n",
              s["curvature_sagittal_at_corner"].get<double>(),
              s["curvature_meridional_at_corner"].get<double>());
  ASSERT_TRUE(s.contains("at_sensor")) << s.dump();
  const double half_diagonal_mm = 0.5 * std::hypot(kWidth, kHeight) * 3e-3;
  const double deg = 180 / std::numbers::pi;
  EXPECT_NEAR(s["at_sensor"]["curvature_um"].get<double>(), 1.8 * 0.01 * 1e3, 0.05 * 18);
  EXPECT_NEAR(s["at_sensor"]["tilt_x_deg"].get<double>(),
              std::atan(truth.tilt_x * 0.01 / half_diagonal_mm) * deg, 0.01);
  EXPECT_NEAR(s["at_sensor"]["tilt_y_deg"].get<double>(),
              std::atan(truth.tilt_y * 0.01 / half_diagonal_mm) * deg, 0.01);
  // One curvature for both classes: no astigmatism.
  EXPECT_NEAR(s["astigmatism_at_corner"].get<double>(), 0, 0.05);
  std::filesystem::remove_all(dir);
}

// What cannot give a surface says why: too few focus positions; a sweep whose every peak
// is at its end is no measurement of best focus.
TEST(LensMap, TooFewFocusPositionsOrPeaksAtTheSweepsEndAreRefusedWithTheReason) {
  using nlohmann::json;
  auto edge = [](int k, double mtf50) {
    json e;
    e["name"] = "e" + std::to_string(k);
    e["status"] = "ok";
    e["mtf50_cy_px"] = mtf50;
    e["centre_px"] = {100 + 150 * k, 100 + 100 * k};
    e["field"] = "sagittal";
    return e;
  };
  json report;
  report["size_px"] = {kWidth, kHeight};
  report["frames"] = json::array();
  for (int step = 0; step < 4; ++step) {
    json frame;
    frame["settings"]["focus_position"] = step;
    frame["edges"] = json::array({edge(0, 0.1 + 0.01 * step)});
    report["frames"].push_back(frame);
  }
  auto few = focus_surfaces(report);
  ASSERT_FALSE(few.ok());
  EXPECT_EQ(few.error().code, ErrorCode::kTooFewSamples);
  EXPECT_NE(few.error().message.find("4 focus position"), std::string::npos) << few.error().message;
  // Eight positions, MTF50 rising through all of them: every edge's peak at the end.
  report["frames"] = json::array();
  for (int step = 0; step < 8; ++step) {
    json frame;
    frame["settings"]["focus_position"] = step;
    frame["edges"] = json::array();
    for (int k = 0; k < 6; ++k) frame["edges"].push_back(edge(k, 0.1 + 0.01 * step));
    report["frames"].push_back(frame);
  }
  auto ends = focus_surfaces(report);
  ASSERT_FALSE(ends.ok());
  EXPECT_EQ(ends.error().code, ErrorCode::kTooFewSamples);
  EXPECT_NE(ends.error().message.find("0 edge(s) have a best focus"), std::string::npos)
      << ends.error().message;
}

// A lens breathes: its image scale follows the lens-to-sensor distance, so an edge moves
// along the radius through the sweep. Its best focus belongs to where it is at that focus,
// not to where its first frame found it. An SFR report drawn here: edges on a 5 x 4 grid
// whose centres scale by 1 + 0.002 per step about the image centre (2.8% over the sweep;
// an 8 mm lens moved 0.1 mm breathes 1.2%), best focus on the surface at each edge's
// place at that focus, MTF50 exactly 1 / sqrt(a + b (p - p*)^2).
TEST(LensMap, AnEdgeIsPlacedWhereItIsAtItsBestFocus) {
  using nlohmann::json;
  const double cx = 0.5 * (kWidth - 1), cy = 0.5 * (kHeight - 1);
  const double half_diagonal = 0.5 * std::hypot(kWidth, kHeight);
  const double centre = 7, tilt_x = 0.6, tilt_y = -0.4, curvature = 1.8;
  auto scale = [](double p) { return 1 + 0.002 * (p - 7); };
  struct Edge {
    double x0, y0, best;  // place at scale 1; best focus
  };
  std::vector<Edge> edges;
  for (double ox : {-500.0, -250.0, 0.0, 250.0, 500.0})
    for (double oy : {-400.0, -130.0, 130.0, 400.0}) {
      Edge e{ox, oy, centre};
      for (int i = 0; i < 50; ++i) {  // p* = surface(place at p*): a contraction
        const double u = e.x0 * scale(e.best) / half_diagonal;
        const double v = e.y0 * scale(e.best) / half_diagonal;
        e.best = centre + tilt_x * u + tilt_y * v + curvature * (u * u + v * v);
      }
      edges.push_back(e);
    }
  json report;
  report["size_px"] = {kWidth, kHeight};
  report["frames"] = json::array();
  for (int step = 0; step <= 14; ++step) {
    json frame;
    frame["settings"] = {{"focus_position", step}, {"f_number", 2.8}};
    frame["edges"] = json::array();
    for (size_t k = 0; k < edges.size(); ++k) {
      const Edge& e = edges[k];
      const double d = step - e.best;
      frame["edges"].push_back({{"name", "e" + std::to_string(k)},
                                {"status", "ok"},
                                {"mtf50_cy_px", 1 / std::sqrt(11.0 + 10.0 * d * d)},
                                {"centre_px", {cx + e.x0 * scale(step), cy + e.y0 * scale(step)}},
                                {"field", "oblique"}});
    }
    // A segment the finder took that no frame shows as an edge, and an edge measured on
    // two frames only: both left out, each with its own reason.
    frame["edges"].push_back({{"name", "ghost"},
                              {"status", "no_edge"},
                              {"centre_px", {cx + 30, cy + 20}},
                              {"field", "oblique"}});
    if (step < 2)
      frame["edges"].push_back({{"name", "brief"},
                                {"status", "ok"},
                                {"mtf50_cy_px", 0.2},
                                {"centre_px", {cx - 30, cy + 20}},
                                {"field", "oblique"}});
    report["frames"].push_back(frame);
  }
  auto surfaces = focus_surfaces(report);
  ASSERT_TRUE(surfaces.ok()) << surfaces.error().message;
  ASSERT_EQ(surfaces->size(), 1u);
  const FocusSurface& s = surfaces->front();
  EXPECT_EQ(s.edges_used, 20);
  for (const EdgeBestFocus& placed : s.edges) {
    if (placed.name == "ghost" || placed.name == "brief") {
      EXPECT_EQ(placed.status,
                placed.name == "ghost" ? kBestFocusNotMeasured : kBestFocusTooFewPoints);
      continue;
    }
    const Edge& e = edges[static_cast<size_t>(std::stoi(placed.name.substr(1)))];
    EXPECT_NEAR(placed.best_focus, e.best, 1e-9) << placed.name;
    EXPECT_NEAR(placed.centre_x_px, cx + e.x0 * scale(e.best), 1e-6) << placed.name;
    EXPECT_NEAR(placed.centre_y_px, cy + e.y0 * scale(e.best), 1e-6) << placed.name;
  }
  // Placed at their first frame's centres (1.4% nearer the axis) the curvature read 3.5%
  // steep (1.862) and the tilt 2% high.
  EXPECT_NEAR(s.curvature, curvature, 1e-6);
  EXPECT_NEAR(s.tilt_x, tilt_x, 1e-6);
  EXPECT_NEAR(s.tilt_y, tilt_y, 1e-6);
  EXPECT_NEAR(s.centre_focus, centre, 1e-6);
}

// A real lens's defocus blur is a disk, not a Gaussian: through focus 1 / MTF50^2 is then
// no parabola (flatter at the peak, steeper on the flanks), though still alike on both
// sides of the best focus. Drawn here in closed form, independently of the lens map: a
// Gaussian lens blur times a disk growing linearly with the distance from best focus,
// MTF(f) = exp(-2 pi^2 sigma^2 f^2) 2 J1(pi D f) / (pi D f), MTF50 by bisection; 40 edges
// whose best foci fall evenly between the sweep's integer steps, so that the points about
// each peak stand differently. A sharp lens whose defocus grows fast (few points about the
// peak) and a soft one whose defocus grows slowly (the curve's flat top over many).
TEST(LensMap, ADiskDefocusBlursBestFocusIsFoundBetweenTheSweepsSteps) {
  using nlohmann::json;
  const double cx = 0.5 * (kWidth - 1), cy = 0.5 * (kHeight - 1);
  std::vector<double> best;
  for (int k = 0; k < 40; ++k) best.push_back(6 + k / 40.0 * 2);  // 6.0 ... 7.95
  for (const auto& [sigma_px, disk_px_per_step] :
       {std::pair{0.6, 1.2}, std::pair{0.4, 4.0}, std::pair{1.5, 1.0}}) {
    auto mtf = [&](double f, double diameter_px) {
      const double x = std::numbers::pi * diameter_px * f;
      const double disk = x < 1e-9 ? 1.0 : 2 * std::cyl_bessel_j(1.0, x) / x;
      return std::exp(-2 * std::numbers::pi * std::numbers::pi * sigma_px * sigma_px * f * f) *
             disk;
    };
    auto mtf50 = [&](double diameter_px) {
      // MTF falls through 0.5 before the disk's first zero, 1.22 / D.
      double lo = 0, hi = diameter_px > 0 ? std::min(1.0, 1.2 / diameter_px) : 1.0;
      for (int i = 0; i < 60; ++i)
        (mtf(0.5 * (lo + hi), diameter_px) > 0.5 ? lo : hi) = 0.5 * (lo + hi);
      return 0.5 * (lo + hi);
    };
    json report;
    report["size_px"] = {kWidth, kHeight};
    report["frames"] = json::array();
    for (int step = 0; step <= 14; ++step) {
      json frame;
      frame["settings"] = {{"focus_position", step}, {"f_number", 2.8}};
      frame["edges"] = json::array();
      for (size_t k = 0; k < best.size(); ++k)
        frame["edges"].push_back(
            {{"name", "e" + std::to_string(k)},
             {"status", "ok"},
             {"mtf50_cy_px", mtf50(disk_px_per_step * std::fabs(step - best[k]))},
             {"centre_px", {cx + 500 * std::cos(0.4 * k), cy + 400 * std::sin(0.4 * k)}},
             {"field", "oblique"}});
      report["frames"].push_back(frame);
    }
    auto surfaces = focus_surfaces(report);
    ASSERT_TRUE(surfaces.ok()) << surfaces.error().message;
    double worst = 0;
    int measured = 0;
    for (const EdgeBestFocus& e : surfaces->front().edges) {
      if (e.status != kBestFocusOk && e.status != kBestFocusOffSurface) continue;
      const double truth = best[static_cast<size_t>(std::stoi(e.name.substr(1)))];
      worst = std::max(worst, std::fabs(e.best_focus - truth)), ++measured;
    }
    std::printf("disk defocus (lens blur %.1f px, disk %.1f px a step): worst error %.4f steps\n",
                sigma_px, disk_px_per_step, worst);
    EXPECT_EQ(measured, 40);
    EXPECT_LT(worst, 0.02);
  }
}

// The stops' exposure H ~ T x gain / N^2 against the best-exposed one's: one time for
// f/1.4 and f/5.6 is 4 stops apart and said; the time grown as N^2, or the gain raised in
// its place, is the same exposure and says nothing.
TEST(LensMap, StopsExposedUnequallyAreSaid) {
  auto report = [](std::vector<std::array<double, 3>> frames) {  // f-number, time, gain
    nlohmann::json out = {{"frames", nlohmann::json::array()}};
    for (const auto& [n, t, gain] : frames)
      out["frames"].push_back(
          {{"settings", {{"f_number", n}, {"exposure_us", t}, {"gain", gain}}}});
    return out;
  };
  const auto fixed = relative_exposure_by_f_number(report({{1.4, 1000, 1}, {5.6, 1000, 1}}));
  EXPECT_NEAR(fixed["f/1.4"].get<double>(), 1, 1e-12);
  EXPECT_NEAR(fixed["f/5.6"].get<double>(), 1.0 / 16, 1e-12);
  const auto warning = unequal_exposure_warning(fixed);
  ASSERT_TRUE(warning);
  EXPECT_NE(warning->find("f/5.6"), std::string::npos) << *warning;
  EXPECT_NE(warning->find("4.0 stops under"), std::string::npos) << *warning;
  const auto held = relative_exposure_by_f_number(report({{1.4, 1000, 1}, {5.6, 16000, 1}}));
  EXPECT_NEAR(held["f/5.6"].get<double>(), 1, 1e-12);
  EXPECT_FALSE(unequal_exposure_warning(held));
  EXPECT_FALSE(unequal_exposure_warning(
      relative_exposure_by_f_number(report({{1.4, 1000, 1}, {5.6, 8000, 2}}))));
  // Within half a stop is alike; frames that give no settings give no verdict.
  EXPECT_FALSE(unequal_exposure_warning(
      relative_exposure_by_f_number(report({{1.4, 1000, 1}, {2, 1500, 1}}))));
  EXPECT_TRUE(relative_exposure_by_f_number(report({})).empty());
  // Settings that are not numbers (a sidecar from elsewhere) are passed over, not thrown on.
  nlohmann::json odd = report({{1.4, 1000, 1}, {5.6, 16000, 1}});
  odd["frames"].push_back({{"settings", {{"f_number", "f/8"}, {"exposure_us", 1000}}}});
  odd["frames"].push_back({{"settings", "none"}});
  odd["frames"].push_back(7);
  EXPECT_EQ(relative_exposure_by_f_number(odd).size(), 2u);
}

}  // namespace lens_map_test
}  // namespace
}  // namespace camlab::analysis
