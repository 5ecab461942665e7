// The automatic rule's fast paths (radiance_integrator.h: flat patches, straight edges in
// closed form, the cubature rule for smooth patterns, local sample counts) against the
// thin-lens integral written out here, and against the uniform path with many samples
// (the slow exact path), within tolerances stated with each check.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "optics/optics.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace adaptive_render_test {

using nlohmann::json;

constexpr double kPi = std::numbers::pi;
constexpr double kFocalMm = 8.0, kPitchMm = 0.004, kFNumber = 2.0;
constexpr double kApertureRadiusM = kFocalMm / kFNumber / 2 * 1e-3;

// Share of a disk of radius rho on the positive side of a line at signed distance d from
// its centre: 1 - segment / pi (the segment area acos(u) - u sqrt(1 - u^2), u = |d| / rho).
double disk_share(double d, double rho) {
  if (rho <= 0) return d > 0 ? 1.0 : 0.0;
  const double u = d / rho;
  if (u >= 1) return 1;
  if (u <= -1) return 0;
  const double a = std::fabs(u);
  const double segment = (std::acos(a) - a * std::sqrt(1 - a * a)) / kPi;
  return u >= 0 ? 1 - segment : segment;
}

// The mean of disk_share over a square pixel whose centre is at signed distance d0 (px)
// from a straight edge with unit normal (cos a, -sin a): the distance over the pixel is
// d0 + cos a u - sin a v, u and v uniform on [-1/2, 1/2], whose density is a trapezoid;
// integrated with Simpson's rule on 20000 intervals.
double pixel_share(double d0, double angle_rad, double rho_px) {
  const double p = std::fabs(std::cos(angle_rad)), q = std::fabs(std::sin(angle_rad));
  const double wide = std::max(p, q), narrow = std::min(p, q);
  const double half = (wide + narrow) / 2;
  if (d0 - half >= rho_px) return 1;
  if (d0 + half <= -rho_px) return 0;
  auto density = [&](double t) {
    const double s = std::fabs(t);
    if (s >= half) return 0.0;
    if (narrow < 1e-12) return 1 / wide;
    if (s <= (wide - narrow) / 2) return 1 / wide;
    return (half - s) / (wide * narrow);
  };
  const int n = 20000;
  const double step = 2 * half / n;
  double sum = 0;
  for (int i = 0; i <= n; ++i) {
    const double t = -half + i * step;
    const double w = (i == 0 || i == n) ? 1 : (i % 2 ? 4 : 2);
    sum += w * density(t) * disk_share(d0 + t, rho_px);
  }
  return sum * step / 3;
}

json edge_scene(double distance_m, double x_m, double angle_deg) {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", 0.3},
          {"targets",
           {{{"type", "slanted_edge"},
             {"size_m", {2.0, 2.0}},
             {"angle_deg", angle_deg},
             {"dark_reflectance", 0.1},
             {"light_reflectance", 0.7},
             {"pose", {{"position_m", {x_m, 0.0, distance_m}}}}}}}};
}

cv::Mat integral(Renderer& renderer, const RenderSettings& settings, int aperture_samples,
                 uint64_t seed) {
  RenderOptions options;
  options.aperture_samples = aperture_samples;
  options.seed = seed;
  auto result = renderer.integrate_scene(settings, 0, options);
  if (!result) throw std::runtime_error(result.error().message);
  return result->reflectance;
}

// A fronto-parallel edge through a pinhole lens: each pixel's value written out from the
// thin lens (the aperture's image on the target is a disk of radius R |1 - z/s|, on the
// sensor rho = R |1/z - 1/s| fx) and compared with the automatic rule's render.
struct EdgeCase {
  const char* name;
  int focus_position;  // 1 um per step; 0 = infinity
  double distance_m;   // < 0: at the plane of focus exactly
  bool colour;
};

class StraightEdge : public ::testing::TestWithParam<EdgeCase> {};

