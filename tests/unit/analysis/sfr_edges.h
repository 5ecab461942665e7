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
#include <vector>

#include <opencv2/core.hpp>

#include "analysis/edge/edge_measure.h"

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

// A dark square of side `side_px` turned `angle_deg` about the centre of a `canvas_px`
// image, through a Gaussian blur of sigma `optics.size_px` (only a Gaussian: its blur of a
// square is exact as a product, the square's coverage along each of its axes), 8 x 8
// samples a pixel, noise at contrast-to-noise `cnr`. Returns the image; `corners` gets the
// square's corners in order (image px), so that corners k and k + 1 bound one side.
inline cv::Mat draw_square(const Optics& optics, double angle_deg, double side_px, int canvas_px,
                           unsigned seed, double cnr, std::vector<cv::Point2d>* corners) {
  const double a = angle_deg * kPi / 180, c = 0.5 * (canvas_px - 1) + 0.31, h = 0.5 * side_px;
  const double ux = std::cos(a), uy = std::sin(a), vx = -std::sin(a), vy = std::cos(a);
  auto inside = [&](double t) {  // the blurred coverage of [-h, h] at t along one axis
    return 0.5 * (std::erf((t + h) / (std::sqrt(2.0) * optics.size_px)) -
                  std::erf((t - h) / (std::sqrt(2.0) * optics.size_px)));
  };
  cv::Mat image(canvas_px, canvas_px, CV_32F);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, cnr > 0 ? 800.0 / cnr : 1e-12);
  for (int y = 0; y < canvas_px; ++y)
    for (int x = 0; x < canvas_px; ++x) {
      double sum = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx) {
          const double px = x - 0.5 + (sx + 0.5) / kSub - c, py = y - 0.5 + (sy + 0.5) / kSub - c;
          sum += inside(px * ux + py * uy) * inside(px * vx + py * vy);
        }
      image.at<float>(y, x) = static_cast<float>(1000 - 800 * sum / (kSub * kSub) + noise(rng));
    }
  if (corners) {
    corners->clear();
    for (const auto& [su, sv] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}})
      corners->push_back({c + h * (su * ux + sv * vx), c + h * (su * uy + sv * vy)});
  }
  return image;
}

// The edge set the accuracy figures are quoted on (docs/analysis.md): Gaussian sigma
// 0.45-1.6 px and disks 1.5-5 px, each at 5 angles off the columns and off the rows: 90.
struct TestEdge {
  Optics optics;
  double angle_deg = 0;
  bool turned = false;
};
// `angles`: the steeper set {24, 26, 26.5, 27, 30} puts the pixel centres near a half-pixel
// lattice across the edge (tan 26.57 deg = 1/2), where the ESF's bins fill unevenly.
inline std::vector<TestEdge> test_edges(const std::vector<double>& angles = {2.5, 5.0, 8.0, 12.0,
                                                                             20.0}) {
  std::vector<TestEdge> edges;
  for (bool disk : {false, true})
    for (double size : disk ? std::vector<double>{1.5, 2.5, 3.5, 5.0}
                            : std::vector<double>{0.45, 0.6, 0.8, 1.1, 1.6})
      for (double angle : angles)
        for (bool turned : {false, true}) edges.push_back({Optics{disk, size}, angle, turned});
  return edges;
}

// Sharp edges, for the top of the range: Gaussian sigma 0.1-0.35 px, MTF50 0.41-0.59
// cycles/px (the pixel's own area nearly all of it), at the same 5 angles: 40.
inline std::vector<TestEdge> sharp_edges() {
  std::vector<TestEdge> edges;
  for (double size : {0.1, 0.2, 0.3, 0.35})
    for (double angle : {2.5, 5.0, 8.0, 12.0, 20.0})
      for (bool turned : {false, true}) edges.push_back({Optics{false, size}, angle, turned});
  return edges;
}

// The segment measured on draw_edge()'s image: 120 px of the edge about the centre (or
// `half_length_px` each side).
inline EdgeSegment centre_segment(double angle_deg, bool turned, double half_length_px = 60) {
  const double a = angle_deg * kPi / 180, c = 0.5 * (kSize - 1), h = half_length_px;
  double ux = std::sin(a), uy = std::cos(a);  // along the edge
  if (turned) std::swap(ux, uy);
  return {"edge", c - h * ux, c - h * uy, c + h * ux, c + h * uy, 0};
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
