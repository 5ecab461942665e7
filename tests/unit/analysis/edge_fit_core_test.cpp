// The pieces both edge fits share (edge_fit_core.h), against truths computed another way:
// window membership by brute force over every pixel, normal equations against a linear
// least-squares problem solved by OpenCV's SVD, and pinning against the reduced problem.
#include "analysis/edge/edge_fit_core.h"

#include <cmath>
#include <numbers>
#include <random>

#include <gtest/gtest.h>

namespace camlab::analysis::edge_fit {
namespace {

TEST(EdgeFitCore, RejectsImagesNoFitCanUse) {
  EXPECT_FALSE(check_fittable_image(cv::Mat()));
  EXPECT_FALSE(check_fittable_image(cv::Mat(8, 8, CV_8UC3)));
  EXPECT_FALSE(check_fittable_image(cv::Mat(8, 8, CV_16S)));
  const Status bad = check_fittable_image(cv::Mat(8, 8, CV_32S));
  ASSERT_FALSE(bad);
  EXPECT_EQ(bad.error().code, ErrorCode::kInvalidArgument);
  for (int depth : {CV_8U, CV_16U, CV_32F, CV_64F}) {
    EXPECT_TRUE(check_fittable_image(cv::Mat(8, 8, CV_MAKETYPE(depth, 1))));
  }
}

// Every pixel of the image tested against the window's definition directly.
TEST(EdgeFitCore, WindowHoldsExactlyThePixelsInsideIt) {
  cv::Mat image(60, 80, CV_16U);
  cv::randu(image, 0, 4096);
  for (double angle_deg : {0.0, 5.0, 37.0, 90.0, 135.0, -80.0}) {
    const double angle = angle_deg * std::numbers::pi / 180.0;
    const LineWindow window{40.3, 29.6, angle, 12.0, -6.5, 9.0};
    auto pixels = sample_window(image, window, "the test window");
    ASSERT_TRUE(pixels) << pixels.error().text();
    size_t expected = 0;
    for (int row = 0; row < image.rows; ++row) {
      for (int col = 0; col < image.cols; ++col) {
        const double dx = col - window.x_px, dy = row - window.y_px;
        const double along = dx * std::cos(angle) + dy * std::sin(angle);
        const double across = -dx * std::sin(angle) + dy * std::cos(angle);
        if (std::fabs(along) <= 12.0 && across >= -6.5 && across <= 9.0) ++expected;
      }
    }
    EXPECT_EQ(pixels->size(), expected) << angle_deg << " deg";
    for (const WindowPixel& pixel : *pixels) {
      EXPECT_EQ(pixel.value, image.at<uint16_t>(pixel.row, pixel.col));
      const double across = -(pixel.col - window.x_px) * std::sin(angle) +
                            (pixel.row - window.y_px) * std::cos(angle);
      EXPECT_NEAR(pixel.across_px, across, 1e-12);
    }
  }
}

TEST(EdgeFitCore, NonFinitePixelsAreLeftOut) {
  cv::Mat image(20, 20, CV_32F, cv::Scalar(1.0f));
  image.at<float>(10, 10) = std::numeric_limits<float>::quiet_NaN();
  image.at<float>(10, 11) = std::numeric_limits<float>::infinity();
  auto pixels = sample_window(image, {10.0, 10.0, 0.0, 3.0, -3.0, 3.0}, "w");
  ASSERT_TRUE(pixels);
  EXPECT_EQ(pixels->size(), 7u * 7u - 2u);
}

TEST(EdgeFitCore, WindowReachingBeyondTheImageIsAnError) {
  const cv::Mat image(40, 50, CV_8U, cv::Scalar(0));
  auto pixels =
      sample_window(image, {3.0, 20.0, std::numbers::pi / 2, 5.0, -4.0, 4.0}, "the fit window");
  ASSERT_FALSE(pixels);
  EXPECT_EQ(pixels.error().code, ErrorCode::kWindowOutsideImage);
  EXPECT_NE(pixels.error().message.find("the fit window spans x -1"), std::string::npos)
      << pixels.error().message;
  // A window whose corners land exactly on the outermost pixel centres is inside.
  EXPECT_TRUE(sample_window(image, {25.0, 20.0, 0.0, 24.0, -20.0, 19.0}, "w"));
}

// A linear model y = a + b t + c t^2: one Gauss-Newton step from zero (lambda 0) is the
// least-squares solution, which SVD gives independently.
TEST(EdgeFitCore, UndampedStepIsTheLeastSquaresSolution) {
  std::mt19937 random(7);
  std::normal_distribution<double> noise(0.0, 0.1);
  NormalEquations<3> normals;
  cv::Mat design(50, 3, CV_64F), values(50, 1, CV_64F);
  for (int i = 0; i < 50; ++i) {
    const double t = -2.0 + 0.08 * i;
    const double y = 1.5 - 0.7 * t + 0.3 * t * t + noise(random);
    normals.add({1.0, t, t * t}, y);
    design.at<double>(i, 0) = 1.0;
    design.at<double>(i, 1) = t;
    design.at<double>(i, 2) = t * t;
    values.at<double>(i) = y;
  }
  normals.symmetrise();
  std::array<double, 3> step{};
  ASSERT_TRUE(solve_damped(normals, 0.0, {}, &step));
  cv::Mat truth;
  cv::solve(design, values, truth, cv::DECOMP_SVD);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(step[i], truth.at<double>(i), 1e-10);

  // Damping shortens the step but keeps it pointing downhill (positive along J^T r).
  std::array<double, 3> damped{};
  ASSERT_TRUE(solve_damped(normals, 10.0, {}, &damped));
  double along_gradient = 0, norm_step = 0, norm_damped = 0;
  for (int i = 0; i < 3; ++i) {
    along_gradient += damped[i] * normals.jtr[i];
    norm_step += step[i] * step[i];
    norm_damped += damped[i] * damped[i];
  }
  EXPECT_GT(along_gradient, 0.0);
  EXPECT_LT(norm_damped, norm_step);
}

// Pinning a parameter keeps it at 0 and solves the others as the reduced problem would.
TEST(EdgeFitCore, PinnedParameterKeepsItsValue) {
  NormalEquations<3> full;
  NormalEquations<2> reduced;
  for (int i = 0; i < 30; ++i) {
    const double t = 0.1 * i;
    const double y = 2.0 + t - 0.5 * t * t;
    full.add({1.0, t, t * t}, y);
    reduced.add({1.0, t * t}, y);
  }
  full.symmetrise();
  reduced.symmetrise();
  std::bitset<3> pinned;
  pinned[1] = true;
  std::array<double, 3> step{};
  std::array<double, 2> reduced_step{};
  ASSERT_TRUE(solve_damped(full, 0.0, pinned, &step));
  ASSERT_TRUE(solve_damped(reduced, 0.0, {}, &reduced_step));
  EXPECT_EQ(step[1], 0.0);
  EXPECT_NEAR(step[0], reduced_step[0], 1e-12);
  EXPECT_NEAR(step[2], reduced_step[1], 1e-12);
}

// A parameter the data say nothing about: singular unless pinned.
TEST(EdgeFitCore, CovarianceOfAnUnconstrainedParameterIsSingular) {
  NormalEquations<2> normals;
  for (int i = 0; i < 10; ++i) normals.add({1.0, 0.0}, 1.0);
  normals.symmetrise();
  cv::Mat inverse;
  EXPECT_FALSE(invert_normals(normals, {}, &inverse));
  std::bitset<2> pinned;
  pinned[1] = true;
  ASSERT_TRUE(invert_normals(normals, pinned, &inverse));
  EXPECT_NEAR(inverse.at<double>(0, 0), 0.1, 1e-15);
  // The damped solve still moves the constrained parameter and keeps the other.
  std::array<double, 2> step{};
  ASSERT_TRUE(solve_damped(normals, 0.0, {}, &step));
  EXPECT_NEAR(step[0], 1.0, 1e-15);
  EXPECT_EQ(step[1], 0.0);
}

}  // namespace
}  // namespace camlab::analysis::edge_fit
