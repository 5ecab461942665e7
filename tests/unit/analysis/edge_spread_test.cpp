// Tests of the pillbox edge model and the slanted-edge blur fit against truths computed
// independently of the code under test:
//  - the disk's ESF by numerically integrating its chord lengths;
//  - a pixel's value by supersampling its area (64 x 64 points), each point taking the
//    light fraction of the blur disk from the circular-segment area formula (acos form,
//    a different derivation from the library's asin form);
//  - an unblurred pixel by clipping the unit square with the edge line (exact polygon
//    area);
//  - at 0 and 45 degrees, fine 1D quadrature against the pixel's box / triangle profile.
// Fits run on images rendered that way (fixed seeds for the noise).
//
// Measured (RelWithDebInfo; set CAMLAB_EDGE_REPORT=1 to print the tables):
//   noise-free: |D - truth| <= 3e-4 px for D = 0.5..30 at 0, 5, 30, 45 degrees (not
//   D = 0.5 at exactly 0 degrees, which the pixels cannot resolve: sigma is infinite);
//   contrast-to-noise 50, 30 seeds, windows D/2 + 8 wide and max(60, 5 D) long:
//   |bias| <= 0.014 px, spread 0.011-0.043 px for D = 1..30 (reported sigma within 25%).
#include "analysis/edge/edge_spread.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <map>
#include <numbers>
#include <random>
#include <utility>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

namespace camlab::analysis {
namespace {

constexpr double kPi = std::numbers::pi;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

double deg(double angle_deg) { return angle_deg * kPi / 180.0; }

// ---- Independent truths -----------------------------------------------------------------

// Fraction of a disk of radius R whose centre lies at signed distance h from the edge
// that is on the light side (h > 0): one minus / plus the circular segment cut off by the
// chord at distance |h|, area R^2 acos(|h|/R) - |h| sqrt(R^2 - h^2).
double disk_light_fraction(double h, double radius) {
  if (radius == 0.0) return h > 0 ? 1.0 : (h < 0 ? 0.0 : 0.5);
  if (h >= radius) return 1.0;
  if (h <= -radius) return 0.0;
  const double ah = std::fabs(h);
  const double segment =
      radius * radius * std::acos(ah / radius) - ah * std::sqrt(radius * radius - h * h);
  const double dark_side = segment / (kPi * radius * radius);
  return h >= 0 ? 1.0 - dark_side : dark_side;
}

// The ESF as the disk area left of x, summing chord lengths 2 sqrt(R^2 - t^2) by the
// midpoint rule.
double esf_by_chords(double x, double radius) {
  if (x <= -radius) return 0.0;
  const double top = std::min(x, radius);
  const int n = 200000;
  const double h = (top + radius) / n;
  double area = 0;
  for (int i = 0; i < n; ++i) {
    const double t = -radius + (i + 0.5) * h;
    area += 2.0 * std::sqrt(std::max(0.0, radius * radius - t * t)) * h;
  }
  return area / (kPi * radius * radius);
}

// Supersampled pixel value: n x n points over the unit square around a centre at signed
// distance d from the edge of normal (nx, ny).
double supersampled_pixel(double d, double diameter, double nx, double ny, int n) {
  double sum = 0;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      const double sx = (i + 0.5) / n - 0.5, sy = (j + 0.5) / n - 0.5;
      sum += disk_light_fraction(d + nx * sx + ny * sy, 0.5 * diameter);
    }
  }
  return sum / (n * n);
}