TEST_P(StraightEdge, MatchesTheThinLensIntegralWrittenOut) {
  const EdgeCase& c = GetParam();
  const int width = 64, height = 48;
  const double angle_deg = 5.0, x_m = 0.0021;
  const double z_s_mm = kFocalMm + c.focus_position * 0.001;
  const double s_mm =
      c.focus_position == 0 ? INFINITY : *optics::focus_distance_mm(kFocalMm, z_s_mm);
  const double z_m = c.distance_m > 0 ? c.distance_m : s_mm * 1e-3;
  json camera = c.colour ? testing::colour_camera_json(width, height)
                         : testing::pinhole_camera_json(width, height);
  Renderer renderer = testing::make_renderer(camera, edge_scene(z_m, x_m, angle_deg));
  RenderSettings settings = renderer.default_settings();
  settings.f_number = kFNumber;
  settings.focus_position = c.focus_position;
  const cv::Mat image = integral(renderer, settings, -1, 7);

  const double fx = z_s_mm / kPitchMm, cx = (width - 1) / 2.0, cy = (height - 1) / 2.0;
  const double a = angle_deg * kPi / 180;
  const std::array<double, 3> shift_mm = {0.02, 0.0, -0.015};  // colour_camera_json's
  double worst = 0, blurred_px = 0;
  int on_edge = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      // Channel: grey, or RGGB's, each focused at its own s_c = 1 / (1/f_c - 1/z_s).
      double inverse_s = std::isfinite(s_mm) ? 1e3 / s_mm : 0.0;
      if (c.colour) {
        const int ch = (y % 2 == 0) ? (x % 2 == 0 ? 0 : 1) : (x % 2 == 0 ? 1 : 2);
        const double f_c = kFocalMm + shift_mm[static_cast<size_t>(ch)];
        inverse_s = (1 / f_c - 1 / z_s_mm) * 1e3;
      }
      const double rho_px = kApertureRadiusM * std::fabs(1 / z_m - inverse_s) * fx;
      // The edge u cos a - v sin a = 0 with u = X - x_m, v = Y at depth z: in pixels, the
      // signed distance of the pixel centre (light side positive).
      const double d0 =
          (x - cx) * std::cos(a) - (y - cy) * std::sin(a) - fx * x_m * std::cos(a) / z_m;
      const double want = 0.1 + 0.6 * pixel_share(d0, a, rho_px);
      const double got = image.at<float>(y, x);
      worst = std::max(worst, std::fabs(got - want));
      on_edge += want > 0.1 + 1e-6 && want < 0.7 - 1e-6;
      blurred_px = std::max(blurred_px, 2 * rho_px);
    }
  ASSERT_GT(on_edge, height) << "the edge must cross the frame";
  // The closed form approximates the distance to the edge as linear over a pixel within
  // 5e-4 of the contrast (0.6), and the image is float.
  EXPECT_LT(worst, 5e-4 * 0.6 + 1e-6) << c.name << ": blur " << blurred_px << " px";
}

