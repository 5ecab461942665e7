// lens_map_bench: the lens map's error against the truth over noise draws, and its time
// (docs/analysis.md, "Lens map"). Two virtual lens-map captures of the example chart
// (scene_lensmap_chart.json: 12 squares 1 m away), 15 focus positions 7 steps apart
// (15 to 113), rendered once per seed:
//  - the 640 x 480 example camera with its best-focus surface tilted 0.4 deg right, -0.25 deg
//    down and sagging 15 um at the corner, no astigmatism (--astigmatism-um: the sagittal
//    surface that far beyond the meridional at the corner), f/1.4 to f/5.6: per f-number the
//    astigmatism's rms and mean error (focus units and fraction of the sweep's step), how many
//    seeds have it within 0.05 of the step, the worst sag and tilt errors, the axis' rms;
//  - the colour example camera (R's focal length 0.02 mm longer, B's 0.015 mm shorter),
//    with lateral colour (R's image 0.8 px outward of G's at the corner, B's 0.5 px inward),
//    f/2 and f/2.8: R's and B's best focus minus G's, rms and mean error, how many within 0.02 of
//    the step, and |error| / stated standard error rms; the lateral colour's rms error.
// Time: the median analysis (analyze_lens_map, the SFR of every frame included) on the
// OpenCV threads there are.
//
//   lens_map_bench [--seeds N] [--no-noise] [--astigmatism-um UM] [--reports DIR]
//
// --reports DIR keeps each seed's lens-map reports (surface_seed_N.json, colour_seed_N.json:
// every edge's through-focus MTF50 and best focus) for a look edge by edge.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <unistd.h>

#include <nlohmann/json.hpp>

#include "../unit/analysis/lens_map_sweep.h"
#include "analysis/lensmap/lens_map.h"
#include "mock_device/render/render_capture.h"
#include "mock_device/render/renderer.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace {

using namespace camlab;
using nlohmann::json;

constexpr double kSweepStep = analysis::testing::kLensMapSweepStep;

json read_json(const std::filesystem::path& path) {
  std::ifstream in(path);
  return json::parse(in);
}

