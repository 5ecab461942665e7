#include "mock_device/render/radiance_integrator.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <thread>

#include "mock_device/render/sampling.h"

namespace camlab::mock {

namespace {

// Reflectance in `channel` along one ray: the nearest target hit, else the background.
inline double trace(const std::vector<TargetSurface>& surfaces, double background,
                    const double o[3], const double d[3], int channel) {
  double nearest = 1e300, value = background;
  for (const auto& surface : surfaces) {
    double reflectance;
    const double lambda = surface.intersect(o, d, channel, &reflectance);
    if (lambda > 0 && lambda < nearest) {
      nearest = lambda;
      value = reflectance;
    }
  }
  return value;
}

// The channel of each pixel of a 2x2 cell, indexed 2 (y & 1) + (x & 1).
std::array<int, 4> channels_of_cell(const IntegratorSetup& s) {
  std::array<int, 4> cell = {s.channel, s.channel, s.channel, s.channel};
  if (s.cfa.size() == 4)
    for (size_t i = 0; i < 4; ++i)
      cell[i] = s.cfa[i] == 'R' ? kRed : s.cfa[i] == 'G' ? kGreen : kBlue;
  return cell;
}

void integrate_rows(const IntegratorSetup& s, int first_row, int row_step, cv::Mat& out) {
  const ChiefRayTable& rays = *s.rays;
  const int width = rays.width_px(), height = rays.height_px();
  const std::array<int, 4> cell = channels_of_cell(s);
  int max_n = s.pixel_grid * s.pixel_grid;
  for (const ChannelSetup& c : s.channels) max_n = std::max(max_n, c.lens_grid * c.lens_grid);
  std::vector<int> strata(static_cast<size_t>(max_n));

  for (int y = first_row; y < height; y += row_step) {
    float* row = out.ptr<float>(y);
    for (int x = 0; x < width; ++x) {
      if (!rays.valid(x, y) || !rays.valid(x + 1, y) || !rays.valid(x, y + 1) ||
          !rays.valid(x + 1, y + 1)) {
        row[x] = 0.f;
        continue;
      }
      const int channel = cell[static_cast<size_t>(2 * (y & 1) + (x & 1))];
      const ChannelSetup& c = s.channels[static_cast<size_t>(channel)];
      const bool lens = c.lens_grid > 0;
      const int grid = lens ? c.lens_grid : s.pixel_grid;
      const int n = grid * grid;
      const double focus_m = c.focus_distance_m;
      const bool focus_at_infinity = !std::isfinite(focus_m);
      const double x00 = rays.xn(x, y), x10 = rays.xn(x + 1, y), x01 = rays.xn(x, y + 1),
                   x11 = rays.xn(x + 1, y + 1);
      const double y00 = rays.yn(x, y), y10 = rays.yn(x + 1, y), y01 = rays.yn(x, y + 1),
                   y11 = rays.yn(x + 1, y + 1);
      SplitMix64 rng(mix_seed(s.seed, static_cast<uint64_t>(y) * width + x));
      if (lens) {
        // Pair each lens stratum with a pixel-area stratum in a random order, so the two
        // are stratified on their own and uncorrelated with each other.
        std::iota(strata.begin(), strata.begin() + n, 0);
        for (int i = n - 1; i > 0; --i) std::swap(strata[i], strata[rng.next() % (i + 1)]);
      }
      double sum = 0;
      for (int k = 0; k < n; ++k) {
        const int area_stratum = lens ? strata[k] : k;
        const double a = ((area_stratum % grid) + rng.uniform()) / grid;
        const double b = ((area_stratum / grid) + rng.uniform()) / grid;
        const double xn = (1 - b) * ((1 - a) * x00 + a * x10) + b * ((1 - a) * x01 + a * x11);
        const double yn = (1 - b) * ((1 - a) * y00 + a * y10) + b * ((1 - a) * y01 + a * y11);
        double o[3] = {0, 0, 0};
        double d[3] = {xn, yn, 1.0};
        if (lens) {
          double lx, ly;
          concentric_disk(((k % grid) + rng.uniform()) / grid, ((k / grid) + rng.uniform()) / grid,
                          &lx, &ly);
          o[0] = lx * s.aperture_radius_m;
          o[1] = ly * s.aperture_radius_m;
          if (!focus_at_infinity && focus_m > 0) {
            // Towards the point x''' where the chief ray meets the plane of focus.
            d[0] = focus_m * xn - o[0];
            d[1] = focus_m * yn - o[1];
            d[2] = focus_m;
          } else if (!focus_at_infinity) {
            // Beyond infinity: per unit depth the ray leaves the chief ray's direction by
            // -o / s, as for a real plane of focus, but s < 0 makes the pixel's rays
            // diverge into the scene.
            d[0] = xn - o[0] / focus_m;
            d[1] = yn - o[1] / focus_m;
          }
        }
        sum += trace(*s.surfaces, c.background_reflectance, o, d, channel);
      }
      row[x] = static_cast<float>(sum / n);
    }
  }
}

}  // namespace

cv::Mat integrate_reflectance(const IntegratorSetup& setup) {
  cv::Mat out(setup.rays->height_px(), setup.rays->width_px(), CV_32F);
  const int threads = std::max(1, setup.threads);
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t)
    workers.emplace_back([&, t] { integrate_rows(setup, t, threads, out); });
  integrate_rows(setup, 0, threads, out);
  for (auto& w : workers) w.join();
  return out;
}

}  // namespace camlab::mock
