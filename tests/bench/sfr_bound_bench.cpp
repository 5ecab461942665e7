// sfr_bound_bench: how close the slanted-edge SFR's MTF50 comes, in noise, to the least
// scatter any unbiased estimator can have on the same pixels: the Cramer-Rao bound
// (docs/analysis.md, "SFR", "The noise floor").
//
// The edges are tests/unit/analysis/sfr_edges.h's (analytic Gaussian and disk ESFs, 8 x 8
// samples a pixel, 120 px of the edge measured). For each, the bound is that of an
// estimator told far more than camlab is told: that the blur is a Gaussian (or a disk) of
// unknown size, on an edge of unknown place, angle, dark and light level, in white
// Gaussian noise. Its Fisher information over the pixels of the measured strip (120 px
// along the edge, 24 px each side of it) gives the variance of the blur's log size; the
// MTF50's log changes with it by d ln MTF50 / d ln size (the pixel's own response does not
// scale), so sigma(MTF50)/MTF50 >= |d ln MTF50 / d ln size| x sqrt(I^-1)[size, size]. An
// estimator that does not know the blur's shape cannot do better than this one.
//
// Then camlab's own scatter over SEEDS noise draws of each edge, and for each set: the
// 95th percentile of |error| an efficient unbiased estimator would have (the bound's
// normal errors pooled over the set's edges), beside camlab's measured one.
//
//   sfr_bound_bench [SEEDS=24] [CNR=50] [HALF_LENGTH_PX=60]
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "../unit/analysis/sfr_edges.h"
#include "analysis/sfr/slanted_edge_sfr.h"

namespace {

using namespace camlab::analysis;
using namespace camlab::analysis::sfr_edges;

// draw_edge()'s noiseless image, with the edge's size, place along its normal and angle
// free, over the pixels within `half_length_px` along the edge and `half_width_px` across
// it of the image's centre, as coverage in [0, 1] (the image is 200 + 800 x coverage).
struct Strip {
  std::vector<cv::Point> pixels;
};

Strip strip_pixels(double angle_deg, bool turned, double half_length_px, double half_width_px) {
  const double a = angle_deg * kPi / 180, c = 0.5 * (kSize - 1) + 0.31;
  double nx = std::cos(a), ny = -std::sin(a);
  if (turned) std::swap(nx, ny);
  const double tx = -ny, ty = nx;
  Strip strip;
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x)
      if (std::fabs((x - c) * tx + (y - c) * ty) <= half_length_px &&
          std::fabs((x - c) * nx + (y - c) * ny) <= half_width_px)
        strip.pixels.push_back({x, y});
  return strip;
}

std::vector<double> coverage(const Strip& strip, Optics optics, double angle_deg, bool turned,
                             double shift_px) {
  const double a = angle_deg * kPi / 180, c = 0.5 * (kSize - 1) + 0.31;
  double nx = std::cos(a), ny = -std::sin(a);
  if (turned) std::swap(nx, ny);
  std::vector<double> values;
  values.reserve(strip.pixels.size());
  for (const cv::Point& p : strip.pixels) {
    double sum = 0;
    for (int sy = 0; sy < kSub; ++sy)
      for (int sx = 0; sx < kSub; ++sx) {
        const double px = p.x - 0.5 + (sx + 0.5) / kSub, py = p.y - 0.5 + (sy + 0.5) / kSub;
        sum += optics.esf((px - c) * nx + (py - c) * ny - shift_px);
      }
    values.push_back(sum / (kSub * kSub));
  }
  return values;
}