INSTANTIATE_TEST_SUITE_P(
    FocusAndChannels, StraightEdge,
    ::testing::Values(EdgeCase{"at_infinity_8px", 0, 1.0, false},
                      EdgeCase{"blur_4px", 30, 1.0, false}, EdgeCase{"blur_1px", 56, 1.0, false},
                      EdgeCase{"blur_0p06px", 64, 1.0, false},
                      EdgeCase{"exactly_in_focus", 64, -1, false},
                      EdgeCase{"behind_focus", 160, 1.0, false},
                      EdgeCase{"colour_each_channel_its_focus", 56, 1.0, true}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(AdaptiveRender, ATargetsSideOverAFlatTargetBehindItIsItsOwnThinLensEdge) {
  // A uniform card (0.7) at 0.5 m whose right side crosses the frame, in front of a uniform
  // wall (0.2) at 2 m: on the card's side the rays that pass it reach the wall, so a pixel
  // is the wall plus the card's share of its aperture, the disk at the card's depth.
  const int width = 64, height = 48;
  json scene = {{"illuminance_lux", 1000},
                {"background_reflectance", 0.5},
                {"targets",
                 {{{"type", "uniform"},
                   {"size_m", {0.2, 1.0}},
                   {"light_reflectance", 0.7},
                   {"pose", {{"position_m", {-0.1 + 0.0003, 0.0, 0.5}}}}},
                  {{"type", "uniform"},
                   {"size_m", {10.0, 10.0}},
                   {"light_reflectance", 0.2},
                   {"pose", {{"position_m", {0.0, 0.0, 2.0}}}}}}}};
  Renderer renderer = testing::make_renderer(testing::pinhole_camera_json(width, height), scene);
  RenderSettings settings = renderer.default_settings();
  settings.f_number = kFNumber;
  settings.focus_position = 64;  // s = 1.008 m: the card 5.9 px out of focus
  const cv::Mat image = integral(renderer, settings, -1, 3);
  const double z_s_mm = kFocalMm + 0.064, fx = z_s_mm / kPitchMm, cx = (width - 1) / 2.0;
  const double inverse_s = 1e3 / *optics::focus_distance_mm(kFocalMm, z_s_mm);
  const double rho_px = kApertureRadiusM * std::fabs(1 / 0.5 - inverse_s) * fx;
  ASSERT_GT(2 * rho_px, 5.0);
  double worst = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      // The card covers X < 0.0003 m at 0.5 m: the positive (card) side is -(x - edge).
      const double d0 = -((x - cx) - fx * 0.0003 / 0.5);
      const double want = 0.2 + 0.5 * pixel_share(d0, 0.0, rho_px);
      worst = std::max(worst, std::fabs(image.at<float>(y, x) - want));
    }
  EXPECT_LT(worst, 5e-4 * 0.5 + 1e-6);
}

// Pixels where `reference` has structure (its 3x3 range above 0.5% of `contrast`).
cv::Mat structured(const cv::Mat& reference, double contrast) {
  cv::Mat hi, lo;
  cv::dilate(reference, hi, cv::Mat());
  cv::erode(reference, lo, cv::Mat());
  return (hi - lo) > 0.005 * contrast;
}

TEST(AdaptiveRender, AgreesWithManyUniformSamplesOnADistortedLensAndTiltedTargets) {
  // The example lens's distortion, tilted targets at several depths: an edge, bars, a
  // chessboard and a texture. The uniform path with 1024 samples per pixel is the
  // reference; its own error at an edge pixel is about 0.5% of the contrast, so the fast
  // paths must agree within that per pixel (RMS) and be unbiased (mean difference).
  json camera = testing::pinhole_camera_json(96, 72);
  camera["lens"]["model"] = "LENSMODEL_OPENCV4";
  camera["lens"]["distortion"] = {-0.05, 0.01, 0.0, 0.0};
  json scene = {
      {"illuminance_lux", 1000},
      {"background_reflectance", 0.18},
      {"targets",
       {{{"type", "slanted_edge"},
         {"size_m", {0.03, 0.03}},
         {"angle_deg", 8},
         {"dark_reflectance", 0.1},
         {"light_reflectance", 0.8},
         {"pose", {{"position_m", {-0.012, -0.005, 0.6}}, {"rotation_deg", {20, -15, 0}}}}},
        {{"type", "bars"},
         {"size_m", {0.02, 0.012}},
         {"bar_width_m", 0.002},
         {"bar_gap_m", 0.002},
         {"bar_count", 5},
         {"dark_reflectance", 0.1},
         {"light_reflectance", 0.8},
         {"pose", {{"position_m", {0.012, 0.008, 0.9}}}}},
        {{"type", "chessboard"},
         {"inner_corners", {4, 3}},
         {"square_m", 0.004},
         {"dark_reflectance", 0.05},
         {"light_reflectance", 0.85},
         {"pose", {{"position_m", {0.002, -0.016, 1.1}}, {"rotation_deg", {-25, 10, 5}}}}},
        {{"type", "texture"},
         {"size_m", {0.03, 0.02}},
         {"feature_m", 0.004},
         {"dark_reflectance", 0.1},
         {"light_reflectance", 0.8},
         {"pose", {{"position_m", {-0.015, 0.02, 1.3}}, {"rotation_deg", {30, 0, 0}}}}}}}};
  Renderer renderer = testing::make_renderer(camera, scene);
  RenderSettings settings = renderer.default_settings();
  settings.f_number = kFNumber;
  settings.focus_position = 60;  // s = 1.075 m: the targets 0 to 7 px out of focus
  RenderOptions options;
  auto fast = renderer.integrate_scene(settings, 0, options);
  ASSERT_TRUE(fast.ok()) << fast.error().message;
  EXPECT_GT(fast->stats.flat_share, 0.3);
  EXPECT_GT(fast->stats.edge_share, 0.02);
  EXPECT_GT(fast->stats.smooth_share + fast->stats.sampled_share, 0.01);
  EXPECT_NEAR(fast->stats.flat_share + fast->stats.edge_share + fast->stats.smooth_share +
                  fast->stats.sampled_share,
              1.0, 1e-9);
  const cv::Mat reference = integral(renderer, settings, 1024, 99);
  const cv::Mat mask = structured(reference, 0.7);
  ASSERT_GT(cv::countNonZero(mask), 500);
  auto rms_and_bias = [&](const cv::Mat& image) {
    cv::Mat diff = image - reference;
    return std::pair{std::sqrt(cv::mean(diff.mul(diff), mask)[0]) / 0.7,
                     cv::mean(diff, mask)[0] / 0.7};
  };
  const auto [rms, bias] = rms_and_bias(fast->reflectance);
  // The uniform rule of before: every pixel the count for the frame's largest blur.
  const auto [uniform_rms, uniform_bias] =
      rms_and_bias(integral(renderer, settings, fast->stats.aperture_samples, 5));
  EXPECT_LT(rms, uniform_rms) << "fast " << rms << ", " << fast->stats.aperture_samples
                              << " uniform samples " << uniform_rms;
  // Unbiased: the mean difference over ~2000 pixels is far below one pixel's error.
  EXPECT_LT(std::fabs(bias), 0.001);
}

// A textured plane through (0, 0, 0.8 m) turned `tilt_deg` about x, and the blur (px) of
// each pixel's centre: the chief ray's depth on the plane n . X = c is
// z = c / (n . (xn, yn, 1)), its CoC 2 R |1/z - 1/s| fx.
json tilted_texture(double tilt_deg, double feature_m) {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", 0.18},
          {"targets",
           {{{"type", "texture"},
             {"size_m", {1.0, 4.0}},
             {"feature_m", feature_m},
             {"seed", 5},
             {"dark_reflectance", 0.1},
             {"light_reflectance", 0.8},
             {"pose", {{"position_m", {0.0, 0.0, 0.8}}, {"rotation_deg", {tilt_deg, 0, 0}}}}}}}};
}

