// Circle of confusion, Airy disk, hyperfocal distance and depth of field: the stable
// forms against the image-side and textbook forms in long double, the exact and infinite
// cases, and invariants over a random sweep.
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
namespace defocus_test {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kEps = std::numeric_limits<double>::epsilon();

template <class T>
void expect_error(const Result<T>& result, ErrorCode code, std::string_view name) {
  ASSERT_FALSE(result.ok()) << name;
  EXPECT_EQ(result.error().code, code) << result.error().message;
  EXPECT_NE(result.error().message.find(name), std::string::npos) << result.error().message;
}

// Image side C = A |z_s - z_i| / z_i in long double, with each image distance written as
// f + f^2 / (z - f): the difference of the small offsets loses only log2(s / |z_o - s|)
// bits, which long double's 11 extra bits cover for |z_o - s| / s >= 1e-4.
long double coc_image_side_reference_mm(long double f, long double n, long double focus,
                                        long double object) {
  const long double sensor_offset = f * f / (focus - f);
  const long double image_offset = f * f / (object - f);
  return (f / n) * std::fabs(sensor_offset - image_offset) / (f + image_offset);
}

// The textbook D_F = D_S f^2 / (f^2 - N C (D_S - f)) and D_N = D_S f^2 / (f^2 + N C (D_S - f)).
long double lecture_far_mm(long double f, long double n, long double s, long double c) {
  return s * f * f / (f * f - n * c * (s - f));
}
long double lecture_near_mm(long double f, long double n, long double s, long double c) {
  return s * f * f / (f * f + n * c * (s - f));
}

double relative_error(double value, long double reference) {
  return static_cast<double>(std::fabs((value - reference) / reference));
}

TEST(OpticsCircleOfConfusion, ObjectAtFocusIsExactlyZero) {
  for (const double focus_mm : {50.0001, 120.0, 1e4, 1e9, kInfinity}) {
    auto coc = circle_of_confusion_mm(50.0, 2.8, focus_mm, focus_mm);
    ASSERT_TRUE(coc.ok()) << focus_mm;
    EXPECT_EQ(*coc, 0.0) << focus_mm;
  }
}

TEST(OpticsCircleOfConfusion, ObjectAtFocalLengthIsApertureDiameter) {
  // Rays from a point at f leave the lens parallel: the blur is the whole aperture.
  for (const double focus_mm : {60.0, 1e4, kInfinity}) {
    for (const double n : {1.4, 4.0, 22.0}) {
      EXPECT_EQ(*circle_of_confusion_mm(50.0, n, focus_mm, 50.0), 50.0 / n);
    }
  }
  // And the general form tends to A as the object approaches f.
  const double near_f_mm = *circle_of_confusion_mm(50.0, 2.0, 1e4, 50.0 * (1.0 + 1e-12));
  EXPECT_NEAR(near_f_mm, 25.0, 1e-8);
}

TEST(OpticsCircleOfConfusion, InfiniteFocusOrObjectUseLimitForms) {
  const long double f = 50.0L, n = 2.8L;
  // Focus at infinity: C = f^2 / (N z_o).
  for (const double object_mm : {100.0, 2000.0, 1e6}) {
    const double coc = *circle_of_confusion_mm(50.0, 2.8, kInfinity, object_mm);
    EXPECT_LT(relative_error(coc, f * f / (n * object_mm)), 1e-15) << object_mm;
  }
  // Object at infinity: C = (f^2 / N) / (s - f).
  for (const double focus_mm : {100.0, 2000.0, 1e6}) {
    const double coc = *circle_of_confusion_mm(50.0, 2.8, focus_mm, kInfinity);
    EXPECT_LT(relative_error(coc, f * f / n / (focus_mm - f)), 1e-15) << focus_mm;
  }
  // The limits agree with very distant finite points.
  EXPECT_NEAR(*circle_of_confusion_mm(50.0, 2.8, kInfinity, 2000.0) /
                  *circle_of_confusion_mm(50.0, 2.8, 1e15, 2000.0),
              1.0, 1e-11);
}

TEST(OpticsCircleOfConfusion, DistantObjectNearFocusIsAccurate) {
  struct Case {
    double focus_mm, object_mm;
  };
  // s = 10 m, z_o = 10.001 m and s = 1 km, z_o = 1.0001 km (and the mirror cases).
  for (const Case c :
       {Case{1e4, 1.0001e4}, Case{1e6, 1.0001e6}, Case{1.0001e4, 1e4}, Case{1.0001e6, 1e6}}) {
    for (const double focal_mm : {24.0, 50.0, 200.0}) {
      const double coc = *circle_of_confusion_mm(focal_mm, 2.8, c.focus_mm, c.object_mm);
      const long double reference =
          coc_image_side_reference_mm(focal_mm, 2.8L, c.focus_mm, c.object_mm);
      EXPECT_LT(relative_error(coc, reference), 1e-12)
          << focal_mm << " mm, s = " << c.focus_mm << ", z_o = " << c.object_mm;
    }
  }
  // The case is hard: the naive image-side form in double misses by far more than 1e-12.
  const double f = 50.0, s = 1e6, z = 1.0001e6;
  const double z_s = f * s / (s - f), z_i = f * z / (z - f);
  const double naive = (f / 2.8) * std::fabs(z_s - z_i) / z_i;
  EXPECT_GT(relative_error(naive, coc_image_side_reference_mm(f, 2.8L, s, z)), 1e-10);
}

TEST(OpticsCircleOfConfusion, AgreesWithImageSideFormInLongDouble) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> log_focal(0.5, 2.7);   // 3 .. 500 mm
  std::uniform_real_distribution<double> log_n(0.0, 1.6);       // f/1 .. f/40
  std::uniform_real_distribution<double> log_ratio(-3.0, 5.0);  // distance / f - 1
  for (int i = 0; i < 5000; ++i) {
    const double f = std::pow(10.0, log_focal(rng));
    const double n = std::pow(10.0, log_n(rng));
    const double s = f * (1.0 + std::pow(10.0, log_ratio(rng)));
    const double z = f * (1.0 + std::pow(10.0, log_ratio(rng)));
    // The reference itself is only good to ~1e-19 s / |z - s|.
    if (std::fabs(z - s) < 1e-4 * s) continue;
    const double coc = *circle_of_confusion_mm(f, n, s, z);
    EXPECT_LT(relative_error(coc, coc_image_side_reference_mm(f, n, s, z)), 1e-13)
        << f << " " << n << " " << s << " " << z;
  }
}

