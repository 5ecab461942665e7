// Refocusing, depth and lenslet decoding on light fields generated independently of the
// renderer (lightfield_synthetic.h), against closed forms: an edge refocused at its own
// depth is the pixel-integrated, blurred step at the thin lens's magnified position; away
// from it, the sum of the views' shifted steps; depth of textured planes is their z;
// decoding a lenslet image returns the views it was made of.
#include <gtest/gtest.h>

#include <cmath>
#include <numeric>

#include "analysis/lightfield/depth.h"
#include "analysis/lightfield/lattice_resampler.h"
#include "analysis/lightfield/lenslet_decode.h"
#include "analysis/lightfield/refocus.h"
#include "lightfield_measures.h"
#include "lightfield_synthetic.h"

namespace camlab::analysis::lightfield {
namespace {

using testing::blurred_step_pixel;
using testing::SineTexture;
using testing::SyntheticOptics;

constexpr double kSigmaPx = 0.8;  // the lens's own blur in the synthetic views

// A vertical edge at x_e (px, central view), 500 DN of contrast over 300.
auto edge_at(double x_e) {
  return [x_e](double x, double) { return 300 + 500 * blurred_step_pixel(x - x_e, kSigmaPx); };
}

TEST(LightFieldRefocus, EdgeAtTheFocusDistanceIsTheThinLensEdge) {
  const cv::Size size(64, 32);
  const SyntheticOptics o;
  for (double z_m : {0.7, 1.6}) {
    const LightField lf = testing::synthetic_light_field(9, size, z_m, edge_at(35.3));
    auto r = refocus(lf, z_m);
    ASSERT_TRUE(r.ok()) << r.error().message;
    // The thin lens focused at z: magnified by alpha about the principal point, the lens
    // blur and the pixel scaled with it, the irradiance down by alpha^2.
    const double alpha = r->magnification;
    EXPECT_NEAR(alpha, (o.focal_mm * z_m * 1e3 / (z_m * 1e3 - o.focal_mm)) / o.lens_to_sensor_mm(),
                1e-12);
    const double c = (size.width - 1) / 2.0, x_e = c + alpha * (35.3 - c);
    double sq = 0;
    int n = 0;
    for (int x = 25; x < 46; ++x) {
      const double truth =
          (300 + 500 * blurred_step_pixel((x - x_e) / alpha, kSigmaPx)) / (alpha * alpha);
      for (int y = 8; y < 24; ++y) {
        sq += std::pow(r->image.at<float>(y, x) - truth, 2);
        ++n;
      }
    }
    EXPECT_LT(std::sqrt(sq / n) / 500, 0.005) << "z " << z_m;  // interpolation only
    EXPECT_GT(r->view_step_px, 0.1);                           // the views really were shifted
  }
}

TEST(LightFieldRefocus, EdgeAwayFromTheFocusIsTheSumOfTheShiftedViews) {
  const cv::Size size(64, 32);
  const SyntheticOptics o;
  const double z_m = 0.8, s_m = 1.5;
  const LightField lf = testing::synthetic_light_field(7, size, z_m, edge_at(30.2));
  for (double f_number : {0.0, 4.0}) {
    auto r = refocus(lf, s_m, f_number);
    ASSERT_TRUE(r.ok()) << r.error().message;
    const double alpha = r->magnification, c = (size.width - 1) / 2.0;
    // A view through o has the edge at 30.2 - f_px o_x (1/z - q); refocusing moves it by
    // f_px o_x (1/s - q), leaving -f_px o_x (1/z - 1/s), then magnifies.
    const double slope = o.f_px() * (1 / z_m - 1 / s_m);
    double sq = 0;
    int n = 0;
    for (int x = 12; x < 52; ++x) {
      double truth = 0;
      for (size_t k = 0; k < lf.views.size(); ++k) {
        const double x_k = c + alpha * (30.2 - slope * lf.description.views[k].centroid_m[0] - c);
        truth += r->aperture.weights[k] *
                 (300 + 500 * blurred_step_pixel((x - x_k) / alpha, kSigmaPx)) / (alpha * alpha);
      }
      for (int y = 8; y < 24; ++y) {
        sq += std::pow(r->image.at<float>(y, x) - truth, 2);
        ++n;
      }
    }
    EXPECT_LT(std::sqrt(sq / n) / 500, 0.005) << "f/" << f_number;
  }
}

TEST(LightFieldRefocus, SyntheticApertureHasTheSecondMomentAskedFor) {
  const auto d = testing::synthetic_description(9, {16, 16});
  for (double n : {2.5, 2.8, 4.0, 5.6, 8.0}) {
    auto a = synthetic_aperture(d, n);
    ASSERT_TRUE(a.ok()) << a.error().message;
    EXPECT_NEAR(a->effective_f_number, n, 1e-6 * n);
    EXPECT_NEAR(std::accumulate(a->weights.begin(), a->weights.end(), 0.0), 1, 1e-6);
    // The same from the weights and the views' lens points, written out: a uniform disk of
    // radius rho has a mean (x^2 + y^2) / 2 of rho^2 / 4.
    double moment = 0;
    for (size_t k = 0; k < d.views.size(); ++k)
      moment += a->weights[k] * 0.5 *
                (std::pow(d.views[k].centroid_m[0], 2) + std::pow(d.views[k].centroid_m[1], 2));
    EXPECT_NEAR(8.0 / (2 * 2 * std::sqrt(moment) * 1e3), n, 1e-5 * n);
  }
  // The whole aperture: every view by its area; f/2's lens points alone give f/2.017.
  auto whole = synthetic_aperture(d, 0);
  ASSERT_TRUE(whole.ok());
  EXPECT_EQ(whole->views_used, 77);
  EXPECT_NEAR(whole->effective_f_number, 2.0 / std::sqrt(1 - 4.0 / (3 * 81)), 2e-3);
  for (double bad : {1.4, -1.0, std::nan("")}) {
    auto a = synthetic_aperture(d, bad);
    ASSERT_FALSE(a.ok()) << bad;
    EXPECT_EQ(a.error().code, ErrorCode::kOutOfRange);
    EXPECT_NE(a.error().message.find("f_number"), std::string::npos);
  }
  // An odd grid's central view is a lens point alone: any smaller aperture. An even
  // grid's four central views sit at (+-1/8, +-1/8) R: their moment is that of a disk of
  // R / 4, so 8 x 8 views of f/2 reach f/8.
  EXPECT_TRUE(synthetic_aperture(d, 40).ok());
  const auto even = testing::synthetic_description(8, {16, 16});
  EXPECT_TRUE(synthetic_aperture(even, 7.9).ok());
  auto too_small = synthetic_aperture(even, 8.1);
  ASSERT_FALSE(too_small.ok());
  EXPECT_NE(too_small.error().message.find("[2, 8]"), std::string::npos)
      << too_small.error().message;
}

TEST(LightFieldDepth, TexturedPlanesAtTheirDepth) {
  const cv::Size size(48, 40);
  const SineTexture texture(4);
  for (double z_m : {0.5, 0.8, 1.25, 2.5}) {
    const LightField lf = testing::synthetic_light_field(
        7, size, z_m, [&](double x, double y) { return texture.pixel(x, y); });
    DepthOptions options;
    auto depth = estimate_depth(lf, options);
    ASSERT_TRUE(depth.ok()) << depth.error().message;
    double worst = 0;
    int ok = 0;
    for (int y = 8; y < size.height - 8; ++y)
      for (int x = 8; x < size.width - 8; ++x) {
        if (depth->status.at<uint8_t>(y, x) != kDepthOk) continue;
        ++ok;
        worst = std::max(worst, std::fabs(depth->depth_m.at<float>(y, x) / z_m - 1));
      }
    EXPECT_EQ(ok, (size.width - 16) * (size.height - 16)) << z_m;
    EXPECT_LT(worst, 0.002) << z_m;  // noise-free: the parabola's refinement alone
  }
}

TEST(LightFieldDepth, FlatAndOutOfRangeAreFlaggedNotGuessed) {
  const cv::Size size(32, 32);
  // A flat field: the views agree at every depth.
  const LightField flat =
      testing::synthetic_light_field(5, size, 0.9, [](double, double) { return 700.0; });
  auto depth = estimate_depth(flat, {});
  ASSERT_TRUE(depth.ok());
  EXPECT_EQ(depth->flat_share, 1.0);
  EXPECT_EQ(cv::countNonZero(depth->depth_m), 0);
  ASSERT_FALSE(depth->warnings.empty());
  EXPECT_NE(depth->warnings[0].find("no texture"), std::string::npos) << depth->warnings[0];
  // A textured plane at 0.4 m, searched from 0.6 to 3 m: it lies beyond the near end.
  const SineTexture texture(8);
  const LightField near = testing::synthetic_light_field(
      5, size, 0.4, [&](double x, double y) { return texture.pixel(x, y); });
  DepthOptions options;
  options.near_m = 0.6;
  options.far_m = 3.0;
  auto out = estimate_depth(near, options);
  ASSERT_TRUE(out.ok());
  EXPECT_GT(out->out_of_range_share, 0.9) << "flat " << out->flat_share << " ok " << out->ok_share;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x)
      if (out->status.at<uint8_t>(y, x) != kDepthOk) {
        EXPECT_EQ(out->depth_m.at<float>(y, x), 0.f);
      }
}

TEST(LightFieldResampler, ShiftsAndStaggeredRowsAreExactForSmoothImages) {
  // A slow quadratic surface: Lanczos-3 is exact to far below a DN on it.
  const auto f = [](double x, double y) { return 500 + 3 * x - 2 * y + 0.01 * x * y; };
  const cv::Size size(40, 30);
  image::ViewLattice square;
  cv::Mat view(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) view.at<float>(y, x) = static_cast<float>(f(x, y));
  LatticeResampler resampler(square, size, size);
  const cv::Mat out = resampler.resample(view, 0.999, 0.37, -0.61);
  for (int y = 6; y < 24; ++y)
    for (int x = 6; x < 34; ++x)
      EXPECT_NEAR(out.at<float>(y, x), f(0.999 * x + 0.37, 0.999 * y - 0.61), 0.05)
          << x << " " << y;
  // A hexagonal lattice: row l at y = 0.9 l, odd rows half a pixel right.
  image::ViewLattice hex{"hex", 0.9, 0.5};
  cv::Mat staggered(size, CV_32F);
  for (int l = 0; l < size.height; ++l)
    for (int k = 0; k < size.width; ++k)
      staggered.at<float>(l, k) = static_cast<float>(f(k + 0.5 * (l % 2), 0.9 * l));
  const cv::Size grid = LatticeResampler::square_grid_size(hex, size);
  EXPECT_EQ(grid, cv::Size(40, 27));
  LatticeResampler hex_resampler(hex, size, grid);
  const cv::Mat square_grid = hex_resampler.resample(staggered, 1.0, 0, 0);
  for (int y = 6; y < 20; ++y)
    for (int x = 6; x < 34; ++x) EXPECT_NEAR(square_grid.at<float>(y, x), f(x, y), 0.05);
}

// Decoding: views of random DN (every view its own), composed into a lenslet image here.
void check_decode(bool staggered, int views) {
  const cv::Size size(20, 14);
  const auto d = testing::synthetic_description(views, size);
  std::vector<cv::Mat> originals;
  cv::RNG rng(13);
  for (size_t k = 0; k < d.views.size(); ++k) {
    cv::Mat v(size, CV_32F);
    rng.fill(v, cv::RNG::UNIFORM, 100, 3000);
    originals.push_back(v);
  }
  const int row_pitch = staggered ? static_cast<int>(std::ceil(views * std::sqrt(3.0) / 2)) : views;
  const auto lenslet = testing::synthetic_lenslet(originals, d, 4, staggered, row_pitch, 64, 3200);
  DecodeOptions options;
  auto decoded = decode_lenslet(lenslet.raw, lenslet.white, 64, d.optics, 0.4, options);
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  const MicrolensLattice& m = decoded->lattice;
  EXPECT_EQ(m.staggered, staggered);
  EXPECT_NEAR(m.pitch_px(), views, 1e-6);
  EXPECT_NEAR(m.origin_px[0], 4 + (views - 1) / 2.0, 1e-6);
  EXPECT_NEAR(m.origin_px[1], 4 + (views - 1) / 2.0, 1e-6);
  EXPECT_EQ(m.columns, size.width);
  EXPECT_EQ(m.rows, size.height);
  EXPECT_EQ(decoded->views_per_side, views);
  const LightField& lf = decoded->light_field;
  EXPECT_EQ(lf.description.lattice.layout, staggered ? "hex" : "square");
  EXPECT_NEAR(lf.description.optics.pixel_pitch_um, 0.4 * views, 1e-9);
  ASSERT_GT(lf.views.size(), d.views.size() / 2);
  double sq = 0;
  long n = 0;
  for (size_t k = 0; k < lf.views.size(); ++k) {
    const auto& v = lf.description.views[k];
    size_t j = 0;
    while (d.views[j].u_index != v.u_index || d.views[j].v_index != v.v_index) ++j;
    EXPECT_NEAR(v.centroid_m[0], d.views[j].centroid_m[0], 1e-12);
    cv::Mat diff = lf.views[k] - originals[j];
    sq += diff.dot(diff);
    n += static_cast<long>(diff.total());
  }
  // Rounding: the raw and white to whole DN, divided by lit shares >= 0.5.
  EXPECT_LT(std::sqrt(sq / n), 0.7) << (staggered ? "hex" : "square");
}

TEST(LensletDecode, SquareGridReturnsTheViews) { check_decode(false, 7); }
TEST(LensletDecode, HexagonalGridReturnsTheViews) { check_decode(true, 8); }

TEST(LensletDecode, DarkOrUniformWhiteImagesAreRefused) {
  const auto d = testing::synthetic_description(5, {16, 16});
  cv::Mat dark(60, 60, CV_16U, cv::Scalar(64));
  auto a = decode_lenslet(dark, dark, 64, d.optics, 1.0, {});
  ASSERT_FALSE(a.ok());
  EXPECT_EQ(a.error().code, ErrorCode::kNoSignal);
  cv::Mat flat(60, 60, CV_16U, cv::Scalar(2000));
  auto b = decode_lenslet(flat, flat, 64, d.optics, 1.0, {});
  ASSERT_FALSE(b.ok());
  EXPECT_EQ(b.error().code, ErrorCode::kNoContrast);
  auto c = decode_lenslet(flat, dark(cv::Rect(0, 0, 30, 30)), 64, d.optics, 1.0, {});
  ASSERT_FALSE(c.ok());
  EXPECT_EQ(c.error().code, ErrorCode::kInvalidArgument);
}

}  // namespace
}  // namespace camlab::analysis::lightfield