cv::Mat blur_px(int width, int height, double tilt_deg, const RenderSettings& settings) {
  const double z_s_mm = kFocalMm + settings.focus_position * 0.001, fx = z_s_mm / kPitchMm;
  const double inverse_s = 1e3 / *optics::focus_distance_mm(kFocalMm, z_s_mm);
  const double r = kFocalMm / settings.f_number / 2 * 1e-3;
  const double t = tilt_deg * kPi / 180;
  const double n[3] = {0, -std::sin(t), std::cos(t)}, c = n[2] * 0.8;
  cv::Mat coc(height, width, CV_64F);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const double xn = (x - (width - 1) / 2.0) / fx, yn = (y - (height - 1) / 2.0) / fx;
      const double z = c / (n[0] * xn + n[1] * yn + n[2]);
      coc.at<double>(y, x) = 2 * r * std::fabs(1 / z - inverse_s) * fx;
    }
  return coc;
}

TEST(AdaptiveRender, EachPixelOfATiltedTextureGetsWhatItsOwnBlurNeeds) {
  // Tilted 80 degrees and focused at 0.65 m, the plane's depth runs from 0.63 to 1.09 m
  // over the frame and its blur from 1 to 6 px. The uniform rule took the count of the
  // target's largest predicted blur everywhere; the automatic rule takes each pixel's own.
  // In each band of blur, its error against a 1024-sample reference must be no worse than
  // the uniform path with the count the rule gives at the band's smallest blur (plus the
  // reference's own noise): no pixel gets fewer samples than its blur needs.
  const int width = 128, height = 96;
  Renderer renderer = testing::make_renderer(testing::pinhole_camera_json(width, height),
                                             tilted_texture(-80, 0.004));
  RenderSettings settings = renderer.default_settings();
  settings.f_number = 1.4;
  settings.focus_position = 100;  // s = 0.648 m
  const cv::Mat coc = blur_px(width, height, -80, settings);
  double coc_min, coc_max;
  cv::minMaxLoc(coc, &coc_min, &coc_max);
  ASSERT_LT(coc_min, 2.0);
  ASSERT_GT(coc_max, 5.0);
  const cv::Mat reference = integral(renderer, settings, 1024, 101);
  const cv::Mat fast = integral(renderer, settings, -1, 1);
  auto band_rms = [&](const cv::Mat& image, double lo, double hi) {
    const cv::Mat mask = (coc >= lo) & (coc < hi);
    cv::Mat diff = image - reference;
    return std::sqrt(cv::mean(diff.mul(diff), mask)[0]) / 0.7;
  };
  for (auto [lo, hi] : {std::pair{1.0, 2.5}, std::pair{2.5, 4.0}, std::pair{4.0, 6.0}}) {
    const int grid = std::clamp(static_cast<int>(std::lround(4 + lo / 2.5)), 4, 16);
    const double uniform = band_rms(integral(renderer, settings, grid * grid, 3), lo, hi);
    const double adaptive = band_rms(fast, lo, hi);
    EXPECT_LT(adaptive, 1.15 * uniform + 2e-4)
        << "blur " << lo << "-" << hi << " px: " << adaptive << " vs " << grid * grid
        << " uniform samples " << uniform;
  }
}