TEST(OpticsCircleOfConfusion, ProportionalToApertureSoCTimesNIsConstant) {
  for (const double object_mm : {300.0, 900.0, 5000.0, kInfinity}) {
    const double c_times_n = *circle_of_confusion_mm(50.0, 1.0, 1000.0, object_mm);
    for (const double n : {1.4, 2.8, 5.6, 11.0, 22.0}) {
      const double coc = *circle_of_confusion_mm(50.0, n, 1000.0, object_mm);
      EXPECT_NEAR(coc * n / c_times_n, 1.0, 1e-14) << object_mm << " f/" << n;
      // C / A is the same fraction of the aperture for every f-number.
      EXPECT_NEAR(coc / *aperture_diameter_mm(50.0, n), c_times_n / 50.0, 1e-15);
    }
  }
}

TEST(OpticsCircleOfConfusion, VAcrossSensorPositionsHasSlopeApertureOverImageDistance) {
  // Fixed object; move the sensor through its image. C = A |z_s - z_i| / z_i: linear in z_s.
  const double f = 50.0, n = 4.0, object_mm = 2000.0;
  const double z_i = *image_distance_mm(f, object_mm);
  const double slope = *aperture_diameter_mm(f, n) / z_i;
  for (const double delta_mm : {-0.5, -0.1, -0.01, 0.01, 0.1, 0.5}) {
    const double focus_mm = *focus_distance_mm(f, z_i + delta_mm);
    const double coc = *circle_of_confusion_mm(f, n, focus_mm, object_mm);
    EXPECT_NEAR(coc / (slope * std::fabs(delta_mm)), 1.0, 1e-9) << delta_mm;
  }
}