// Area of the unit square around the origin where (p . n) + d > 0: Sutherland-Hodgman
// clipping of the square by a half-plane, then the shoelace formula.
double clipped_square_area(double d, double nx, double ny) {
  const std::vector<std::pair<double, double>> square = {
      {-0.5, -0.5}, {0.5, -0.5}, {0.5, 0.5}, {-0.5, 0.5}};
  std::vector<std::pair<double, double>> poly;
  for (size_t i = 0; i < square.size(); ++i) {
    const auto [ax, ay] = square[i];
    const auto [bx, by] = square[(i + 1) % square.size()];
    const double fa = ax * nx + ay * ny + d, fb = bx * nx + by * ny + d;
    if (fa >= 0) poly.push_back({ax, ay});
    if ((fa >= 0) != (fb >= 0)) {
      const double t = fa / (fa - fb);
      poly.push_back({ax + t * (bx - ax), ay + t * (by - ay)});
    }
  }
  double twice_area = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const auto [ax, ay] = poly[i];
    const auto [bx, by] = poly[(i + 1) % poly.size()];
    twice_area += ax * by - bx * ay;
  }
  return 0.5 * std::fabs(twice_area);
}

// Pixel value at 0 degrees (the square projects to a box of width 1) or 45 degrees (a
// triangle of base sqrt 2): quadrature of the disk's light fraction weighted by that
// profile, split at every kink, each piece by the midpoint rule in theta on
// t = (1 - cos theta) / 2, which crowds the points towards the kinks.
double profile_quadrature(double d, double diameter, bool triangle) {
  const double half = triangle ? std::sqrt(0.5) : 0.5;
  const double radius = 0.5 * diameter;
  std::vector<double> cuts = {-half, half, 0.0, -radius - d, radius - d};
  std::sort(cuts.begin(), cuts.end());
  double sum = 0;
  for (size_t k = 0; k + 1 < cuts.size(); ++k) {
    const double lo = std::max(cuts[k], -half), hi = std::min(cuts[k + 1], half);
    if (hi <= lo) continue;
    const int n = 20000;
    for (int i = 0; i < n; ++i) {
      const double theta = kPi * (i + 0.5) / n;
      const double t = lo + (hi - lo) * 0.5 * (1.0 - std::cos(theta));
      const double dt = (hi - lo) * 0.5 * std::sin(theta) * kPi / n;
      const double weight = triangle ? (half - std::fabs(t)) / (half * half) : 1.0;
      sum += weight * disk_light_fraction(d + t, radius) * dt;
    }
  }
  return sum;
}

// ---- Rendered edges ---------------------------------------------------------------------

const std::vector<double> kAngles_deg = {0.0, 5.0, 30.0, 45.0};
const std::vector<double> kDiameters_px = {0.5, 1.0, 2.0, 5.0, 10.0, 20.0, 30.0};
constexpr double kDark = 0.2, kLight = 0.8;

// Windows: 8 px of flat level beyond the blur on each side, and an edge at least 120 px
// or 10 diameters long. The spread of D grows with D and falls as 1/sqrt(length): at
// contrast-to-noise 50 a 120 px window gives 0.056 px at D = 30, a 300 px one 0.035.
double half_width_for(double diameter) { return 0.5 * diameter + 8.0; }
double half_length_for(double diameter) { return std::max(60.0, 5.0 * diameter); }

// A slanted edge in a CV_32F image just large enough for its fit window: dark 0.2, light
// 0.8, through a point just off the centre at `angle_rad`. Pixels the blur and the pixel
// footprint cannot reach are exactly dark or light; the others are supersampled.
struct Scene {
  cv::Mat image;
  EdgeLine truth;
};

