// Thin lens 1/f = 1/z_i + 1/z_o: the equation itself in long double, its symmetric and
// limiting cases, and the rejection of objects at or inside f.
#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "optics/optics.h"

namespace camlab::optics {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace thin_lens_test {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

template <class T>
void expect_error(const Result<T>& result, ErrorCode code, std::string_view name) {
  ASSERT_FALSE(result.ok()) << name;
  EXPECT_EQ(result.error().code, code) << result.error().message;
  EXPECT_NE(result.error().message.find(name), std::string::npos) << result.error().message;
}

TEST(OpticsThinLens, ImageDistanceSatisfiesLensEquation) {
  std::mt19937_64 rng(20240611);
  std::uniform_real_distribution<double> log_focal(0.0, 3.0);   // 1 mm .. 1 m
  std::uniform_real_distribution<double> log_ratio(-9.0, 6.0);  // z_o / f - 1
  for (int i = 0; i < 5000; ++i) {
    const double focal_mm = std::pow(10.0, log_focal(rng));
    const double object_mm = focal_mm * (1.0 + std::pow(10.0, log_ratio(rng)));
    if (!(object_mm > focal_mm)) continue;
    auto image_mm = image_distance_mm(focal_mm, object_mm);
    ASSERT_TRUE(image_mm.ok()) << focal_mm << " " << object_mm;
    ASSERT_GT(*image_mm, focal_mm);
    // 1/z_i = 1/f - 1/z_o = (z_o - f) / (f z_o), in long double.
    const long double f = focal_mm, z_o = object_mm;
    const long double expected_inverse = (z_o - f) / (f * z_o);
    EXPECT_NEAR(static_cast<double>((1.0L / *image_mm) / expected_inverse), 1.0, 1e-14)
        << focal_mm << " " << object_mm;
  }
}

TEST(OpticsThinLens, SymmetricAndLimitingCases) {
  // 2f - 2f imaging: unit magnification, exactly.
  EXPECT_EQ(*image_distance_mm(50.0, 100.0), 100.0);
  EXPECT_EQ(*magnification(50.0, 100.0), 1.0);
  // Object at infinity: image at f, magnification 0.
  EXPECT_EQ(*image_distance_mm(50.0, kInfinity), 50.0);
  EXPECT_EQ(*magnification(50.0, kInfinity), 0.0);
  // Far objects: the image approaches f from above, never below.
  const double far_mm = *image_distance_mm(50.0, 1e300);
  EXPECT_GE(far_mm, 50.0);
  EXPECT_NEAR(far_mm, 50.0, 1e-12);
  // Just outside f: a huge but finite image distance, z_i = f z_o / (z_o - f).
  const double just_outside_mm = std::nextafter(50.0, 100.0);
  const double huge_mm = *image_distance_mm(50.0, just_outside_mm);
  EXPECT_TRUE(std::isfinite(huge_mm));
  EXPECT_DOUBLE_EQ(huge_mm, 50.0 * just_outside_mm / (just_outside_mm - 50.0));
}

TEST(OpticsThinLens, MagnificationIsImageOverObjectDistance) {
  for (const double focal_mm : {4.0, 50.0, 300.0}) {
    for (const double factor : {1.001, 1.5, 2.0, 10.0, 1e4, 1e8}) {
      const double object_mm = focal_mm * factor;
      const double m = *magnification(focal_mm, object_mm);
      EXPECT_NEAR(m / (*image_distance_mm(focal_mm, object_mm) / object_mm), 1.0, 1e-13);
    }
  }
}

TEST(OpticsThinLens, FocusDistanceInvertsLensToSensor) {
  for (const double focal_mm : {4.0, 50.0, 300.0}) {
    for (const double focus_mm : {focal_mm * 1.01, focal_mm * 3.0, 1000.0 + focal_mm, 1e7}) {
      const double sensor_mm = *lens_to_sensor_mm(focal_mm, focus_mm);
      EXPECT_EQ(sensor_mm, *image_distance_mm(focal_mm, focus_mm));
      EXPECT_NEAR(*focus_distance_mm(focal_mm, sensor_mm) / focus_mm, 1.0, 1e-9)
          << focal_mm << " " << focus_mm;
    }
  }
  EXPECT_EQ(*focus_distance_mm(50.0, 50.0), kInfinity);  // sensor at f: infinity in focus
  EXPECT_EQ(*lens_to_sensor_mm(50.0, kInfinity), 50.0);
}

TEST(OpticsThinLens, ApertureDiameterIsFocalOverFNumber) {
  EXPECT_EQ(*aperture_diameter_mm(50.0, 2.0), 25.0);
  EXPECT_EQ(*aperture_diameter_mm(100.0, 4.0), 25.0);
  // One full stop (N x sqrt 2) halves the aperture area.
  const double wide_mm = *aperture_diameter_mm(50.0, 2.8);
  const double narrow_mm = *aperture_diameter_mm(50.0, 2.8 * std::sqrt(2.0));
  EXPECT_NEAR(wide_mm * wide_mm / (narrow_mm * narrow_mm), 2.0, 1e-12);
}

TEST(OpticsThinLens, ObjectAtOrInsideFocalLengthHasNoRealImage) {
  for (const double object_mm : {50.0, 49.999, 1.0}) {
    expect_error(image_distance_mm(50.0, object_mm), kErrNoRealImage, "object_mm");
    expect_error(magnification(50.0, object_mm), kErrNoRealImage, "object_mm");
    expect_error(lens_to_sensor_mm(50.0, object_mm), kErrNoRealImage, "focus_mm");
  }
  expect_error(focus_distance_mm(50.0, 49.0), kErrNoRealImage, "lens_to_sensor_mm");
  // The message says what is allowed.
  auto inside = image_distance_mm(50.0, 20.0);
  EXPECT_NE(inside.error().message.find("must be > focal_mm = 50"), std::string::npos)
      << inside.error().message;
}

TEST(OpticsThinLens, RejectsInvalidInputs) {
  for (const double bad : {0.0, -5.0, kNaN, -kInfinity}) {
    expect_error(image_distance_mm(bad, 1000.0), kErrInvalidArgument, "focal_mm");
    expect_error(image_distance_mm(50.0, bad), kErrInvalidArgument, "object_mm");
    expect_error(magnification(bad, 1000.0), kErrInvalidArgument, "focal_mm");
    expect_error(magnification(50.0, bad), kErrInvalidArgument, "object_mm");
    expect_error(lens_to_sensor_mm(50.0, bad), kErrInvalidArgument, "focus_mm");
    expect_error(focus_distance_mm(bad, 52.0), kErrInvalidArgument, "focal_mm");
    expect_error(focus_distance_mm(50.0, bad), kErrInvalidArgument, "lens_to_sensor_mm");
    expect_error(aperture_diameter_mm(bad, 2.0), kErrInvalidArgument, "focal_mm");
    expect_error(aperture_diameter_mm(50.0, bad), kErrInvalidArgument, "f_number");
  }
  // Infinity is a distance, not a focal length, f-number or sensor position.
  expect_error(image_distance_mm(kInfinity, 1000.0), kErrInvalidArgument, "focal_mm");
  expect_error(focus_distance_mm(50.0, kInfinity), kErrInvalidArgument, "lens_to_sensor_mm");
  expect_error(aperture_diameter_mm(50.0, kInfinity), kErrInvalidArgument, "f_number");
  auto negative = image_distance_mm(-5.0, 1000.0);
  EXPECT_NE(negative.error().message.find("focal_mm = -5"), std::string::npos)
      << negative.error().message;
}

}  // namespace thin_lens_test
}  // namespace
}  // namespace camlab::optics
