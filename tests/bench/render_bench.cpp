// Render speed against error (docs/measuring.md).
//
//   render_bench [--quick] [--tables speed,focus,noise,draws,aperture] [--references DIR]
//
// Table 1 (speed): per example scene, the scene integral's cost when it is computed
//          afresh (a new sampling seed each frame, so nothing is reused), the whole
//          frame's cost (integral + sensor model, noise on) fresh and with the integral
//          reused, and the integral's error against a 1024-sample reference of the same
//          frame: RMS over the pixels with structure (the reference's 3x3 range above
//          0.5% of the scene's contrast), in % of that contrast. Wall time is what the
//          2 threads took; CPU time is what they used (on a shared machine the wall time
//          also counts the time other processes held the cores).
// Table 2 (focus): focus and iris changed on every frame, so every frame integrates
//          afresh; the error of the first setting against its reference.
// Table 3 (noise): the sensor model alone (expose(): noise, gain, black level, rounding)
//          per frame, on a ramp from 0 to the full well, with the noise off, with the
//          noise samplers it had before (std::poisson_distribution per pixel) and with the
//          current ones, in the same run.
// Table 4 (draws): the noise deviates one at a time, ns per draw.
// Table 5 (aperture): for a slanted edge defocused to D px, per aperture sample count:
//          time per frame, RMS error of the edge pixels against a 1024-sample reference
//          render of the same frame (in % of the edge contrast), and the blur diameter
//          measured by the exact pillbox fit against the thin-lens CoC; "auto" is the
//          renderer's own choice.
// No noise in the error columns, so the error is the sampling's alone. The references take
// minutes (1024 samples on every pixel), so they are kept in DIR (default
// render_bench_references next to the binary) keyed by scene and settings.
#include <time.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/edge/edge_spread.h"
#include "mock_device/render/noise_sampler.h"
#include "mock_device/render/renderer.h"
#include "mock_device/render/sensor_model.h"
#include "optics/optics.h"
#include "render_bench_previous_noise.h"

namespace {

using namespace camlab;
using namespace camlab::mock;
namespace fs = std::filesystem;

const fs::path kExamples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";
fs::path g_reference_dir;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double cpu_seconds() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) + 1e-9 * static_cast<double>(ts.tv_nsec);
}

template <class T>
T or_exit(Result<T> r) {
  if (!r) {
    std::fprintf(stderr, "%s\n", r.error().message.c_str());
    std::exit(1);
  }
  return std::move(*r);
}

Renderer load(const char* camera, const char* scene) {
  return or_exit(Renderer::create(or_exit(load_camera_spec(kExamples / camera)),
                                  or_exit(load_scene_spec(kExamples / scene))));
}

// The largest dark-to-light step of the scene's targets (grey reflectance).
double scene_contrast(const SceneSpec& scene) {
  double contrast = 0;
  for (const auto& t : scene.targets)
    contrast = std::max(contrast, std::fabs(t.light.grey - t.dark.grey));
  return contrast > 0 ? contrast : 1.0;
}

