// analysis_bench: speed against error for the optics measurements (docs/measuring.md).
//  1. Edge fit: time per fit and diameter error (bias, spread over noise draws) against the
//     window's length and width, at contrast-to-noise 50, for D = 2, 8, 20 px.
//  2. Baseline-blur removal: its cost per edge and the error it removes.
//  3. Renderer sampling: diameter error on virtual-camera edges against the aperture
//     samples per pixel (the rendering's own noise, which the measurement inherits).
//  5. Overlapping edges (--pairs): the joint fit's time per edge and its diameter error
//     against the bar's width and the blur.
//  4. Focus measure: time per megapixel for a 12 MP frame against the previous fused
//     pass and OpenCV's three passes in the same run (with the largest relative
//     difference from OpenCV's), one core and two, and a full accumulator step.
// Medians over repeats; one core (cv::setNumThreads(1)) unless a row says otherwise.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <numbers>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/edge/edge_measure.h"
#include "analysis/edge/edge_spread.h"
#include "analysis/focus/focus_stack.h"
#include "analysis_bench_previous_focus.h"
#include "mock_device/render/renderer.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace {

using namespace camlab;
using namespace camlab::analysis;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

struct Stats {
  double bias = 0, spread = 0, ms = 0;
  int failed = 0;
};

Stats edge_stats(double d, double hl, double hw, double sigma_b, int draws) {
  const double a = 95.0 * std::numbers::pi / 180.0;
  const int size = static_cast<int>(2 * (hl + hw)) + 12;
  const double c = 0.5 * (size - 1) + 0.31;
  const cv::Mat clean = render_edge_model(size, size, EdgeLine{c, c, a}, d, sigma_b, 100.0, 1100.0);
  std::vector<double> values, times;
  Stats s;
  for (int k = 0; k < draws; ++k) {
    cv::Mat noise(size, size, CV_32F);
    cv::RNG rng(1000 + k);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 1000.0 / 50.0);
    const cv::Mat img = clean + noise;
    EdgeFitOptions o;
    o.half_length_px = hl;
    o.half_width_px = hw;
    const auto t0 = Clock::now();
    auto fit = fit_pillbox_edge(img, EdgeLine{c, c, a}, o);
    double value = fit ? fit->diameter_px : 0.0;
    if (fit && sigma_b > 0) {
      auto inv = remove_baseline_blur(value, sigma_b, fit->angle_rad);
      value = inv ? inv->diameter_px : 0.0;
    }
    times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    if (!fit) {
      ++s.failed;
      continue;
    }
    values.push_back(value);
  }
  double mean = 0, m2 = 0;
  for (double v : values) mean += v / values.size();
  for (double v : values) m2 += (v - mean) * (v - mean) / std::max<size_t>(1, values.size() - 1);
  s.bias = mean - d;
  s.spread = std::sqrt(m2);
  s.ms = median(times);
  return s;
}

void edge_table() {
  std::printf("## Edge fit: window against time and error (CNR 50, 5 deg, 24 noise draws)\n\n");
  std::printf(
      "| D px | half_length px | half_width px | ms per fit | bias px | spread px | failed |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|---:|\n");
  for (double d : {2.0, 8.0, 20.0}) {
    for (double hl : {15.0, 30.0, 60.0, 120.0}) {
      for (double extra : {3.0, 8.0, 16.0}) {
        const double hw = 0.5 * d + extra;
        const Stats s = edge_stats(d, hl, hw, 0.0, 24);
        std::printf("| %.0f | %.0f | %.1f | %.2f | %+.4f | %.4f | %d |\n", d, hl, hw, s.ms, s.bias,
                    s.spread, s.failed);
      }
    }
  }
  std::printf(
      "\n## Baseline blur (Gaussian sigma 1 px): removal cost and error (half_length 60)\n\n");
  std::printf(
      "| D px | removal | ms per edge | bias px | spread px |\n|---:|---|---:|---:|---:|\n");
  for (double d : {2.0, 8.0, 20.0}) {
    const double hw = 0.5 * d + 12.0;
    // Without removal: the pure-disk fit of a disk (x) Gaussian.
    const double a = 95.0 * std::numbers::pi / 180.0;
    const int size = static_cast<int>(2 * (60 + hw)) + 12;
    const double c = 0.5 * (size - 1) + 0.31;
    const cv::Mat clean = render_edge_model(size, size, EdgeLine{c, c, a}, d, 1.0, 100.0, 1100.0);
    EdgeFitOptions o;
    o.half_length_px = 60;
    o.half_width_px = hw;
    auto raw = fit_pillbox_edge(clean, EdgeLine{c, c, a}, o);
    std::printf("| %.0f | none (noise-free) | - | %+.4f | - |\n", d,
                raw ? raw->diameter_px - d : NAN);
    const Stats s = edge_stats(d, 60.0, hw, 1.0, 16);
    std::printf("| %.0f | inverted | %.2f | %+.4f | %.4f |\n", d, s.ms, s.bias, s.spread);
  }
}

