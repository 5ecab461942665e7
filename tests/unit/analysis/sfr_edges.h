// Slanted edges drawn by a generator that shares nothing with the SFR code, and their
// MTF50 in closed form (sfr_test.cpp, analyze_cli_test.cpp): an analytic ESF (a
// Gaussian's or a disk's) sampled at 8 x 8 points per pixel and averaged, Gaussian noise
// at a contrast-to-noise ratio; the truth is the optics' MTF times the 8 x 8 average's
// response along the edge's normal.
#pragma once

#include <cmath>
#include <numbers>
#include <random>
#include <utility>

#include <opencv2/core.hpp>

namespace camlab::analysis::sfr_edges {

constexpr int kSize = 160, kSub = 8;
constexpr double kPi = std::numbers::pi;

struct Optics {
  bool disk = false;
  double size_px = 1;  // Gaussian sigma or disk diameter
  double esf(double d) const {
    if (!disk) return 0.5 * std::erfc(-d / (std::sqrt(2.0) * size_px));
    const double r = 0.5 * size_px;
    if (d >= r) return 1;
    if (d <= -r) return 0;
    return (r * r * std::acos(-d / r) + d * std::sqrt(r * r - d * d)) / (kPi * r * r);
  }
  double mtf(double f) const {
    if (!disk) return std::exp(-2 * kPi * kPi * size_px * size_px * f * f);
    const double x = kPi * size_px * f;
    return x < 1e-9 ? 1.0 : 2 * std::cyl_bessel_j(1.0, x) / x;
  }
};

inline double sample_average_response(double u) {
  return std::fabs(u) < 1e-12 ? 1.0 : std::sin(kPi * u) / (kSub * std::sin(kPi * u / kSub));
}

// The edge through the image's centre, `angle_deg` off the pixel columns (`turned`: off
// the rows), dark (200) on one side, light (1000) on the other, noise at contrast-to-noise
// `cnr` (0: none).
inline cv::Mat draw_edge(const Optics& optics, double angle_deg, bool turned, unsigned seed,
                         double cnr = 50) {
  const double a = angle_deg * kPi / 180;
  // Unit normal of the edge: for an edge along the columns tilted by a, (cos a, -sin a).
  double nx = std::cos(a), ny = -std::sin(a);
  if (turned) std::swap(nx, ny);
  const double c = 0.5 * (kSize - 1) + 0.31;
  cv::Mat image(kSize, kSize, CV_32F);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, cnr > 0 ? 800.0 / cnr : 1e-12);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      double sum = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx) {
          const double px = x - 0.5 + (sx + 0.5) / kSub, py = y - 0.5 + (sy + 0.5) / kSub;
          sum += optics.esf((px - c) * nx + (py - c) * ny);
        }
      image.at<float>(y, x) = static_cast<float>(200 + 800 * sum / (kSub * kSub) + noise(rng));
    }
  return image;
}

inline double true_mtf50(const Optics& optics, double angle_deg) {
  const double a = angle_deg * kPi / 180;
  auto system = [&](double f) {
    return optics.mtf(f) * sample_average_response(f * std::cos(a)) *
           sample_average_response(f * std::sin(a));
  };
  double lo = 0, hi = 1;
  for (int k = 0; k < 60; ++k) (system(0.5 * (lo + hi)) > 0.5 ? lo : hi) = 0.5 * (lo + hi);
  return 0.5 * (lo + hi);
}

}  // namespace camlab::analysis::sfr_edges
