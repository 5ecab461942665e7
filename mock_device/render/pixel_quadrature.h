// How the renderer integrates one pixel by tracing rays: the random stratified estimate
// (lens and pixel-area strata paired at random, the reference every fast path is measured
// against), the fixed cubature rule for smooth patterns, and the ray from an aperture point.
// A pixel's positions are bilinear in its four corners' chief rays (chief_ray_table.h).
//
// Reentrant: reads only its arguments. Used by radiance_integrator.cpp.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <numbers>
#include <numeric>
#include <vector>

#include "mock_device/render/chief_ray_table.h"
#include "mock_device/render/gauss_legendre.h"
#include "mock_device/render/radiance_integrator.h"
#include "mock_device/render/sampling.h"
#include "mock_device/render/target_surface.h"

namespace camlab::mock {

inline bool pixel_valid(const ChiefRayTable& rays, int x, int y) {
  return rays.valid(x, y) && rays.valid(x + 1, y) && rays.valid(x, y + 1) &&
         rays.valid(x + 1, y + 1);
}

// One pixel's chief rays at its corners (00, 10, 01, 11) in normalised coordinates, times
// `scale` (a colour channel's ChannelSetup::ray_scale: lateral colour).
struct PixelCorners {
  double x[4], y[4];
  PixelCorners(const ChiefRayTable& rays, int px, int py, double scale = 1) {
    const int ix[4] = {px, px + 1, px, px + 1}, iy[4] = {py, py, py + 1, py + 1};
    for (int i = 0; i < 4; ++i) {
      x[i] = rays.xn(ix[i], iy[i]) * scale;
      y[i] = rays.yn(ix[i], iy[i]) * scale;
    }
  }
  // The chief ray at (a, b) inside the pixel, bilinear in the corners.
  void at(double a, double b, double* xn, double* yn) const {
    *xn = (1 - b) * ((1 - a) * x[0] + a * x[1]) + b * ((1 - a) * x[2] + a * x[3]);
    *yn = (1 - b) * ((1 - a) * y[0] + a * y[1]) + b * ((1 - a) * y[2] + a * y[3]);
  }
};

// The ray from aperture point (lx, ly) R (unit-disk coordinates; the lens centre without
// `lens`) through the point where the chief ray (xn, yn, 1) meets channel c's plane of
// focus: origin o, direction d.
inline void lens_ray(const IntegratorSetup& s, const ChannelSetup& c, double xn, double yn,
                     double lx, double ly, bool lens, double o[3], double d[3]) {
  o[0] = o[1] = o[2] = 0;
  d[0] = xn;
  d[1] = yn;
  d[2] = 1.0;
  if (!lens) return;
  const double focus_m = c.focus_distance_m;
  o[0] = lx * s.aperture_radius_m;
  o[1] = ly * s.aperture_radius_m;
  if (!std::isnan(c.inverse_focus_meridional_m)) {
    // Astigmatic: per unit depth the ray leaves the chief ray by -q o, q the meridional
    // plane's for the aperture's radial component (towards the chief ray's direction) and
    // the sagittal plane's for its tangential one: two focal lines, an elliptical blur.
    const double r = std::hypot(xn, yn);
    const double ex = r > 0 ? xn / r : 1, ey = r > 0 ? yn / r : 0;
    const double radial = o[0] * ex + o[1] * ey, tangential = -o[0] * ey + o[1] * ex;
    const double qm = c.inverse_focus_meridional_m, qs = c.inverse_focus_sagittal_m;
    d[0] = xn - qm * radial * ex + qs * tangential * ey;
    d[1] = yn - qm * radial * ey - qs * tangential * ex;
    return;
  }
  if (!std::isfinite(focus_m)) return;  // at infinity: parallel to the chief ray
  if (focus_m > 0) {
    // Towards the point where the chief ray meets the plane of focus.
    d[0] = focus_m * xn - o[0];
    d[1] = focus_m * yn - o[1];
    d[2] = focus_m;
  } else {
    // Beyond infinity: per unit depth the ray leaves the chief ray's direction by -o / s,
    // as for a real plane of focus, but s < 0 makes the pixel's rays diverge into the
    // scene.
    d[0] = xn - o[0] / focus_m;
    d[1] = yn - o[1] / focus_m;
  }
}

// One pixel's stratified estimate: k x k lens samples paired with as many pixel-area
// samples in a random order (unbiased, and the two are stratified on their own and
// uncorrelated), or m x m area samples without the lens (k = 0, m = area_grid).
// `trace(o, d)` gives the reflectance along a ray.
template <class Trace>
double sample_pixel(const IntegratorSetup& s, int x, int y, const ChannelSetup& c, int lens_grid,
                    int area_grid, int* strata, Trace&& trace) {
  const ChiefRayTable& rays = *s.rays;
  const PixelCorners corners(rays, x, y, c.ray_scale);
  const bool lens = lens_grid > 0;
  const int grid = lens ? lens_grid : area_grid;
  const int n = grid * grid;
  SplitMix64 rng(mix_seed(s.seed, static_cast<uint64_t>(y) * rays.width_px() + x));
  if (lens) {
    std::iota(strata, strata + n, 0);
    for (int i = n - 1; i > 0; --i) std::swap(strata[i], strata[rng.next() % (i + 1)]);
  }
  double sum = 0;
  for (int k = 0; k < n; ++k) {
    const int area_stratum = lens ? strata[k] : k;
    const double a = ((area_stratum % grid) + rng.uniform()) / grid;
    const double b = ((area_stratum / grid) + rng.uniform()) / grid;
    double xn, yn;
    corners.at(a, b, &xn, &yn);
    double lx = 0, ly = 0;
    if (lens)
      concentric_disk(((k % grid) + rng.uniform()) / grid, ((k / grid) + rng.uniform()) / grid, &lx,
                      &ly);
    double o[3], d[3];
    lens_ray(s, c, xn, yn, lx, ly, lens, o, d);
    sum += trace(o, d);
  }
  return sum / n;
}

// sample_pixel for each cell of a light field (IntegratorSetup::cells): grid x grid
// lens samples inside the cell, each paired with a pixel-area stratum in a random order,
// weighted so that the mean is the cell's (aperture_region.h); dst[k] is cell k's value.
template <class Trace>
void sample_pixel_cells(const IntegratorSetup& s, int x, int y, const ChannelSetup& c, int grid,
                        int* strata, Trace&& trace, float* dst) {
  const ChiefRayTable& rays = *s.rays;
  const PixelCorners corners(rays, x, y, c.ray_scale);
  const int n = grid * grid;
  SplitMix64 rng(mix_seed(s.seed, static_cast<uint64_t>(y) * rays.width_px() + x));
  const std::vector<ApertureRegion>& cells = *s.cells;
  for (size_t cell = 0; cell < cells.size(); ++cell) {
    std::iota(strata, strata + n, 0);
    for (int i = n - 1; i > 0; --i) std::swap(strata[i], strata[rng.next() % (i + 1)]);
    double sum = 0;
    for (int k = 0; k < n; ++k) {
      const double a = ((strata[k] % grid) + rng.uniform()) / grid;
      const double b = ((strata[k] / grid) + rng.uniform()) / grid;
      double lx, ly, weight;
      cells[cell].sample(((k % grid) + rng.uniform()) / grid, ((k / grid) + rng.uniform()) / grid,
                         &lx, &ly, &weight);
      if (weight == 0) continue;
      double xn, yn, o[3], d[3];
      corners.at(a, b, &xn, &yn);
      lens_ray(s, c, xn, yn, lx, ly, true, o, d);
      sum += weight * trace(o, d);
    }
    dst[cell] = static_cast<float>(sum / n);
  }
}

// Points and weights of a cubature rule on the unit disk: the centre alone (rings = 0), or
// `rings` rings at the Gauss-Legendre nodes of r^2 on [0, 1] with 4 rings equally spaced
// points each, every ring turned half a step from the one inside it. One ring is 4 points
// at 1/sqrt 2 on the axes, exact for polynomials of degree 3; each ring more resolves a
// pattern that changes faster across the disk.
inline constexpr int kMaxDiskRings = 4;
struct DiskRule {
  int n = 0;
  double x[4 * kMaxDiskRings * kMaxDiskRings], y[4 * kMaxDiskRings * kMaxDiskRings],
      w[4 * kMaxDiskRings * kMaxDiskRings];
};

inline const DiskRule& disk_rule(int rings) {
  static const std::array<DiskRule, kMaxDiskRings + 1> rules = [] {
    std::array<DiskRule, kMaxDiskRings + 1> out{};
    out[0].n = 1;
    out[0].x[0] = out[0].y[0] = 0;
    out[0].w[0] = 1;
    for (int rings = 1; rings <= kMaxDiskRings; ++rings) {
      DiskRule& r = out[static_cast<size_t>(rings)];
      const GaussRule& radial = kGauss[rings];
      const int per_ring = 4 * rings;
      for (int i = 0; i < rings; ++i)
        for (int j = 0; j < per_ring; ++j) {
          const double radius = std::sqrt(radial.x[i]);
          const double angle = 2 * std::numbers::pi * (j + 0.5 * (i % 2)) / per_ring;
          r.x[r.n] = radius * std::cos(angle);
          r.y[r.n] = radius * std::sin(angle);
          r.w[r.n] = radial.w[i] / per_ring;
          ++r.n;
        }
    }
    return out;
  }();
  return rules[static_cast<size_t>(std::clamp(rings, 0, kMaxDiskRings))];
}

// The integral over a pixel and an aperture rule: Gauss-Legendre points over the pixel's
// area times `count` weighted aperture points (`point(k, &x, &y, &w)`, unit disk). No
// randomness: for a smooth integrand its error falls far faster with the number of
// points than a random one's.
template <class Point, class Trace>
double rule_over_pixel(const IntegratorSetup& s, const PixelCorners& corners, const ChannelSetup& c,
                       const GaussRule& area, int count, bool lens, Point&& point, Trace&& trace) {
  double sum = 0;
  for (int j = 0; j < area.n; ++j)
    for (int i = 0; i < area.n; ++i) {
      double xn, yn;
      corners.at(area.x[i], area.x[j], &xn, &yn);
      double inner = 0;
      for (int k = 0; k < count; ++k) {
        double x, y, w, o[3], d[3];
        point(k, &x, &y, &w);
        lens_ray(s, c, xn, yn, x, y, lens, o, d);
        inner += w * trace(o, d);
      }
      sum += area.w[i] * area.w[j] * inner;
    }
  return sum;
}

// A pixel whose rays see one smooth pattern: the area rule times a disk rule.
template <class Trace>
double smooth_pixel(const IntegratorSetup& s, const PixelCorners& corners, const ChannelSetup& c,
                    const GaussRule& area, const DiskRule& disk, Trace&& trace) {
  return rule_over_pixel(
      s, corners, c, area, disk.n, disk.n > 1,
      [&](int k, double* x, double* y, double* w) {
        *x = disk.x[k];
        *y = disk.y[k];
        *w = disk.w[k];
      },
      trace);
}

// smooth_pixel for each cell of a light field: the area rule times the cell's own
// cubature rule of `order` (aperture_region.h); dst[k] is cell k's value.
template <class Trace>
void smooth_pixel_cells(const IntegratorSetup& s, const PixelCorners& corners,
                        const ChannelSetup& c, const GaussRule& area, int order, Trace&& trace,
                        float* dst) {
  const std::vector<ApertureRegion>& cells = *s.cells;
  for (size_t cell = 0; cell < cells.size(); ++cell) {
    const std::vector<ApertureRegion::Point>& rule = cells[cell].rule(order);
    dst[cell] = static_cast<float>(rule_over_pixel(
        s, corners, c, area, static_cast<int>(rule.size()), true,
        [&](int k, double* x, double* y, double* w) {
          const ApertureRegion::Point& p = rule[static_cast<size_t>(k)];
          *x = p.x;
          *y = p.y;
          *w = p.w;
        },
        trace));
  }
}

// Reflectance in `channel` along one ray: the nearest hit among `surfaces[hits[i]]`
// (every surface when hits is null), else the background.
inline double trace_ray(const std::vector<TargetSurface>& surfaces, const int* hits, int hit_count,
                        double background, const double o[3], const double d[3], int channel) {
  double nearest = std::numeric_limits<double>::max(), value = background;
  const int count = hits ? hit_count : static_cast<int>(surfaces.size());
  for (int i = 0; i < count; ++i) {
    double reflectance;
    const double lambda =
        surfaces[static_cast<size_t>(hits ? hits[i] : i)].intersect(o, d, channel, &reflectance);
    if (lambda > 0 && lambda < nearest) {
      nearest = lambda;
      value = reflectance;
    }
  }
  return value;
}

}  // namespace camlab::mock