Scene render_scene(double diameter, double angle_rad, int supersampling) {
  const double hw = half_width_for(diameter);
  const double c = std::fabs(std::cos(angle_rad)), s = std::fabs(std::sin(angle_rad));
  const int half_cols = static_cast<int>(std::ceil(half_length_for(diameter) * c + hw * s + 5));
  const int half_rows = static_cast<int>(std::ceil(half_length_for(diameter) * s + hw * c + 5));
  Scene scene;
  scene.image.create(2 * half_rows + 1, 2 * half_cols + 1, CV_32F);
  scene.truth = {half_cols + 0.3, half_rows + 0.17, angle_rad};
  const double nx = -std::sin(angle_rad), ny = std::cos(angle_rad);
  const double reach = 0.5 * diameter + 0.75;  // disk radius + half the pixel diagonal
  for (int row = 0; row < scene.image.rows; ++row) {
    for (int col = 0; col < scene.image.cols; ++col) {
      const double d = (col - scene.truth.x_px) * nx + (row - scene.truth.y_px) * ny;
      const double p = d >= reach    ? 1.0
                       : d <= -reach ? 0.0
                                     : supersampled_pixel(d, diameter, nx, ny, supersampling);
      scene.image.at<float>(row, col) = static_cast<float>(kDark + (kLight - kDark) * p);
    }
  }
  return scene;
}

// Rendered once per test program: the fit tests share them.
const Scene& scene_for(double diameter, double angle_deg) {
  static std::map<std::pair<double, double>, Scene> cache;
  auto it = cache.find({diameter, angle_deg});
  if (it == cache.end()) {
    // 64 x 64 where the profile is steep; 32 x 32 suffices (and halves the render time)
    // once the blur spans several pixels: the sampling error scales as 1 / (n D)^2.
    const int n = diameter < 5.0 ? 64 : 32;
    it =
        cache
            .emplace(std::make_pair(diameter, angle_deg), render_scene(diameter, deg(angle_deg), n))
            .first;
  }
  return it->second;
}

// The guess a user would give: 0.4 px across and 3 px along from a point of the true
// edge, 0.3 degrees off in angle.
EdgeLine perturbed_guess(const EdgeLine& truth) {
  const double nx = -std::sin(truth.angle_rad), ny = std::cos(truth.angle_rad);
  return {truth.x_px + 0.4 * nx + 3.0 * ny, truth.y_px + 0.4 * ny - 3.0 * nx,
          truth.angle_rad + deg(0.3)};
}

EdgeFitOptions options_for(double diameter) {
  return {half_length_for(diameter), half_width_for(diameter), true};
}

bool report() { return std::getenv("CAMLAB_EDGE_REPORT") != nullptr; }

// Signed distance of a point from a line.
double distance_to(const EdgeLine& line, double x, double y) {
  return (x - line.x_px) * -std::sin(line.angle_rad) + (y - line.y_px) * std::cos(line.angle_rad);
}

// ---- The profile ------------------------------------------------------------------------

TEST(PillboxEsf, MatchesChordIntegralOfTheDisk) {
  for (const double diameter : {0.5, 1.0, 7.0, 30.0}) {
    const double radius = 0.5 * diameter;
    for (double u = -1.1; u <= 1.1; u += 0.0731) {
      EXPECT_NEAR(pillbox_esf(u * radius, diameter), esf_by_chords(u * radius, radius), 1e-7)
          << "D " << diameter << " u " << u;
    }
  }
}

TEST(PillboxEsf, StepLimitSymmetryAndMonotony) {
  EXPECT_EQ(pillbox_esf(-1e-12, 0.0), 0.0);
  EXPECT_EQ(pillbox_esf(0.0, 0.0), 0.5);
  EXPECT_EQ(pillbox_esf(1e-12, 0.0), 1.0);
  for (const double diameter : {1e-9, 0.5, 3.0, 30.0}) {
    const double radius = 0.5 * diameter;
    EXPECT_EQ(pillbox_esf(-radius, diameter), 0.0);
    EXPECT_EQ(pillbox_esf(radius, diameter), 1.0);
    EXPECT_DOUBLE_EQ(pillbox_esf(0.0, diameter), 0.5);
    double previous = 0;
    for (double u = -1.05; u <= 1.05; u += 0.01) {
      const double v = pillbox_esf(u * radius, diameter);
      EXPECT_NEAR(v + pillbox_esf(-u * radius, diameter), 1.0, 1e-14);
      EXPECT_GE(v, previous);
      previous = v;
    }
  }
}