// The Cramer-Rao bound on sigma(MTF50) / MTF50 for one edge at noise sigma `noise_dn`.
double relative_mtf50_bound(const TestEdge& edge, const Strip& strip, double noise_dn) {
  const auto& [optics, angle, turned] = edge;
  constexpr double kStepLog = 1e-4, kStepPx = 1e-4, kStepDeg = 1e-3;
  auto scaled = [&](double log_step) {
    Optics o = optics;
    o.size_px *= std::exp(log_step);
    return o;
  };
  const auto centre = coverage(strip, optics, angle, turned, 0);
  const auto size_up = coverage(strip, scaled(kStepLog), angle, turned, 0);
  const auto size_down = coverage(strip, scaled(-kStepLog), angle, turned, 0);
  const auto shift_up = coverage(strip, optics, angle, turned, kStepPx);
  const auto shift_down = coverage(strip, optics, angle, turned, -kStepPx);
  const auto turn_up = coverage(strip, optics, angle + kStepDeg, turned, 0);
  const auto turn_down = coverage(strip, optics, angle - kStepDeg, turned, 0);
  // Parameters: log size, shift (px), angle (deg), dark level, light level (DN).
  cv::Matx<double, 5, 5> fisher = cv::Matx<double, 5, 5>::zeros();
  for (size_t i = 0; i < centre.size(); ++i) {
    const double contrast = 800;
    const cv::Vec<double, 5> gradient(contrast * (size_up[i] - size_down[i]) / (2 * kStepLog),
                                      contrast * (shift_up[i] - shift_down[i]) / (2 * kStepPx),
                                      contrast * (turn_up[i] - turn_down[i]) / (2 * kStepDeg),
                                      1 - centre[i], centre[i]);
    fisher += gradient * gradient.t();
  }
  fisher *= 1 / (noise_dn * noise_dn);
  const cv::Matx<double, 5, 5> covariance = fisher.inv(cv::DECOMP_SVD);
  const double mtf50_up = true_mtf50(scaled(kStepLog), angle);
  const double mtf50_down = true_mtf50(scaled(-kStepLog), angle);
  const double log_slope = (std::log(mtf50_up) - std::log(mtf50_down)) / (2 * kStepLog);
  return std::fabs(log_slope) * std::sqrt(covariance(0, 0));
}

// The 95th percentile of |e| when e is normal with one of `sigmas`, each as likely.
double pooled_p95(const std::vector<double>& sigmas) {
  auto inside = [&](double q) {
    double p = 0;
    for (double s : sigmas) p += std::erf(q / (std::sqrt(2.0) * s)) / sigmas.size();
    return p;
  };
  double lo = 0, hi = 1;
  for (int k = 0; k < 60; ++k) (inside(0.5 * (lo + hi)) < 0.95 ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(std::min<double>(v.size() - 1, std::ceil(p * v.size()) - 1))];
}

struct SetTally {
  std::vector<double> bound_sigmas, camlab_abs_errors, efficiency_ratios;
  std::vector<double> z_scores;  // error / stated standard error
};

}  // namespace