void sampling_table() {
  std::printf(
      "\n## Renderer aperture samples against the measured diameter (virtual camera, "
      "f/2..f/8)\n\n");
  std::printf(
      "| aperture samples | f-number | truth D px | measured D px | error px | render s |\n");
  std::printf("|---:|---:|---:|---:|---:|---:|\n");
  const nlohmann::json camera = {
      {"name", "bench"},
      {"sensor",
       {{"width_px", 160},
        {"height_px", 160},
        {"pixel_pitch_um", 6.0},
        {"bit_depth", 12},
        {"black_level_dn", 64},
        {"full_well_e", 20000},
        {"read_noise_e", 0.0},
        {"shot_noise", false}}},
      {"lens", {{"focal_mm", 8.0}, {"model", "LENSMODEL_PINHOLE"}, {"f_number_min", 1.4}}},
      {"timing", {{"frame_interval_us", 100000}}},
      {"controls", {{"exposure_time_absolute", {{"min", 1}, {"max", 1000}, {"default", 30}}}}}};
  const nlohmann::json scene = {{"illuminance_lux", 1000},
                                {"targets",
                                 {{{"type", "slanted_edge"},
                                   {"size_m", {0.03, 0.03}},
                                   {"angle_deg", 5},
                                   {"dark_reflectance", 0.1},
                                   {"light_reflectance", 0.8},
                                   {"pose", {{"position_m", {0.0, 0.0, 0.35}}}}}}}};
  auto cs = mock::parse_camera_spec(camera);
  auto ss = mock::parse_scene_spec(scene);
  if (!cs || !ss) return;
  auto renderer = mock::Renderer::create(std::move(*cs), std::move(*ss));
  if (!renderer) return;
  for (int samples : {16, 64, 256}) {
    for (double n : {2.0, 8.0}) {
      mock::RenderSettings st{std::round(27.0 * (n / 2) * (n / 2)) * 100.0, 1.0, n, 0};
      mock::RenderOptions ro;
      ro.aperture_samples = samples;
      ro.noise = false;
      ro.threads = 1;
      auto frame = renderer->render(st, 0, ro);
      if (!frame) continue;
      const auto& e = frame->truth["targets"][0]["edge_px"];
      EdgeSegment seg{"edge", e["start"][0], e["start"][1], e["end"][0], e["end"][1], 0};
      cv::Mat img;
      frame->image.convertTo(img, CV_32F);
      auto m = measure_edge(img, seg, {}, {});
      const double truth = frame->truth["targets"][0]["coc_px"]["at_origin"];
      std::printf("| %d | %.0f | %.3f | %.3f | %+.4f | %.2f |\n", samples, n, truth,
                  m ? m->diameter_px : NAN, m ? m->diameter_px - truth : NAN, frame->stats.seconds);
    }
  }
}

void focus_table() {
  std::printf("\n## Focus measure speed (9x9 window; 12-bit data in 16-bit frames)\n\n");
  std::printf(
      "| frame | step | threads | ms per frame | ms per MP | max relative difference |\n"
      "|---|---|---:|---:|---:|---:|\n");
  for (cv::Size size : {cv::Size(1000, 1000), cv::Size(4000, 3000)}) {
    cv::Mat frame(size, CV_16U);
    cv::randu(frame, 0, 4096);
    const double mp = size.area() / 1e6;
    auto time_ms = [](auto&& f) {
      std::vector<double> t;
      for (int k = 0; k < 7; ++k) {
        const auto t0 = Clock::now();
        f();
        t.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      }
      return median(t);
    };
    // The reference: OpenCV's three passes; every other row is checked against it.
    cv::Mat reference;
    const double t_opencv = time_ms([&] {
      cv::Mat lap;
      cv::Laplacian(frame, lap, CV_32F, 1, 1.0, 0.0, cv::BORDER_REFLECT);
      cv::multiply(lap, lap, lap);
      cv::boxFilter(lap, reference, CV_32F, cv::Size(9, 9), cv::Point(-1, -1), true,
                    cv::BORDER_REFLECT);
    });
    auto max_rel = [&](const cv::Mat& m) {
      cv::Mat diff = cv::abs(m - reference) / cv::max(reference, 1e-30);
      double worst = 0;
      cv::minMaxLoc(diff, nullptr, &worst);
      return worst;
    };
    auto row = [&](const char* step, int threads, double ms, const cv::Mat& m) {
      std::printf("| %dx%d | %s | %d | %.1f | %.1f | %.1e |\n", size.width, size.height, step,
                  threads, ms, ms / mp, max_rel(m));
    };
    row("3 OpenCV passes (Laplacian, multiply, boxFilter)", 1, t_opencv, reference);
    cv::Mat previous, fresh, reused;
    row("previous fused pass (double running sums)", 1,
        time_ms([&] { previous = bench::previous::previous_focus_measure(frame, 9); }), previous);
    row("focus_measure, new output each call", 1, time_ms([&] { fresh = focus_measure(frame, 9); }),
        fresh);
    row("focus_measure into a reused buffer", 1,
        time_ms([&] { focus_measure(frame, 9, &reused, 1.0); }), reused);
    cv::setNumThreads(2);
    row("focus_measure into a reused buffer", 2,
        time_ms([&] { focus_measure(frame, 9, &reused, 1.0); }), reused);
    cv::setNumThreads(1);
    FocusStackAccumulator acc({});
    const double t_add = time_ms([&] { (void)acc.add(frame); });
    std::printf(
        "| %dx%d | accumulator add (measure, noise floor, running peak, 32 px regions) | 1 | %.1f "
        "| %.1f | - |\n",
        size.width, size.height, t_add, t_add / mp);
  }
}