TEST(PillboxEsfPixel, MatchesSupersampledDiskAreas) {
  double worst = 0;
  for (const double angle_deg : {0.0, 5.0, 30.0, 45.0, 63.0, 90.0, 160.0}) {
    const double nx = -std::sin(deg(angle_deg)), ny = std::cos(deg(angle_deg));
    for (const double diameter : kDiameters_px) {
      for (double d = -0.5 * diameter - 1.0; d <= 0.5 * diameter + 1.0; d += 0.377) {
        const double truth = supersampled_pixel(d, diameter, nx, ny, 64);
        const double model = pillbox_esf_pixel(d, diameter, nx, ny);
        worst = std::max(worst, std::fabs(model - truth));
        ASSERT_NEAR(model, truth, 1e-4) << angle_deg << " deg, D " << diameter << ", d " << d;
      }
    }
  }
  if (report()) std::printf("pixel model vs 64x64 supersampling: worst %.2g\n", worst);
}

TEST(PillboxEsfPixel, UnblurredPixelIsTheClippedSquareArea) {
  for (const double angle_deg :
       {0.0, 1e-10, 1e-6, 3.0, 30.0, 45.0, 45.0 + 1e-9, 90.0, 135.0, 200.0, 301.0}) {
    const double nx = -std::sin(deg(angle_deg)), ny = std::cos(deg(angle_deg));
    for (double d = -1.0; d <= 1.0; d += 0.0137) {
      const double truth = clipped_square_area(d, nx, ny);
      EXPECT_NEAR(pillbox_esf_pixel(d, 0.0, nx, ny), truth, 1e-12) << angle_deg << " " << d;
      // A vanishing disk changes the value by at most its diameter (it moves mass that far).
      EXPECT_NEAR(pillbox_esf_pixel(d, 1e-12, nx, ny), truth, 1e-11);
      EXPECT_NEAR(pillbox_esf_pixel(d, 1e-7, nx, ny), truth, 1e-7);
    }
  }
}

// At exactly 0 and 45 degrees the closed form runs at its limits (the trapezoid collapses
// to a box; its top to a point); check them, and tiny D, to 1e-8 against fine quadrature
// (it agrees to 3e-12 with 400,000 points per piece).
TEST(PillboxEsfPixel, BoxAndTriangleLimitsMatchQuadrature) {
  for (const bool triangle : {false, true}) {
    const double angle = triangle ? deg(45.0) : 0.0;
    const double nx = -std::sin(angle), ny = std::cos(angle);
    for (const double diameter : {1e-6, 1e-3, 0.05, 0.5, 1.0, 1.4142, 3.0, 30.0}) {
      for (double d = -0.5 * diameter - 0.8; d <= 0.5 * diameter + 0.8; d += 0.0917) {
        EXPECT_NEAR(pillbox_esf_pixel(d, diameter, nx, ny),
                    profile_quadrature(d, diameter, triangle), 1e-8)
            << (triangle ? "45" : "0") << " deg, D " << diameter << ", d " << d;
      }
    }
  }
}

// Just off 0 and 45 degrees the general form takes over; the value must not jump.
TEST(PillboxEsfPixel, ContinuousAcrossTheSpecialAngles) {
  for (const double base_deg : {0.0, 45.0, 90.0}) {
    for (const double diameter : {1e-4, 0.5, 2.0, 30.0}) {
      for (const double delta_rad : {1e-12, 1e-9, 1e-7, 1e-5}) {
        const double a0 = deg(base_deg), a1 = a0 + delta_rad;
        for (double d = -0.5 * diameter - 1.0; d <= 0.5 * diameter + 1.0; d += 0.0531) {
          const double v0 = pillbox_esf_pixel(d, diameter, -std::sin(a0), std::cos(a0));
          const double v1 = pillbox_esf_pixel(d, diameter, -std::sin(a1), std::cos(a1));
          EXPECT_NEAR(v0, v1, 2.0 * delta_rad + 1e-12) << base_deg << " " << diameter;
        }
      }
    }
  }
}

