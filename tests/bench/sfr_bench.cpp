// sfr_bench: the slanted-edge SFR's time per edge against its MTF50 error, over the ESF
// window's half width and the edge's length (docs/analysis.md, "SFR"). Edges from
// tests/unit/analysis/sfr_edges.h (analytic Gaussian ESF, 8 x 8 samples a pixel, 5 deg
// off the columns) at contrast-to-noise 50, 24 noise draws a row; time: median of the 24
// calls on one core.
//
//   sfr_bench
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <vector>

#include <opencv2/core.hpp>

#include "../unit/analysis/sfr_edges.h"
#include "analysis/sfr/slanted_edge_sfr.h"

namespace {

using namespace camlab::analysis;
using namespace camlab::analysis::sfr_edges;

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v.empty() ? 0.0 : v[v.size() / 2];
}

}  // namespace

int main() {
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
  return 0;
}