// The 1024-sample reference integral of a frame, from DIR when an earlier run made it.
cv::Mat reference_integral(Renderer& renderer, const std::string& name,
                           const RenderSettings& settings, int view) {
  char key[256];
  std::snprintf(key, sizeof key, "%s_v%d_focus%d_f%.3f.f32", name.c_str(), view,
                settings.focus_position, settings.f_number);
  const fs::path file = g_reference_dir / key;
  const int rows = renderer.camera().sensor.height_px, cols = renderer.camera().sensor.width_px;
  cv::Mat ref(rows, cols, CV_32F);
  if (std::ifstream in(file, std::ios::binary); in) {
    in.read(reinterpret_cast<char*>(ref.data), static_cast<std::streamsize>(ref.total() * 4));
    if (in.gcount() == static_cast<std::streamsize>(ref.total() * 4)) return ref;
  }
  RenderOptions options;
  options.aperture_samples = 1024;
  options.seed = 1000;
  const auto start = std::chrono::steady_clock::now();
  ref = or_exit(renderer.integrate_scene(settings, view, options)).reflectance;
  std::fprintf(stderr, "reference %s: %.0f s\n", key,
               std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  fs::create_directories(g_reference_dir);
  std::ofstream(file, std::ios::binary)
      .write(reinterpret_cast<const char*>(ref.data),
             static_cast<std::streamsize>(ref.total() * 4));
  return ref;
}

struct ErrorFigures {
  double rms_percent = 0;  // of the contrast, over the structured pixels
  double max_percent = 0;
  int pixels = 0;  // structured pixels
};

ErrorFigures integral_error(const cv::Mat& integral, const cv::Mat& reference, double contrast) {
  cv::Mat hi, lo;
  cv::dilate(reference, hi, cv::Mat());
  cv::erode(reference, lo, cv::Mat());
  const cv::Mat mask = (hi - lo) > 0.005 * contrast;
  cv::Mat diff;
  cv::absdiff(integral, reference, diff);
  ErrorFigures e;
  e.pixels = cv::countNonZero(mask);
  if (e.pixels == 0) return e;
  cv::Mat sq = diff.mul(diff);
  e.rms_percent = std::sqrt(cv::mean(sq, mask)[0]) / contrast * 100;
  double max_diff = 0;
  cv::minMaxLoc(diff, nullptr, &max_diff, nullptr, nullptr, mask);
  e.max_percent = max_diff / contrast * 100;
  return e;
}

struct SpeedCase {
  const char* label;
  const char* camera;
  const char* scene;
};

void speed_table(int repeats) {
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::printf(
      "Speed and error (%u threads, median of %d; fresh = integral recomputed with a new seed, "
      "cached = integral reused)\n",
      threads, repeats);
  std::printf(
      "| scene | rule | samples/px | integral ms fresh (wall) | integral CPU ms | frame ms fresh "
      "(noise on) | frame ms cached | frames/s fresh | error vs 1024 ref, RMS %% | max %% | "
      "structured px |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  const SpeedCase cases[] = {
      {"640x480 slanted edges", "camera_640x480.json", "scene_slanted_edges.json"},
      {"640x480 in focus (edge at 1 m)", "camera_640x480.json", "scene_colour_edge_1m.json"},
      {"1280x800 chessboard (view 0)", "camera_wide_1280x800.json",
       "scene_chessboard_calibration.json"},
      {"640x480 textured tilted plane", "camera_640x480.json", "scene_textured_tilted_plane.json"},
      {"640x480 colour, slanted edges", "camera_colour_640x480.json", "scene_slanted_edges.json"},
  };
  for (const SpeedCase& c : cases) {
    Renderer renderer = load(c.camera, c.scene);
    const RenderSettings settings = renderer.default_settings();
    const std::string name = std::string(c.camera).substr(0, std::strlen(c.camera) - 5) + "_" +
                             std::string(c.scene).substr(0, std::strlen(c.scene) - 5);
    const cv::Mat reference = reference_integral(renderer, name, settings, 0);
    std::vector<double> integral_wall, integral_cpu, frame_fresh, frame_cached;
    SceneIntegral first;
    for (int i = 0; i < repeats; ++i) {
      RenderOptions options;
      options.seed = static_cast<uint64_t>(100 + i);
      const double cpu0 = cpu_seconds();
      SceneIntegral integral = or_exit(renderer.integrate_scene(settings, 0, options));
      integral_cpu.push_back(cpu_seconds() - cpu0);
      integral_wall.push_back(integral.stats.seconds);
      if (i == 0) first = integral;
      options.seed = static_cast<uint64_t>(500 + i);  // not yet integrated: a fresh frame
      options.frame_number = static_cast<uint64_t>(i);
      frame_fresh.push_back(or_exit(renderer.render(settings, 0, options)).stats.seconds);
      options.frame_number += 1000;  // the same integral, new noise
      frame_cached.push_back(or_exit(renderer.render(settings, 0, options)).stats.seconds);
    }
    const ErrorFigures e =
        integral_error(first.reflectance, reference, scene_contrast(renderer.scene()));
    const RenderStats& s = first.stats;
    char rule[96];
    std::snprintf(rule, sizeof rule, "auto (up to %d lens samples)", s.aperture_samples);
    std::printf("| %s | %s | %.1f | %.1f | %.1f | %.1f | %.1f | %.2f | %.3f | %.2f | %d |\n",
                c.label, rule, s.mean_samples_per_pixel, median(integral_wall) * 1e3,
                median(integral_cpu) * 1e3, median(frame_fresh) * 1e3, median(frame_cached) * 1e3,
                1.0 / median(frame_fresh), e.rms_percent, e.max_percent, e.pixels);
  }
}

void focus_table(int frames) {
  Renderer renderer = load("camera_640x480.json", "scene_slanted_edges.json");
  std::printf(
      "\nFocus and iris changed on every frame (640x480, scene_slanted_edges.json, %d frames: "
      "focus 40..90 steps, f/2, f/2.8, f/4)\n",
      frames);
  std::printf(
      "| part | ms/frame (wall, median) | CPU ms/frame | frames/s | error of the first setting vs "
      "1024 ref, RMS %% |\n|---|---|---|---|---|\n");
  const int focus_steps[] = {40, 52, 65, 78, 90, 71, 58};
  const double f_numbers[] = {2.0, 2.8, 4.0};
  auto settings_of = [&](int i) {
    RenderSettings settings = renderer.default_settings();
    settings.focus_position = focus_steps[i % 7];
    settings.f_number = f_numbers[i % 3];
    return settings;
  };
  // The integral alone, then whole frames with noise (a new seed: nothing reused).
  for (bool whole_frame : {false, true}) {
    std::vector<double> wall;
    const double cpu0 = cpu_seconds();
    for (int i = 0; i < frames; ++i) {
      RenderOptions options;
      options.seed = whole_frame ? 2 : 1;
      options.frame_number = static_cast<uint64_t>(i);
      RenderStats stats = whole_frame
                              ? or_exit(renderer.render(settings_of(i), 0, options)).stats
                              : or_exit(renderer.integrate_scene(settings_of(i), 0, options)).stats;
      if (stats.cached) std::fprintf(stderr, "frame %d reused an integral\n", i);
      wall.push_back(stats.seconds);
    }
    const double cpu_per_frame = (cpu_seconds() - cpu0) / frames;
    double error = NAN;
    if (!whole_frame) {
      const cv::Mat ref =
          reference_integral(renderer, "camera_640x480_scene_slanted_edges", settings_of(0), 0);
      RenderOptions again;  // a new seed: integrated afresh, noise-free
      again.seed = 77;
      const cv::Mat integral =
          or_exit(renderer.integrate_scene(settings_of(0), 0, again)).reflectance;
      error = integral_error(integral, ref, scene_contrast(renderer.scene())).rms_percent;
    }
    char error_text[32] = "-";
    if (!std::isnan(error)) std::snprintf(error_text, sizeof error_text, "%.3f", error);
    std::printf("| %s | %.1f | %.1f | %.2f | %s |\n",
                whole_frame ? "whole frame (noise on)" : "scene integral", median(wall) * 1e3,
                cpu_per_frame * 1e3, 1.0 / median(wall), error_text);
  }
}

// expose() on a horizontal ramp of reflectance whose electrons run from 0 to the full
// well: every regime of the shot-noise sampler (under 1 e- to thousands) in one frame.
void noise_table(int repeats) {
  std::printf(
      "\nSensor model per frame (expose(): a ramp from 0 e- to the full well, median of %d), "
      "previous samplers against the current ones\n",
      repeats);
  std::printf(
      "| sensor | threads | noise off ms | previous noise ms | current noise ms | speed-up "
      "|\n|---|---|---|---|---|---|\n");
  const int hardware = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  for (const char* name : {"camera_640x480.json", "camera_wide_1280x800.json"}) {
    auto camera = load_camera_spec(kExamples / name);
    if (!camera) {
      std::fprintf(stderr, "%s\n", camera.error().message.c_str());
      std::exit(1);
    }
    const int w = camera->sensor.width_px, h = camera->sensor.height_px;
    cv::Mat ramp(h, w, CV_32F);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) ramp.at<float>(y, x) = static_cast<float>(x) / (w - 1);
    const double e_per_reflectance = camera->sensor.full_well_e;
    for (int threads : {1, hardware}) {
      auto time_ms = [&](auto&& expose_once) {
        std::vector<double> ms;
        for (int i = 0; i < repeats; ++i) {
          const auto start = std::chrono::steady_clock::now();
          cv::Mat out = expose_once(static_cast<uint64_t>(i));
          ms.push_back(
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                  .count());
          if (out.empty()) std::exit(1);
        }
        return median(ms);
      };
      const double off = time_ms([&](uint64_t seed) {
        return expose(ramp, *camera, e_per_reflectance, 1.0, false, seed, threads);
      });
      const double before = time_ms([&](uint64_t seed) {
        return bench::previous::expose(ramp, *camera, e_per_reflectance, 1.0, true, seed, threads);
      });
      const double now = time_ms([&](uint64_t seed) {
        return expose(ramp, *camera, e_per_reflectance, 1.0, true, seed, threads);
      });
      std::printf("| %dx%d | %d | %.1f | %.1f | %.1f | %.1fx |\n", w, h, threads, off, before, now,
                  before / now);
    }
  }
}