TEST(PillboxEsfPixel, SymmetricAndNormalScaleFree) {
  for (const double diameter : {0.0, 0.7, 9.0}) {
    for (double d = -6.0; d <= 6.0; d += 0.173) {
      const double v = pillbox_esf_pixel(d, diameter, 0.3, -0.8);
      EXPECT_NEAR(v + pillbox_esf_pixel(-d, diameter, 0.3, -0.8), 1.0, 1e-12);
      EXPECT_NEAR(v, pillbox_esf_pixel(d, diameter, 3.0, -8.0), 1e-12);
    }
  }
}

TEST(PillboxEsfPixel, NeverNaN) {
  const double odd[] = {kNaN, kInf, -kInf, -1.0, 0.0, 1e-300, 1e300};
  for (const double d : odd) {
    for (const double diameter : odd) {
      for (const double n : odd) {
        for (const double v :
             {pillbox_esf(d, diameter), pillbox_esf_pixel(d, diameter, n, 1.0),
              pillbox_esf_pixel(d, diameter, 0.0, n), pillbox_esf_pixel(d, diameter, n, n)}) {
          ASSERT_TRUE(v >= 0.0 && v <= 1.0) << d << " " << diameter << " " << n << " -> " << v;
        }
      }
    }
  }
}

// ---- The fit ----------------------------------------------------------------------------

TEST(FitPillboxEdge, RecoversDiameterNoiseFree) {
  for (const double angle_deg : kAngles_deg) {
    for (const double diameter : kDiameters_px) {
      const Scene& scene = scene_for(diameter, angle_deg);
      const auto fit =
          fit_pillbox_edge(scene.image, perturbed_guess(scene.truth), options_for(diameter));
      ASSERT_TRUE(fit.ok()) << angle_deg << " deg, D " << diameter << ": " << fit.error().message;
      if (angle_deg == 0.0 && diameter < 1.0) {
        // Axis-aligned: every row is the same, and with this phase one row holds the whole
        // transition, so offset and D trade off along a valley. The fit must say so.
        EXPECT_TRUE(std::isinf(fit->diameter_sigma_px) ||
                    std::fabs(fit->diameter_px - diameter) <= 3.0 * fit->diameter_sigma_px);
        continue;
      }
      const double tolerance = std::max(0.02, 0.005 * diameter);
      EXPECT_NEAR(fit->diameter_px, diameter, tolerance) << angle_deg << " deg";
      // The fitted line: through the true edge, at the true angle (mod pi), light side on
      // the normal's side as rendered.
      EXPECT_NEAR(distance_to(scene.truth, fit->line.x_px, fit->line.y_px), 0.0, 2e-3);
      EXPECT_NEAR(std::remainder(fit->angle_rad - scene.truth.angle_rad, 2 * kPi), 0.0, 1e-4);
      EXPECT_NEAR(fit->dark_level, kDark, 1e-4);
      EXPECT_NEAR(fit->light_level, kLight, 1e-4);
      EXPECT_LT(fit->rms_residual, 1e-4);
      EXPECT_GT(fit->contrast_to_noise, 5e3);
      EXPECT_LT(fit->iterations, 60);
      EXPECT_GT(fit->samples, 1500);
      if (report()) {
        std::printf("noise-free %4.1f deg D %5.2f: error %+.1e px, sigma %.1e, %d iterations\n",
                    angle_deg, diameter, fit->diameter_px - diameter, fit->diameter_sigma_px,
                    fit->iterations);
      }
    }
  }
}