int main(int argc, char** argv) {
  const int seeds = argc > 1 ? std::clamp(std::atoi(argv[1]), 2, 1000) : 24;
  const double cnr = argc > 2 ? std::clamp(std::atof(argv[2]), 1.0, 1e6) : 50;
  const double half_length_px = argc > 3 ? std::clamp(std::atof(argv[3]), 10.0, 80.0) : 60;
  const double noise_dn = 800 / cnr;
  cv::setNumThreads(1);
  std::printf(
      "Cramer-Rao bound on MTF50 against camlab's scatter: %d noise draws an edge, "
      "contrast-to-noise %.0f, %.0f px of the edge\n\n",
      seeds, cnr, 2 * half_length_px);
  std::printf(
      "| optics | size px | angle deg | truth cy/px | bound sigma | camlab sigma | camlab's "
      "stated standard error, rms | camlab mean error | camlab / bound |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  SetTally near_quarter, all, sharp_set;
  unsigned seed = 1000;
  for (const bool sharp : {false, true})
    for (const TestEdge& edge : sharp ? sharp_edges() : test_edges()) {
      const auto& [optics, angle, turned] = edge;
      const Strip strip = strip_pixels(angle, turned, half_length_px, 24);
      const double truth = true_mtf50(optics, angle);
      const double bound = relative_mtf50_bound(edge, strip, noise_dn);
      std::vector<double> errors, stated, z_scores;
      for (int draw = 0; draw < seeds; ++draw) {
        const cv::Mat image = draw_edge(optics, angle, turned, seed++, cnr);
        const auto r = slanted_edge_sfr(image, centre_segment(angle, turned, half_length_px));
        if (r.ok() && r->status == "ok" && r->mtf50_cy_px) {
          errors.push_back(*r->mtf50_cy_px / truth - 1);
          if (r->mtf50_standard_error_cy_px) {
            stated.push_back(*r->mtf50_standard_error_cy_px / truth);
            z_scores.push_back(errors.back() / stated.back());
          }
        }
      }
      double mean = 0, square = 0;
      for (double e : errors) mean += e / errors.size();
      for (double e : errors) square += (e - mean) * (e - mean) / (errors.size() - 1);
      const double sigma = std::sqrt(square);
      double stated_rms = 0;
      for (double s : stated) stated_rms += s * s / stated.size();
      stated_rms = std::sqrt(stated_rms);
      std::printf("| %s | %.2f | %.1f%s | %.3f | %.2f%% | %.2f%% | %.2f%% | %+.2f%% | %.2f |\n",
                  optics.disk ? "disk" : "Gaussian", optics.size_px, angle, turned ? " (rows)" : "",
                  truth, 100 * bound, 100 * sigma, 100 * stated_rms, 100 * mean, sigma / bound);
      for (SetTally* set : std::vector<SetTally*>{sharp ? &sharp_set : &all})
        set->z_scores.insert(set->z_scores.end(), z_scores.begin(), z_scores.end());
      std::vector<SetTally*> sets{sharp ? &sharp_set : &all};
      if (!sharp && truth >= 0.2 && truth <= 0.3) sets.push_back(&near_quarter);
      for (SetTally* set : sets) {
        set->bound_sigmas.push_back(bound);
        set->efficiency_ratios.push_back(sigma / bound);
        for (double e : errors) set->camlab_abs_errors.push_back(std::fabs(e));
      }
      if (errors.size() < static_cast<size_t>(seeds))
        std::printf("  (%zu of %d draws not measured)\n", seeds - errors.size(), seeds);
    }
  std::printf(
      "\n| edges | count | p95 of abs(error), efficient estimator (bound) | camlab p95 | camlab "
      "worst | camlab sigma / bound, median (max) |\n|---|---|---|---|---|---|\n");
  for (const auto& [name, set] :
       {std::pair<const char*, const SetTally&>{"truth 0.2-0.3 cy/px", near_quarter},
        {"all 90", all},
        {"sharp 40 (0.41-0.59 cy/px)", sharp_set}})
    std::printf("| %s | %zu | %.2f%% | %.2f%% | %.2f%% | %.2f (%.2f) |\n", name,
                set.bound_sigmas.size(), 100 * pooled_p95(set.bound_sigmas),
                100 * percentile(set.camlab_abs_errors, 0.95),
                100 * percentile(set.camlab_abs_errors, 1.0),
                percentile(set.efficiency_ratios, 0.5), percentile(set.efficiency_ratios, 1.0));
  for (const auto& [name, set] :
       {std::pair<const char*, const SetTally&>{"all 90", all}, {"sharp 40", sharp_set}}) {
    double square = 0;
    int beyond_2 = 0;
    for (double z : set.z_scores)
      square += z * z / set.z_scores.size(), beyond_2 += std::fabs(z) > 2;
    std::printf("%s: error / stated standard error rms %.2f over %zu, beyond 2: %.1f%%\n", name,
                std::sqrt(square), set.z_scores.size(), 100.0 * beyond_2 / set.z_scores.size());
  }
  return 0;
}