TEST(OpticsCircleOfConfusion, FocusOrObjectInsideFocalLengthIsNoRealImage) {
  expect_error(circle_of_confusion_mm(50.0, 2.8, 50.0, 1000.0), kErrNoRealImage, "focus_mm");
  expect_error(circle_of_confusion_mm(50.0, 2.8, 30.0, 1000.0), kErrNoRealImage, "focus_mm");
  expect_error(circle_of_confusion_mm(50.0, 2.8, 1000.0, 49.9), kErrNoRealImage, "object_mm");
  expect_error(circle_of_confusion_mm(50.0, 2.8, kInfinity, 10.0), kErrNoRealImage, "object_mm");
}

TEST(OpticsCircleOfConfusion, RejectsInvalidInputs) {
  for (const double bad : {0.0, -5.0, kNaN, -kInfinity}) {
    expect_error(circle_of_confusion_mm(bad, 2.8, 1000.0, 2000.0), kErrInvalidArgument, "focal_mm");
    expect_error(circle_of_confusion_mm(50.0, bad, 1000.0, 2000.0), kErrInvalidArgument,
                 "f_number");
    expect_error(circle_of_confusion_mm(50.0, 2.8, bad, 2000.0), kErrInvalidArgument, "focus_mm");
    expect_error(circle_of_confusion_mm(50.0, 2.8, 1000.0, bad), kErrInvalidArgument, "object_mm");
    expect_error(circle_of_confusion_px(0.01, bad), kErrInvalidArgument, "pixel_pitch_um");
    expect_error(airy_diameter_um(bad), kErrInvalidArgument, "f_number");
    expect_error(airy_diameter_um(8.0, bad), kErrInvalidArgument, "wavelength_nm");
  }
  for (const double bad : {-0.01, kNaN, kInfinity}) {
    expect_error(circle_of_confusion_px(bad, 4.0), kErrInvalidArgument, "coc_mm");
  }
  expect_error(circle_of_confusion_mm(kInfinity, 2.8, 1000.0, 2000.0), kErrInvalidArgument,
               "focal_mm");
  expect_error(circle_of_confusion_mm(50.0, kInfinity, 1000.0, 2000.0), kErrInvalidArgument,
               "f_number");
}

TEST(OpticsCircleOfConfusion, PixelsAndDiffractionFloor) {
  EXPECT_DOUBLE_EQ(*circle_of_confusion_px(0.01, 5.0), 2.0);
  EXPECT_EQ(*circle_of_confusion_px(0.0, 5.0), 0.0);
  // 2.44 lambda N: about 10.7 um at f/8 for 550 nm, proportional to N and lambda.
  EXPECT_NEAR(*airy_diameter_um(8.0), 10.7, 0.05);
  EXPECT_NEAR(*airy_diameter_um(8.0), 2.44 * 0.550 * 8.0, 1e-12);
  EXPECT_NEAR(*airy_diameter_um(16.0) / *airy_diameter_um(8.0), 2.0, 1e-15);
  EXPECT_NEAR(*airy_diameter_um(8.0, 450.0) / *airy_diameter_um(8.0, 550.0), 450.0 / 550.0, 1e-15);
}