// Joint fit of two overlapping edges (edge_pair.h) through measure_edge: a bar of
// `width` px (1800 on 1000) under a disk of D px, 3 degrees off the pixel grid, CNR 50.
void pair_table() {
  std::printf("\n## Overlapping edges: joint fit of a bar's two edges (CNR 50, 8 noise draws)\n\n");
  std::printf(
      "| D px | bar width px | ms per edge | accepted | bias px | spread px | mean sigma px |\n"
      "|---:|---:|---:|---:|---:|---:|---:|\n");
  const double a = 93.0 * std::numbers::pi / 180.0, c = 110.27;
  for (double d : {2.0, 5.0, 10.0, 20.0})
    for (double width : {2.0, 5.0, 10.0}) {
      const double shift = width / std::sin(a);
      const cv::Mat left = render_edge_model(220, 220, EdgeLine{c, c, a}, d, 0.0, 0.0, 1.0);
      const cv::Mat right =
          render_edge_model(220, 220, EdgeLine{c + shift, c, a}, d, 0.0, 0.0, 1.0);
      const cv::Mat clean = 1000.0 - 800.0 * (left - right);
      const std::vector<EdgeSegment> edges = {
          {"left", c - 80 * std::cos(a), c - 80 * std::sin(a), c + 80 * std::cos(a),
           c + 80 * std::sin(a), 0},
          {"right", c + shift - 80 * std::cos(a), c - 80 * std::sin(a),
           c + shift + 80 * std::cos(a), c + 80 * std::sin(a), 0}};
      std::vector<double> values, times, sigmas;
      constexpr int kDraws = 8;
      for (int k = 0; k < kDraws; ++k) {
        cv::Mat noise(clean.size(), CV_32F);
        cv::RNG rng(500 + k);
        rng.fill(noise, cv::RNG::NORMAL, 0.0, 800.0 / 50.0);
        const cv::Mat image = clean + noise;
        const auto t0 = Clock::now();
        auto m = measure_edge(image, edges[k % 2], edges, {});
        times.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
        if (m && m->status == kEdgeOk) {
          values.push_back(m->diameter_px);
          sigmas.push_back(m->diameter_sigma_px);
        }
      }
      double mean = 0, ss = 0, sig = 0;
      for (double v : values) mean += v / std::max<size_t>(1, values.size());
      for (double v : values) ss += (v - mean) * (v - mean);
      for (double v : sigmas) sig += v / std::max<size_t>(1, sigmas.size());
      if (values.empty())
        std::printf("| %.0f | %.0f | %.0f | 0/%d | - | - | - |\n", d, width, median(times), kDraws);
      else
        std::printf("| %.0f | %.0f | %.0f | %zu/%d | %+.4f | %.4f | %.4f |\n", d, width,
                    median(times), values.size(), kDraws, mean - d,
                    values.size() > 1 ? std::sqrt(ss / (values.size() - 1)) : 0.0, sig);
    }
}

}  // namespace

// analysis_bench [--edges] [--sampling] [--focus] [--pairs]: the named tables (all
// without arguments).
int main(int argc, char** argv) {
  cv::setNumThreads(1);
  auto want = [&](const char* name) {
    if (argc == 1) return true;
    for (int i = 1; i < argc; ++i)
      if (std::strcmp(argv[i], name) == 0) return true;
    return false;
  };
  if (want("--edges")) edge_table();
  if (want("--sampling")) sampling_table();
  if (want("--focus")) focus_table();
  if (want("--pairs")) pair_table();
  return 0;
}
