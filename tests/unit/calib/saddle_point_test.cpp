// The saddle-point refinement of one corner (calib/corners/saddle_point.h) on X-junctions
// drawn here: two straight edges through a known point at given angles, each pixel the
// exact share of its area (pixel (x, y) spans x +- 0.5) on each side (polygon clipping,
// not samples: a sampled pixel places an edge along x or y to its sample spacing, the same
// way all along the edge, which is a bias of the drawing), then a Gaussian blur and
// fixed-seed noise.
#include <cmath>
#include <cstdio>
#include <numbers>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include "calib/corners/saddle_point.h"

namespace camlab::calib {
namespace {

using Polygon = std::vector<cv::Point2d>;

// The part of `poly` where n . p > 0 (Sutherland-Hodgman, one half-plane).
Polygon clip(const Polygon& poly, cv::Point2d n) {
  Polygon out;
  for (size_t i = 0; i < poly.size(); ++i) {
    const cv::Point2d a = poly[i], b = poly[(i + 1) % poly.size()];
    const double da = n.dot(a), db = n.dot(b);
    if (da > 0) out.push_back(a);
    if ((da > 0) != (db > 0)) out.push_back(a + (b - a) * (da / (da - db)));
  }
  return out;
}

double area(const Polygon& poly) {
  double twice = 0;
  for (size_t i = 0; i < poly.size(); ++i) twice += poly[i].cross(poly[(i + 1) % poly.size()]);
  return std::fabs(twice) / 2;
}

// An X-junction at `corner` whose edges run at angle_a and angle_b (deg from +x): dark
// (200) where the two sides' signs agree, light (30) where they differ.
cv::Mat draw_junction(cv::Point2d corner, double angle_a, double angle_b, double blur_px,
                      double noise_dn, cv::Size size = {41, 41}) {
  const double a = angle_a * std::numbers::pi / 180, b = angle_b * std::numbers::pi / 180;
  const cv::Point2d na(-std::sin(a), std::cos(a)), nb(-std::sin(b), std::cos(b));
  cv::Mat image(size, CV_32F);
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      const cv::Point2d c(x - corner.x, y - corner.y);
      const Polygon pixel = {c + cv::Point2d(-0.5, -0.5), c + cv::Point2d(0.5, -0.5),
                             c + cv::Point2d(0.5, 0.5), c + cv::Point2d(-0.5, 0.5)};
      const double same = area(clip(clip(pixel, na), nb)) + area(clip(clip(pixel, -na), -nb));
      image.at<float>(y, x) = static_cast<float>(30 + 170 * same);
    }
  if (blur_px > 0) cv::GaussianBlur(image, image, cv::Size(), blur_px);
  if (noise_dn > 0) {
    cv::Mat n(size, CV_32F);
    cv::RNG rng(3);
    rng.fill(n, cv::RNG::NORMAL, 0, noise_dn);
    image += n;
  }
  return image;
}

// The fit's own bias: a quadratic is not an X-junction, and the pixels of a window are
// not placed symmetrically about a corner between them, so the saddle of the fit is off by
// up to about 0.02 px at a 6 px window (0.01 at 9 px), by phase and skew.
TEST(SaddlePoint, FindsTheCornerOfSkewedJunctionsAtAnySubpixelPosition) {
  double worst = 0, sum_sq = 0;
  int n = 0;
  for (double fx : {0.0, 0.23, 0.5, 0.81})
    for (double fy : {0.0, 0.37, 0.64})
      for (auto [a, b] : {std::pair{0.0, 90.0}, {20.0, 95.0}, {-35.0, 40.0}, {10.0, 140.0}}) {
        const cv::Point2d corner(20 + fx, 20 + fy);
        const cv::Mat image = draw_junction(corner, a, b, 0.7, 0);
        // Started a pixel and a half off, in a 6 px window.
        auto r = refine_saddle_point(image, corner + cv::Point2d(1.2, -0.9), 6, 3);
        ASSERT_TRUE(r.ok()) << r.error().message;
        const double e = cv::norm(r->corner_px - corner);
        worst = std::max(worst, e);
        sum_sq += e * e;
        ++n;
        EXPECT_GT(r->saddle_strength, 0.1);
      }
  std::printf("corner error over %d junctions: RMS %.4f px, worst %.4f px\n", n,
              std::sqrt(sum_sq / n), worst);
  EXPECT_LT(std::sqrt(sum_sq / n), 0.012);
  EXPECT_LT(worst, 0.025);
}

TEST(SaddlePoint, NoiseAveragesOutOverTheWindow) {
  const cv::Point2d corner(20.3, 19.6);
  const cv::Mat image = draw_junction(corner, 15, 100, 1.0, 4);  // 4 DN of 170 DN contrast
  auto r = refine_saddle_point(image, corner + cv::Point2d(-0.5, 0.5), 7, 3);
  ASSERT_TRUE(r.ok()) << r.error().message;
  EXPECT_LT(cv::norm(r->corner_px - corner), 0.05);
}

TEST(SaddlePoint, ReadsEightAndSixteenBitImages) {
  const cv::Point2d corner(20.4, 20.7);
  const cv::Mat f = draw_junction(corner, 0, 90, 0.7, 0);
  cv::Mat u8, u16;
  f.convertTo(u8, CV_8U);
  f.convertTo(u16, CV_16U, 20);
  for (const cv::Mat& image : {u8, u16}) {
    auto r = refine_saddle_point(image, corner + cv::Point2d(0.6, 0.6), 6, 3);
    ASSERT_TRUE(r.ok()) << r.error().message;
    EXPECT_LT(cv::norm(r->corner_px - corner), 0.03);
  }
}

TEST(SaddlePoint, RefusesWhatIsNoSaddle) {
  const cv::Mat flat(41, 41, CV_32F, cv::Scalar(100));
  auto r = refine_saddle_point(flat, {20, 20}, 6, 3);
  ASSERT_FALSE(r.ok());
  EXPECT_EQ(r.error().code, ErrorCode::kNotConverged);

  // One straight edge: a ridge, no saddle, or a saddle that wanders off along the edge.
  cv::Mat edge(41, 41, CV_32F, cv::Scalar(30));
  edge.colRange(20, 41).setTo(200);
  cv::GaussianBlur(edge, edge, cv::Size(), 0.8);
  EXPECT_FALSE(refine_saddle_point(edge, {20, 20}, 6, 3).ok());

  const cv::Mat junction = draw_junction({20, 20}, 0, 90, 0.7, 0);
  EXPECT_EQ(refine_saddle_point(junction, {3, 20}, 6, 3).error().code,
            ErrorCode::kWindowOutsideImage);
  EXPECT_EQ(refine_saddle_point(junction, {20, 20}, 1.5, 3).error().code,
            ErrorCode::kWindowTooSmall);
  EXPECT_EQ(refine_saddle_point(cv::Mat(), {20, 20}, 6, 3).error().code, ErrorCode::kBadImage);
  // Further from the start than allowed.
  EXPECT_EQ(refine_saddle_point(junction, {22.5, 20}, 6, 1).error().code, ErrorCode::kNotConverged);
}

}  // namespace
}  // namespace camlab::calib