// A sharp edge (the exact clipped-square areas) fits to D = 0. Near 0 the model changes
// as D^2, so with noise D scatters over 0..0.15 px (and the linearised sigma means little).
TEST(FitPillboxEdge, SharpEdgeGivesZeroDiameter) {
  const double angle = deg(5.0);
  const double nx = -std::sin(angle), ny = std::cos(angle);
  cv::Mat image(61, 141, CV_32F);
  const EdgeLine truth{70.3, 30.17, angle};
  for (int row = 0; row < image.rows; ++row) {
    for (int col = 0; col < image.cols; ++col) {
      const double d = (col - truth.x_px) * nx + (row - truth.y_px) * ny;
      image.at<float>(row, col) =
          static_cast<float>(kDark + (kLight - kDark) * clipped_square_area(d, nx, ny));
    }
  }
  const auto fit = fit_pillbox_edge(image, perturbed_guess(truth), {60.0, 8.0});
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_LT(fit->diameter_px, 0.02);
  EXPECT_NEAR(distance_to(truth, fit->line.x_px, fit->line.y_px), 0.0, 1e-3);
  // With noise (contrast-to-noise 50).
  for (int seed = 0; seed < 10; ++seed) {
    cv::Mat noisy = image.clone();
    cv::RNG rng(seed);
    cv::Mat noise(image.size(), CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, (kLight - kDark) / 50.0);
    noisy += noise;
    const auto noisy_fit = fit_pillbox_edge(noisy, perturbed_guess(truth), {60.0, 8.0});
    ASSERT_TRUE(noisy_fit.ok()) << noisy_fit.error().message;
    EXPECT_LT(noisy_fit->diameter_px, 0.25);
    if (report()) {
      std::printf("sharp edge, seed %d: D %.3g sigma %.3g\n", seed, noisy_fit->diameter_px,
                  noisy_fit->diameter_sigma_px);
    }
  }
}

// Contrast-to-noise 50 (Gaussian noise of sigma 0.6 / 50 on the 0.6 step), 30 seeds.
TEST(FitPillboxEdge, RecoversDiameterWithNoise) {
  constexpr int kSeeds = 30;
  const double noise_sigma = (kLight - kDark) / 50.0;
  double total_s = 0;
  int fits = 0;
  for (const double angle_deg : kAngles_deg) {
    for (const double diameter : {1.0, 2.0, 5.0, 10.0, 20.0, 30.0}) {
      const Scene& scene = scene_for(diameter, angle_deg);
      std::vector<double> estimates, sigmas;
      for (int seed = 0; seed < kSeeds; ++seed) {
        std::mt19937_64 rng(1000 * seed + static_cast<int>(diameter * 10 + angle_deg));
        std::normal_distribution<float> noise(0.0f, static_cast<float>(noise_sigma));
        cv::Mat noisy = scene.image.clone();
        for (auto it = noisy.begin<float>(); it != noisy.end<float>(); ++it) *it += noise(rng);
        const auto start = std::chrono::steady_clock::now();
        const auto fit =
            fit_pillbox_edge(noisy, perturbed_guess(scene.truth), options_for(diameter));
        total_s += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
        ++fits;
        ASSERT_TRUE(fit.ok()) << fit.error().message;
        ASSERT_TRUE(std::isfinite(fit->diameter_sigma_px));
        EXPECT_NEAR(fit->contrast_to_noise, 50.0, 3.0);
        estimates.push_back(fit->diameter_px);
        sigmas.push_back(fit->diameter_sigma_px);
      }
      double mean = 0, mean_sigma = 0;
      for (int i = 0; i < kSeeds; ++i) mean += estimates[i] / kSeeds;
      for (int i = 0; i < kSeeds; ++i) mean_sigma += sigmas[i] / kSeeds;
      double var = 0;
      for (const double e : estimates) var += (e - mean) * (e - mean) / (kSeeds - 1);
      const double spread = std::sqrt(var), bias = mean - diameter;
      EXPECT_LE(std::fabs(bias), std::max(0.05, 0.01 * diameter))
          << angle_deg << " deg, D " << diameter;
      EXPECT_LE(spread, 0.05) << angle_deg << " deg, D " << diameter;
      // The Jacobian's 1-sigma must describe the real scatter (30 seeds: +-25% at 2 sigma).
      EXPECT_GT(mean_sigma, 0.6 * spread);
      EXPECT_LT(mean_sigma, 1.6 * spread);
      if (report()) {
        std::printf("CNR 50 %4.1f deg D %5.2f: bias %+.4f px, spread %.4f px, sigma %.4f px\n",
                    angle_deg, diameter, bias, spread, mean_sigma);
      }
    }
  }
  if (report()) std::printf("mean fit time %.2f ms\n", 1e3 * total_s / fits);
}