void aperture_table(const std::vector<double>& diameters_px, const std::vector<int>& samples) {
  // 8 mm f/2 pinhole-model camera, 4 um pixels, 192x192, an edge at 1 m; focus placed in
  // front so the thin-lens CoC is D.
  nlohmann::json camera = {
      {"sensor",
       {{"width_px", 192},
        {"height_px", 192},
        {"pixel_pitch_um", 4.0},
        {"bit_depth", 16},
        {"full_well_e", 60000},
        {"read_noise_e", 0.0},
        {"shot_noise", false}}},
      {"lens",
       {{"focal_mm", 8.0},
        {"f_number_min", 2.0},
        {"f_number_max", 16.0},
        {"focus", {{"position_max", 2000}, {"extension_mm_per_step", 0.0005}}}}},
      {"timing", {{"frame_interval_us", 100000}}},
      {"controls", {{"exposure_time_absolute", {{"max", 1000}, {"default", 100}}}}}};
  nlohmann::json scene = {{"illuminance_lux", 1500},  // light side at ~40% of full well
                          {"targets",
                           {{{"type", "slanted_edge"},
                             {"size_m", {1.0, 1.0}},
                             {"angle_deg", 5.0},
                             {"dark_reflectance", 0.1},
                             {"light_reflectance", 0.7},
                             {"pose", {{"position_m", {0.0, 0.0, 1.0}}}}}}}};
  Renderer renderer =
      or_exit(Renderer::create(*parse_camera_spec(camera), *parse_scene_spec(scene)));
  std::printf(
      "\nEdge profile error against a 1024-sample reference, and measured D against the thin "
      "lens\n");
  std::printf(
      "| D px (thin lens) | aperture samples | ms/frame | edge RMS error %% of contrast | fitted D "
      "px | D error %% |\n");
  std::printf("|---|---|---|---|---|---|\n");
  for (double d_px : diameters_px) {
    const double coc_mm = d_px * 0.004, f = 8.0, n = 2.0, a = f / n, z = 1000.0;
    const double s_mm = f * z * (a + coc_mm) / (coc_mm * z + a * f);
    RenderSettings settings = renderer.default_settings();
    settings.f_number = n;
    settings.focus_position =
        static_cast<int>(std::lround((*optics::lens_to_sensor_mm(f, s_mm) - f) / 0.0005));
    RenderOptions options;
    options.noise = false;
    options.aperture_samples = 1024;
    options.seed = 1000;
    auto reference = renderer.render(settings, 0, options);
    const double truth_px = reference->truth["targets"][0]["coc_px"]["at_origin"].get<double>();
    cv::Mat ref;
    reference->image.convertTo(ref, CV_64F);
    double lo, hi;
    cv::minMaxLoc(ref, &lo, &hi);
    // Edge pixels: those strictly between dark and light in the reference.
    cv::Mat edge_mask = (ref > lo + 0.01 * (hi - lo)) & (ref < hi - 0.01 * (hi - lo));
    const auto& e = reference->truth["targets"][0]["edge_px"];
    analysis::EdgeLine guess{e["middle"][0].get<double>(), e["middle"][1].get<double>(),
                             std::atan2(e["end"][1].get<double>() - e["start"][1].get<double>(),
                                        e["end"][0].get<double>() - e["start"][0].get<double>())};
    std::vector<int> counts = samples;
    counts.push_back(-1);  // the automatic rule
    for (int count : counts) {
      options.aperture_samples = count;
      options.seed = 1;
      std::vector<double> seconds;
      Result<RenderedFrame> frame = make_error("internal", "not run yet");
      for (int i = 0; i < 3; ++i) {
        options.seed = static_cast<uint64_t>(1 + i);  // fresh integrals; the last is measured
        frame = renderer.render(settings, 0, options);
        seconds.push_back(frame->stats.seconds);
      }
      cv::Mat img;
      frame->image.convertTo(img, CV_64F);
      cv::Mat diff = img - ref;
      const double rms = std::sqrt(cv::mean(diff.mul(diff), edge_mask)[0]) / (hi - lo) * 100;
      analysis::EdgeFitOptions fit_options;
      fit_options.half_width_px = truth_px / 2 + 8;
      fit_options.half_length_px = 80;
      auto fit = analysis::fit_pillbox_edge(frame->image, guess, fit_options);
      char label[64];
      if (count > 0)
        std::snprintf(label, sizeof label, "%d", frame->stats.aperture_samples);
      else
        std::snprintf(label, sizeof label, "auto (%.1f per px)",
                      frame->stats.mean_samples_per_pixel);
      std::printf("| %.2f | %s | %.1f | %.3f | %.3f | %+.2f |\n", truth_px, label,
                  median(seconds) * 1e3, rms, fit ? fit->diameter_px : NAN,
                  fit ? (fit->diameter_px / truth_px - 1) * 100 : NAN);
    }
  }
}