// Renders the chart through `camera` over the f-numbers x the 15 focus positions into
// `dir`; exits on failure (a benchmark has no result without its frames).
void render_sweep(const json& camera, const std::vector<double>& f_numbers, uint64_t seed,
                  bool noise, const std::filesystem::path& dir) {
  auto c = mock::parse_camera_spec(camera);
  auto s = mock::parse_scene_spec(
      read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/scene_lensmap_chart.json"));
  if (!c || !s) {
    std::fprintf(stderr, "spec: %s\n", (!c ? c.error() : s.error()).message.c_str());
    std::exit(1);
  }
  auto renderer = mock::Renderer::create(std::move(*c), std::move(*s));
  if (!renderer) {
    std::fprintf(stderr, "renderer: %s\n", renderer.error().message.c_str());
    std::exit(1);
  }
  mock::RenderCaptureRequest req =
      analysis::testing::lens_map_sweep(*renderer, dir, f_numbers, seed);
  req.options.noise = noise;
  if (auto rendered = mock::render_capture(*renderer, req); !rendered) {
    std::fprintf(stderr, "render: %s\n", rendered.error().message.c_str());
    std::exit(1);
  }
}

// Analyses `dir`, adding the seconds it took to `seconds`.
json analyse(const std::filesystem::path& dir, std::vector<double>* seconds) {
  const auto start = std::chrono::steady_clock::now();
  auto map = analysis::analyze_lens_map(dir, analysis::LensMapOptions{});
  seconds->push_back(
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  if (!map) {
    std::fprintf(stderr, "lens map of %s: %s\n", dir.c_str(), map.error().message.c_str());
    std::exit(1);
  }
  return map->report;
}

// Writes `report` to DIR/<what>_seed_<seed>.json when DIR is given.
void keep_report(const std::filesystem::path& dir, const char* what, int seed, const json& report) {
  if (dir.empty()) return;
  std::filesystem::create_directories(dir);
  std::ofstream(dir / (std::string(what) + "_seed_" + std::to_string(seed) + ".json"))
      << report.dump(1);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct SurfaceErrors {
  double astigmatism_sum = 0, astigmatism_ss = 0, astigmatism_z_ss = 0, axis_ss = 0;
  double sag_worst = 0, tilt_worst_deg = 0;
  int astigmatism_within = 0, runs = 0, agree = 0;
};

struct ColourErrors {
  double sum = 0, ss = 0, z_ss = 0, lateral_ss = 0;
  int within = 0, runs = 0;
};

}  // namespace

int main(int argc, char** argv) {
  int seeds = 12;
  bool noise = true;
  std::filesystem::path reports_dir;
  double astigmatism_um = 0;
  for (int i = 1; i < argc; ++i) {
    if (!std::strcmp(argv[i], "--seeds") && i + 1 < argc)
      seeds = std::max(1, std::atoi(argv[++i]));
    else if (!std::strcmp(argv[i], "--no-noise"))
      noise = false;
    else if (!std::strcmp(argv[i], "--astigmatism-um") && i + 1 < argc)
      astigmatism_um = std::atof(argv[++i]);
    else if (!std::strcmp(argv[i], "--reports") && i + 1 < argc)
      reports_dir = argv[++i];
    else {
      std::fprintf(stderr,
                   "usage: lens_map_bench [--seeds N] [--no-noise] [--astigmatism-um UM] "
                   "[--reports DIR]\n");
      return 2;
    }
  }
  if (!noise) seeds = 1;  // every draw is the same
  const auto dir = std::filesystem::temp_directory_path() /
                   ("camlab_lens_map_bench_" + std::to_string(::getpid()));

  // The tilted, curved surface; truth in focus units (1 um of lens travel a unit).
  json curved = read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_640x480.json");
  const double tilt_x_deg = 0.4, tilt_y_deg = -0.25, sag_um = -15;
  curved["lens"]["field_focus"] = {{"tilt_x_deg", tilt_x_deg},
                                   {"tilt_y_deg", tilt_y_deg},
                                   {"curvature_sag_um", sag_um},
                                   {"astigmatism_um", astigmatism_um}};
  const double f_mm = 8, d_mm = 1000, step_mm = 0.001;
  auto image_mm = [&](double focal_mm) { return focal_mm * d_mm / (d_mm - focal_mm); };
  const double axis = (image_mm(f_mm) - f_mm) / step_mm;
  const double truth_sag = sag_um * 1e-3 / step_mm;
  const double truth_astigmatism = astigmatism_um * 1e-3 / step_mm;
  // Longitudinal colour: each channel's image distance for the chart against green's.
  json colour = read_json(CAMLAB_SOURCE_DIR "/mock_device/examples/camera_colour_640x480.json");
  const double lateral_r_px = 0.8, lateral_b_px = -0.5;  // at the corner, radially outward
  colour["lens"]["lateral_colour_px"] = {lateral_r_px, 0.0, lateral_b_px};
  const double truth_r = (image_mm(8.02) - image_mm(8.0)) / step_mm;
  const double truth_b = (image_mm(7.985) - image_mm(8.0)) / step_mm;

  std::map<double, SurfaceErrors> surface_errors;
  std::map<std::pair<double, std::string>, ColourErrors> colour_errors;
  std::vector<double> surface_seconds, colour_seconds;
  for (int seed = 1; seed <= seeds; ++seed) {
    std::filesystem::remove_all(dir);
    render_sweep(curved, {1.4, 2, 2.8, 4, 5.6}, static_cast<uint64_t>(seed), noise, dir);
    const json surface_report = analyse(dir, &surface_seconds);  // kept: the loop reads into it
    keep_report(reports_dir, "surface", seed, surface_report);
    for (const json& s : surface_report["surfaces"]) {
      SurfaceErrors& e = surface_errors[s["f_number"].get<double>()];
      const double astigmatism = s["astigmatism_at_corner"].get<double>() - truth_astigmatism;
      e.astigmatism_sum += astigmatism, e.astigmatism_ss += astigmatism * astigmatism;
      e.astigmatism_within += std::fabs(astigmatism) <= 0.05 * kSweepStep;
      e.astigmatism_z_ss +=
          std::pow(astigmatism / s["standard_errors"]["astigmatism_at_corner"].get<double>(), 2);
      e.axis_ss += std::pow(s["centre_focus"].get<double>() - axis, 2);
      e.sag_worst =
          std::max(e.sag_worst, std::fabs(s["curvature_at_corner"].get<double>() / truth_sag - 1));
      e.tilt_worst_deg = std::max(
          {e.tilt_worst_deg, std::fabs(s["at_sensor"]["tilt_x_deg"].get<double>() - tilt_x_deg),
           std::fabs(s["at_sensor"]["tilt_y_deg"].get<double>() - tilt_y_deg)});
      ++e.runs;
    }
    // All f-numbers together (key 0 in the table).
    if (const json& pooled = surface_report["astigmatism_all_f_numbers"]; pooled.is_object()) {
      SurfaceErrors& e = surface_errors[0];
      const double astigmatism = pooled["at_corner"].get<double>() - truth_astigmatism;
      e.astigmatism_sum += astigmatism, e.astigmatism_ss += astigmatism * astigmatism;
      e.astigmatism_within += std::fabs(astigmatism) <= 0.05 * kSweepStep;
      e.astigmatism_z_ss += std::pow(astigmatism / pooled["standard_error"].get<double>(), 2);
      e.agree += pooled["f_numbers_agree"].get<bool>();
      ++e.runs;
    }
    std::filesystem::remove_all(dir);
    render_sweep(colour, {2, 2.8}, static_cast<uint64_t>(seed), noise, dir);
    const json colour_report = analyse(dir, &colour_seconds);
    keep_report(reports_dir, "colour", seed, colour_report);
    for (const json& s : colour_report["surfaces"])
      for (const json& c : s["channels"]) {
        const std::string name = c["channel"].get<std::string>();
        if (name == "G" || !c["focus_minus_green"].is_number()) continue;
        ColourErrors& e = colour_errors[{s["f_number"].get<double>(), name}];
        const double error =
            c["focus_minus_green"].get<double>() - (name == "R" ? truth_r : truth_b);
        const double sigma = c["focus_minus_green_standard_error"].get<double>();
        e.sum += error, e.ss += error * error;
        e.z_ss += sigma > 0 ? std::pow(error / sigma, 2) : 0;
        e.within += std::fabs(error) <= 0.02 * kSweepStep;
        e.lateral_ss += std::pow(c["lateral_colour_px_at_corner"].get<double>() -
                                     (name == "R" ? lateral_r_px : lateral_b_px),
                                 2);
        ++e.runs;
      }
    std::fprintf(stderr, "seed %d of %d\n", seed, seeds);
  }
  std::filesystem::remove_all(dir);

  std::printf(
      "Lens map of the tilted, curved virtual lens (%d seed(s)%s; truth: axis %.3f, "
      "sag %.3f, astigmatism %.3f focus units; step %.0f):\n",
      seeds, noise ? "" : ", no noise", axis, truth_sag, truth_astigmatism, kSweepStep);
  std::printf(
      "| f-number | astigmatism rms error | mean error | of the step | within 0.05 step | "
      "|error|/sigma rms | sag worst | tilt worst (deg) | axis rms error |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  for (const auto& [n, e] : surface_errors) {
    if (n == 0) continue;
    std::printf("| %.1f | %.3f | %+.3f | %.4f | %d of %d | %.2f | %.1f%% | %.4f | %.3f |\n", n,
                std::sqrt(e.astigmatism_ss / e.runs), e.astigmatism_sum / e.runs,
                std::sqrt(e.astigmatism_ss / e.runs) / kSweepStep, e.astigmatism_within, e.runs,
                std::sqrt(e.astigmatism_z_ss / e.runs), 100 * e.sag_worst, e.tilt_worst_deg,
                std::sqrt(e.axis_ss / e.runs));
  }
  if (auto all = surface_errors.find(0); all != surface_errors.end()) {
    const SurfaceErrors& e = all->second;
    std::printf(
        "| all (weighted) | %.3f | %+.3f | %.4f | %d of %d | %.2f | f-numbers agree in %d of %d | "
        "| "
        "|\n",
        std::sqrt(e.astigmatism_ss / e.runs), e.astigmatism_sum / e.runs,
        std::sqrt(e.astigmatism_ss / e.runs) / kSweepStep, e.astigmatism_within, e.runs,
        std::sqrt(e.astigmatism_z_ss / e.runs), e.agree, e.runs);
  }
  std::printf("analysis: %.2f s median (75 frames)\n\n", median(surface_seconds));
  std::printf(
      "Colour of the colour example camera (truth R - G %.3f, B - G %.3f focus units; lateral "
      "%.1f and %.1f px):\n",
      truth_r, truth_b, lateral_r_px, lateral_b_px);
  std::printf(
      "| f-number | channel | rms error | mean error | of the step | within 0.02 step | "
      "|error|/sigma rms | lateral rms error (px) |\n|---|---|---|---|---|---|---|---|\n");
  for (const auto& [key, e] : colour_errors)
    std::printf("| %.1f | %s - G | %.3f | %+.3f | %.4f | %d of %d | %.2f | %.4f |\n", key.first,
                key.second.c_str(), std::sqrt(e.ss / e.runs), e.sum / e.runs,
                std::sqrt(e.ss / e.runs) / kSweepStep, e.within, e.runs, std::sqrt(e.z_ss / e.runs),
                std::sqrt(e.lateral_ss / e.runs));
  std::printf("analysis: %.2f s median (30 frames)\n", median(colour_seconds));
  return 0;
}