TEST(FitPillboxEdge, IntegerImagesGiveTheSameDiameter) {
  const double diameter = 5.0;
  const Scene& scene = scene_for(diameter, 30.0);
  // 8 bit: levels 40..220 DN (dark 0.2 -> 40); 16 bit: 13107..52428 DN.
  cv::Mat u8, u16, f64;
  scene.image.convertTo(u8, CV_8U, 300.0, -20.0);
  scene.image.convertTo(u16, CV_16U, 65535.0);
  scene.image.convertTo(f64, CV_64F);
  for (const cv::Mat* image : {&u8, &u16, &f64}) {
    const auto fit = fit_pillbox_edge(*image, perturbed_guess(scene.truth), options_for(diameter));
    ASSERT_TRUE(fit.ok()) << fit.error().message;
    // 8-bit rounding is noise of 0.29 DN on a 180 DN step (CNR ~600).
    EXPECT_NEAR(fit->diameter_px, diameter, image->depth() == CV_8U ? 0.01 : 0.002);
  }
}

TEST(FitPillboxEdge, GuessFromTheOtherSideAndFixedAngle) {
  const double diameter = 10.0;
  const Scene& scene = scene_for(diameter, 5.0);
  EdgeLine flipped = perturbed_guess(scene.truth);
  flipped.angle_rad += kPi;  // normal towards the dark side: the fit turns it round
  const auto fit = fit_pillbox_edge(scene.image, flipped, options_for(diameter));
  ASSERT_TRUE(fit.ok()) << fit.error().message;
  EXPECT_NEAR(fit->diameter_px, diameter, 0.05);
  EXPECT_NEAR(std::remainder(fit->angle_rad - scene.truth.angle_rad, 2 * kPi), 0.0, 1e-4);
  EXPECT_LT(fit->dark_level, fit->light_level);

  EdgeFitOptions fixed = options_for(diameter);
  fixed.fit_angle = false;
  const auto fixed_fit = fit_pillbox_edge(scene.image, scene.truth, fixed);
  ASSERT_TRUE(fixed_fit.ok()) << fixed_fit.error().message;
  EXPECT_NEAR(fixed_fit->diameter_px, diameter, 0.05);
  EXPECT_EQ(fixed_fit->angle_rad, scene.truth.angle_rad);
}

TEST(FitPillboxEdge, RejectsImagesWithoutAnEdge) {
  const EdgeLine guess{80.0, 50.0, deg(10.0)};
  const EdgeFitOptions options{40.0, 10.0, true};
  cv::Mat flat(100, 160, CV_8U, cv::Scalar(255));  // saturated, constant
  cv::Mat noise(100, 160, CV_32F);
  cv::randn(noise, 0.5, 0.01);  // cv::theRNG's fixed default seed
  for (const cv::Mat* image : {&flat, &noise}) {
    const auto fit = fit_pillbox_edge(*image, guess, options);
    ASSERT_FALSE(fit.ok());
    EXPECT_EQ(fit.error().code, kErrNoContrast) << fit.error().message;
  }
}

TEST(FitPillboxEdge, RejectsWindowOffTheImage) {
  const Scene& scene = scene_for(2.0, 30.0);
  EdgeLine shifted = scene.truth;
  shifted.x_px += 20.0;
  const auto fit = fit_pillbox_edge(scene.image, shifted, options_for(2.0));
  ASSERT_FALSE(fit.ok());
  EXPECT_EQ(fit.error().code, kErrWindowOutsideImage) << fit.error().message;
}