// One deviate at a time: the Poisson law rebuilt for every draw (a pixel whose mean
// differs from its neighbour's) and kept (a uniform patch), and the normal; best of 15
// runs of 200000 draws, so other work on the machine counts least.
void draw_table() {
  std::printf("\nNoise deviates: ns per draw (best of 15 runs of 200000)\n");
  std::printf("| deviate | mean e- | ns per draw, law rebuilt | ns per draw, law kept |\n");
  std::printf("|---|---|---|---|\n");
  auto best_ns = [](auto&& draw) {
    double best = 1e9;
    for (int run = 0; run < 15; ++run) {
      constexpr int kDraws = 200000;
      double sum = 0;
      const auto start = std::chrono::steady_clock::now();
      for (int i = 0; i < kDraws; ++i) sum += draw(static_cast<uint64_t>(run * kDraws + i));
      const double ns =
          std::chrono::duration<double, std::nano>(std::chrono::steady_clock::now() - start)
              .count() /
          kDraws;
      if (sum == -1) std::printf(" ");  // keeps the draws from being optimised away
      best = std::min(best, ns);
    }
    return best;
  };
  constexpr uint64_t kKey = 0x5EED;
  for (double mean : {0.5, 5.0, 30.0, 1000.0, 6000.0}) {
    const noise::PoissonLaw law(mean);
    const double rebuilt =
        best_ns([&](uint64_t i) { return static_cast<double>(noise::poisson(mean, kKey, i)); });
    const double kept = best_ns([&](uint64_t i) { return static_cast<double>(law.draw(kKey, i)); });
    std::printf("| Poisson | %g | %.1f | %.1f |\n", mean, rebuilt, kept);
  }
  std::printf("| normal | - | %.1f | - |\n",
              best_ns([&](uint64_t i) { return noise::standard_normal(kKey, i); }));
}

}  // namespace

int main(int argc, char** argv) {
  bool quick = false;
  std::string tables = "speed,focus,noise,draws,aperture";
  g_reference_dir = fs::absolute(argv[0]).parent_path() / "render_bench_references";
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--quick") {
      quick = true;
    } else if (arg == "--tables" && i + 1 < argc) {
      tables = argv[++i];
    } else if (arg == "--references" && i + 1 < argc) {
      g_reference_dir = argv[++i];
    } else {
      std::fprintf(stderr,
                   "usage: render_bench [--quick] [--tables speed,focus,noise,draws,aperture] "
                   "[--references DIR]\n");
      return 2;
    }
  }
  if (tables.find("speed") != std::string::npos) speed_table(quick ? 1 : 5);
  if (tables.find("focus") != std::string::npos) focus_table(quick ? 7 : 21);
  if (tables.find("noise") != std::string::npos) noise_table(quick ? 3 : 9);
  if (tables.find("draws") != std::string::npos) draw_table();
  if (tables.find("aperture") != std::string::npos) {
    if (quick)
      aperture_table({10.0}, {4, 16, 64});
    else
      aperture_table({3.0, 10.0, 30.0}, {1, 4, 9, 16, 36, 64, 144, 256});
  }
  return 0;
}
