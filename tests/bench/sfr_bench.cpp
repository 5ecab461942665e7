// sfr_bench: the slanted-edge SFR's time per edge against its MTF50 error, over the ESF
// window's half width and the edge's length (docs/analysis.md, "SFR"). Edges from
// tests/unit/analysis/sfr_edges.h (analytic Gaussian ESF, 8 x 8 samples a pixel, 5 deg
// off the columns) at contrast-to-noise 50, 24 noise draws a row; time: median of the 24
// calls on one core. Then a whole frame: a 12 MP chart (4000 x 3000) of 9 x 7 dark squares
// turned 5 deg, each side an edge (252), found and measured by analyze_sfr as `camlab
// analyze sfr` does; time: median of 5 runs, on the OpenCV threads given (default 2).
//
//   sfr_bench [THREADS]
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "../unit/analysis/sfr_edges.h"
#include "analysis/sfr/sfr_image.h"
#include "analysis/sfr/slanted_edge_sfr.h"

namespace {

using namespace camlab::analysis;
using namespace camlab::analysis::sfr_edges;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

// The 12 MP chart: squares of 220 px drawn anti-aliased, blurred
// by a Gaussian of sigma 1 px, light 0.8 / dark 0.1 of 4000 DN, noise of 16 DN (SNR 50 on
// the light side).
cv::Mat chart_12mp() {
  const int width = 4000, height = 3000;
  // Anti-aliased with the corners at quarter-pixel precision (cv::LINE_AA, shift 2).
  cv::Mat chart(height, width, CV_8U, cv::Scalar(204));
  const double side = 220, a = 5.0 * kPi / 180;
  for (int j = 0; j < 7; ++j)
    for (int i = 0; i < 9; ++i) {
      const double cx = (i + 0.5) * width / 9.0, cy = (j + 0.5) * height / 7.0;
      std::vector<cv::Point> corners;
      for (int k = 0; k < 4; ++k) {
        const double t = a + k * kPi / 2;
        const double x = cx + side / std::sqrt(2.0) * std::cos(t + kPi / 4);
        const double y = cy + side / std::sqrt(2.0) * std::sin(t + kPi / 4);
        corners.emplace_back(static_cast<int>(std::lround(x * 4)),
                             static_cast<int>(std::lround(y * 4)));
      }
      cv::fillConvexPoly(chart, corners, cv::Scalar(26), cv::LINE_AA, 2);
    }
  cv::Mat f;
  chart.convertTo(f, CV_32F, 4000.0 / 255.0);
  cv::GaussianBlur(f, f, cv::Size(0, 0), 1.0);
  cv::Mat noise(f.size(), CV_32F);
  cv::randn(noise, 0, 16);
  f += noise;
  cv::Mat out;
  f.convertTo(out, CV_16U);
  return out;
}

void time_12mp_frame(int threads) {
  cv::setNumThreads(threads);
  const cv::Mat frame = chart_12mp();
  SfrImageOptions o;
  std::vector<double> seconds;
  size_t edges = 0, measured = 0;
  std::map<std::string, int> left_out;  // status and message: count
  for (int run = 0; run < 5; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto r = analyze_sfr(frame, "chart_12mp", o);
    seconds.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    if (!r.ok()) {
      std::printf("12 MP chart: %s\n", r.error().message.c_str());
      return;
    }
    edges = r->report["edges"].size();
    measured = 0;
    left_out.clear();
    for (const auto& e : r->report["edges"]) {
      measured += e["status"] == "ok";
      if (e["status"] != "ok")
        ++left_out[e["status"].get<std::string>() + ": " + e.value("message", std::string())];
    }
  }
  std::printf(
      "\n12 MP chart (4000 x 3000, 9 x 7 squares, 252 sides): %zu edges found, %zu measured, "
      "%.3f s a frame (median of 5, %d OpenCV threads)\n",
      edges, measured, median(seconds), threads);
  for (const auto& [why, count] : left_out) std::printf("  left out %d: %s\n", count, why.c_str());
}

int main(int argc, char** argv) {
  const int threads = argc > 1 ? std::max(1, std::atoi(argv[1])) : 2;
  cv::setNumThreads(1);
  std::printf(
      "| sigma (px) | true MTF50 (cy/px) | edge length (px) | half width (px) | time per edge "
      "(ms) | MTF50 bias | MTF50 sd | worst |\n|---|---|---|---|---|---|---|---|\n");
  for (double sigma : {0.6, 1.1})
    for (double half_length : {25.0, 50.0, 70.0})
      for (double half_width : {12.0, 24.0, 48.0}) {
        const Optics optics{false, sigma};
        const double truth = true_mtf50(optics, 5.0);
        const double a = 5.0 * kPi / 180, c = 0.5 * (kSize - 1);
        const EdgeSegment edge{"edge",
                               c - half_length * std::sin(a) - 4 * std::sin(a),
                               c - (half_length + 4) * std::cos(a),
                               c + (half_length + 4) * std::sin(a),
                               c + (half_length + 4) * std::cos(a),
                               0};
        SfrOptions o;
        o.half_width_px = half_width;
        std::vector<double> ms, errors;
        for (unsigned seed = 1; seed <= 24; ++seed) {
          const cv::Mat image = draw_edge(optics, 5.0, false, seed, 50);
          const auto t0 = std::chrono::steady_clock::now();
          const auto r = slanted_edge_sfr(image, edge, o);
          ms.push_back(
              std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                  .count());
          if (r.ok() && r->status == "ok" && r->mtf50_cy_px)
            errors.push_back(*r->mtf50_cy_px / truth - 1);
        }
        double mean = 0, var = 0, worst = 0;
        for (double e : errors) mean += e / errors.size();
        for (double e : errors) {
          var += (e - mean) * (e - mean) / std::max<size_t>(1, errors.size() - 1);
          worst = std::max(worst, std::fabs(e));
        }
        std::printf(
            "| %.1f | %.4f | %.0f | %.0f | %.3f | %+.2f%% | %.2f%% | %.2f%% (%zu of 24 measured) "
            "|\n",
            sigma, truth, 2 * half_length, half_width, median(ms), 100 * mean, 100 * std::sqrt(var),
            100 * worst, errors.size());
      }
  time_12mp_frame(threads);
  return 0;
}