TEST(OpticsDepthOfField, HyperfocalAndItsLimits) {
  // 50 mm f/8 c = 0.03 mm: H = 2500 / 0.24 + 50.
  const double H = *hyperfocal_mm(50.0, 8.0, 0.03);
  EXPECT_NEAR(H, 2500.0 / 0.24 + 50.0, 1e-9);
  // Focused at H: far is infinity, near is H / 2 (D_N = H (H - f) / (2H - 2f)).
  auto at_h = depth_of_field(50.0, 8.0, H, 0.03);
  ASSERT_TRUE(at_h.ok());
  EXPECT_EQ(at_h->far_mm, kInfinity);
  EXPECT_EQ(at_h->total_mm, kInfinity);
  EXPECT_NEAR(at_h->near_mm / (H / 2.0), 1.0, 1e-14);
  EXPECT_EQ(at_h->hyperfocal_mm, H);
  // Beyond H: still infinity; near keeps approaching H - f.
  auto beyond = depth_of_field(50.0, 8.0, 3.0 * H, 0.03);
  ASSERT_TRUE(beyond.ok());
  EXPECT_EQ(beyond->far_mm, kInfinity);
  EXPECT_LT(beyond->near_mm, H - 50.0);
  // Focused at infinity: near = H - f, far and total infinite.
  auto at_infinity = depth_of_field(50.0, 8.0, kInfinity, 0.03);
  ASSERT_TRUE(at_infinity.ok());
  EXPECT_NEAR(at_infinity->near_mm, H - 50.0, 1e-9);
  EXPECT_EQ(at_infinity->far_mm, kInfinity);
  EXPECT_EQ(at_infinity->total_mm, kInfinity);
  // Just short of H: finite, very large, never NaN or negative.
  auto short_of_h = depth_of_field(50.0, 8.0, std::nextafter(H, 0.0), 0.03);
  ASSERT_TRUE(short_of_h.ok());
  EXPECT_GT(short_of_h->far_mm, 1e9);
}

TEST(OpticsDepthOfField, NearLimitIsFocalLengthWhenApertureIsSmallerThanCoc) {
  // f = 1 mm at f/16: A = 0.0625 mm < c = 0.1 mm, so f^2 / (N c) < f and the formula's
  // near limit would fall inside f. Every real image from f on is sharp enough.
  const double f = 1.0, n = 16.0, c = 0.1;
  for (const double focus_mm : {1.5, 10.0, kInfinity}) {
    auto dof = depth_of_field(f, n, focus_mm, c);
    ASSERT_TRUE(dof.ok());
    EXPECT_EQ(dof->near_mm, f);
    EXPECT_LT(*circle_of_confusion_mm(f, n, focus_mm, f), c);
  }
}

TEST(OpticsDepthOfField, AgreesWithLectureForms) {
  for (const double f : {24.0, 50.0, 135.0}) {
    for (const double n : {1.4, 4.0, 16.0}) {
      const double c = 0.03;
      const double H = *hyperfocal_mm(f, n, c);
      // The textbook far form cancels near H; compare away from it.
      for (const double s : {1.5 * f, 3.0 * f, 1000.0, 0.5 * H, 0.9 * H}) {
        if (s <= f) continue;
        auto dof = depth_of_field(f, n, s, c);
        ASSERT_TRUE(dof.ok());
        EXPECT_LT(relative_error(dof->near_mm, lecture_near_mm(f, n, s, c)), 1e-13);
        EXPECT_LT(relative_error(dof->far_mm, lecture_far_mm(f, n, s, c)), 1e-12);
        EXPECT_DOUBLE_EQ(dof->total_mm, dof->far_mm - dof->near_mm);
      }
    }
  }
}

TEST(OpticsDepthOfField, SmallerApertureDeeperLongerFocalShallower) {
  double previous_mm = 0.0;
  for (const double n : {1.4, 2.0, 2.8, 4.0, 5.6}) {  // 50 mm at 3 m, all short of H
    const double total_mm = depth_of_field(50.0, n, 3000.0, 0.03)->total_mm;
    EXPECT_GT(total_mm, previous_mm) << n;
    previous_mm = total_mm;
  }
  previous_mm = kInfinity;
  for (const double f : {35.0, 50.0, 85.0, 135.0, 200.0}) {
    const double total_mm = depth_of_field(f, 4.0, 5000.0, 0.03)->total_mm;
    EXPECT_LT(total_mm, previous_mm) << f;
    previous_mm = total_mm;
  }
}