TEST(FitPillboxEdge, RejectsAWindowNarrowerThanTheBlur) {
  const Scene& scene = scene_for(20.0, 5.0);
  for (const double half_width : {6.0, 9.0, 11.0}) {  // D/2 + 2 = 12 is needed
    const auto fit = fit_pillbox_edge(scene.image, scene.truth, {80.0, half_width});
    ASSERT_FALSE(fit.ok()) << half_width;
    EXPECT_EQ(fit.error().code, kErrWindowTooSmall) << fit.error().message;
    EXPECT_NE(fit.error().message.find("need >="), std::string::npos) << fit.error().message;
  }
}

TEST(FitPillboxEdge, RejectsInvalidArgumentsAndTinyWindows) {
  const Scene& scene = scene_for(2.0, 0.0);
  const EdgeLine good = scene.truth;
  const auto code = [](const Result<EdgeFit>& r) {
    return r.ok() ? std::string_view("ok") : name_of(r.error().code);
  };
  EXPECT_EQ(code(fit_pillbox_edge(cv::Mat(), good, options_for(2.0))), kErrInvalidArgument);
  EXPECT_EQ(code(fit_pillbox_edge(cv::Mat(50, 50, CV_8UC3), good, options_for(2.0))),
            kErrInvalidArgument);
  EXPECT_EQ(code(fit_pillbox_edge(cv::Mat(50, 50, CV_32S), good, options_for(2.0))),
            kErrInvalidArgument);
  EXPECT_EQ(code(fit_pillbox_edge(scene.image, {kNaN, good.y_px, 0.0}, options_for(2.0))),
            kErrInvalidArgument);
  EXPECT_EQ(code(fit_pillbox_edge(scene.image, good, {60.0, kNaN})), kErrInvalidArgument);
  EXPECT_EQ(code(fit_pillbox_edge(scene.image, good, {-1.0, 8.0})), kErrInvalidArgument);
  EXPECT_EQ(code(fit_pillbox_edge(scene.image, good, {1.0, 4.0})), kErrTooFewPixels);
}

// Clipped levels, NaN pixels and a lone bright pixel give a finite answer or an error.
TEST(FitPillboxEdge, NeverReturnsNaN) {
  const double diameter = 5.0;
  const Scene& scene = scene_for(diameter, 30.0);
  cv::Mat clipped;  // light side at 330 DN, clipped to 255
  scene.image.convertTo(clipped, CV_8U, 500.0, -70.0);
  cv::Mat holes = scene.image.clone();
  for (int i = 0; i < holes.rows; i += 3) holes.at<float>(i, (7 * i) % holes.cols) = NAN;
  cv::Mat spike(scene.image.size(), CV_32F, cv::Scalar(0.0f));
  spike.at<float>(spike.rows / 2, spike.cols / 2) = 1.0f;
  for (const cv::Mat* image : {&clipped, &holes, &spike}) {
    const auto fit = fit_pillbox_edge(*image, perturbed_guess(scene.truth), options_for(diameter));
    if (!fit.ok()) continue;
    for (const double v :
         {fit->diameter_px, fit->diameter_sigma_px, fit->offset_px, fit->angle_rad, fit->dark_level,
          fit->light_level, fit->rms_residual, fit->contrast_to_noise, fit->line.x_px}) {
      EXPECT_FALSE(std::isnan(v));
    }
  }
  const auto with_holes =
      fit_pillbox_edge(holes, perturbed_guess(scene.truth), options_for(diameter));
  ASSERT_TRUE(with_holes.ok()) << with_holes.error().message;
  EXPECT_NEAR(with_holes->diameter_px, diameter, 0.01);
}

}  // namespace
}  // namespace camlab::analysis