TEST(AdaptiveRender, ASmoothTextureTakesTheCubatureRuleAndBeatsManyRandomSamples) {
  // Tilted 62 degrees, blurred less than 2 px: every pixel's footprint lies on one smooth
  // patch and takes fixed Gauss points. With 4 mm features (10 px at 0.8 m) and with
  // 1 mm ones (2.5 px: more points per pixel), against 1024 random samples, the rule must
  // err less than random samples with about four times as many points.
  const int width = 96, height = 72;
  for (double feature_m : {0.004, 0.001}) {
    Renderer renderer = testing::make_renderer(testing::pinhole_camera_json(width, height),
                                               tilted_texture(-62, feature_m));
    RenderSettings settings = renderer.default_settings();
    settings.f_number = 2.8;
    settings.focus_position = 80;  // s = 0.808 m
    double blur_max;
    cv::minMaxLoc(blur_px(width, height, -62, settings), nullptr, &blur_max);
    ASSERT_LT(blur_max, 2.0);
    RenderOptions options;
    auto fast = renderer.integrate_scene(settings, 0, options);
    ASSERT_TRUE(fast.ok());
    EXPECT_GT(fast->stats.smooth_share, 0.99);
    const double points = fast->stats.mean_samples_per_pixel;
    EXPECT_LE(points, 64.0);
    const cv::Mat reference = integral(renderer, settings, 1024, 7);
    auto rms = [&](const cv::Mat& image) {
      cv::Mat diff = image - reference;
      return std::sqrt(cv::mean(diff.mul(diff))[0]) / 0.7;
    };
    const int grid = static_cast<int>(std::ceil(std::sqrt(4 * points)));
    const double random = rms(integral(renderer, settings, grid * grid, 8));
    EXPECT_LT(rms(fast->reflectance), random)
        << feature_m << " m features: cubature " << rms(fast->reflectance) << " with " << points
        << " points vs " << grid * grid << " random samples " << random;
  }
}

TEST(AdaptiveRender, TheThreadCountDoesNotChangeTheIntegral) {
  // Two renderers (no shared cache): a colour camera, a defocused edge at 12 degrees.
  Renderer a =
      testing::make_renderer(testing::colour_camera_json(72, 56), edge_scene(0.7, 0.001, 12.0));
  Renderer b =
      testing::make_renderer(testing::colour_camera_json(72, 56), edge_scene(0.7, 0.001, 12.0));
  RenderSettings settings = a.default_settings();
  settings.f_number = kFNumber;
  RenderOptions options;
  options.threads = 1;
  auto one = a.integrate_scene(settings, 0, options);
  options.threads = 3;
  auto three = b.integrate_scene(settings, 0, options);
  ASSERT_TRUE(one.ok() && three.ok());
  ASSERT_FALSE(one->stats.cached || three->stats.cached);
  EXPECT_GT(one->stats.edge_share, 0.05);
  EXPECT_EQ(cv::norm(one->reflectance, three->reflectance, cv::NORM_INF), 0.0);
}

}  // namespace adaptive_render_test
}  // namespace
}  // namespace camlab::mock