TEST(OpticsDepthOfField, FocusAtOrInsideFocalLengthAndInvalidInputs) {
  expect_error(depth_of_field(50.0, 8.0, 50.0, 0.03), kErrNoRealImage, "focus_mm");
  expect_error(depth_of_field(50.0, 8.0, 20.0, 0.03), kErrNoRealImage, "focus_mm");
  for (const double bad : {0.0, -1.0, kNaN, kInfinity, -kInfinity}) {
    expect_error(depth_of_field(bad, 8.0, 3000.0, 0.03), kErrInvalidArgument, "focal_mm");
    expect_error(depth_of_field(50.0, bad, 3000.0, 0.03), kErrInvalidArgument, "f_number");
    expect_error(depth_of_field(50.0, 8.0, 3000.0, bad), kErrInvalidArgument, "coc_mm");
    expect_error(hyperfocal_mm(50.0, 8.0, bad), kErrInvalidArgument, "coc_mm");
    if (!(bad == kInfinity)) {
      expect_error(depth_of_field(50.0, 8.0, bad, 0.03), kErrInvalidArgument, "focus_mm");
    }
  }
}

// Random valid inputs from macro to infinity: no NaN, near <= s <= far, and the blur at
// each limit is the acceptable CoC (the definition of the limits).
TEST(OpticsDepthOfField, RandomSweepIsOrderedAndConsistentWithCoc) {
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> log_focal(0.0, 3.0);    // 1 mm .. 1 m
  std::uniform_real_distribution<double> log_n(-0.15, 2.0);      // f/0.7 .. f/100
  std::uniform_real_distribution<double> log_coc(-4.0, -0.5);    // 0.1 um .. 0.3 mm
  std::uniform_real_distribution<double> log_ratio(-10.0, 8.0);  // s / f - 1
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int checked_limits = 0;
  for (int i = 0; i < 20000; ++i) {
    const double f = std::pow(10.0, log_focal(rng));
    const double n = std::pow(10.0, log_n(rng));
    const double c = std::pow(10.0, log_coc(rng));
    double s = f * (1.0 + std::pow(10.0, log_ratio(rng)));
    if (unit(rng) < 0.02) s = kInfinity;
    if (!(s > f)) continue;
    auto dof = depth_of_field(f, n, s, c);
    ASSERT_TRUE(dof.ok()) << f << " " << n << " " << s << " " << c;
    ASSERT_FALSE(std::isnan(dof->near_mm) || std::isnan(dof->far_mm) || std::isnan(dof->total_mm) ||
                 std::isnan(dof->hyperfocal_mm));
    ASSERT_GT(dof->near_mm, 0.0);
    ASSERT_LE(dof->near_mm, s);
    ASSERT_GE(dof->far_mm, s);
    ASSERT_GE(dof->total_mm, 0.0);
    if (s >= dof->hyperfocal_mm) {
      ASSERT_EQ(dof->far_mm, kInfinity);
    }

    // CoC of a point at the limits. Its accuracy is bounded by how well s - limit is
    // resolved in double: relative error ~ eps s / |s - limit|.
    for (const double limit_mm : {dof->near_mm, dof->far_mm}) {
      if (std::isinf(limit_mm) || std::isinf(s)) continue;
      const double conditioning = s / std::fabs(s - limit_mm);
      if (!(conditioning < 1e8)) continue;
      const double coc = *circle_of_confusion_mm(f, n, s, limit_mm);
      ASSERT_FALSE(std::isnan(coc));
      if (limit_mm == f) {  // aperture smaller than c: sharp enough down to f (C = A < c)
        EXPECT_EQ(coc, f / n);
        EXPECT_LT(coc, c);
        continue;
      }
      EXPECT_NEAR(coc / c, 1.0, 64.0 * kEps * (1.0 + conditioning))
          << f << " " << n << " " << s << " " << c << " at " << limit_mm;
      ++checked_limits;
    }
    auto coc_at_far_object = circle_of_confusion_mm(f, n, s, 10.0 * s);
    ASSERT_TRUE(coc_at_far_object.ok());
    ASSERT_FALSE(std::isnan(*coc_at_far_object));
    ASSERT_GE(*coc_at_far_object, 0.0);
  }
  EXPECT_GT(checked_limits, 10000);
}

}  // namespace defocus_test
}  // namespace
}  // namespace camlab::optics
