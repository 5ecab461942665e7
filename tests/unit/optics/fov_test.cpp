// Field of view, sensor formats and crop factors against the common format table, the figures
// quoted in docs/physics.md and closed forms computed another way.
#include <array>
#include <cmath>
#include <limits>
#include <numbers>
#include <string>
#include <string_view>

#include <gtest/gtest.h>

#include "optics/optics.h"

namespace camlab::optics {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace fov_test {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

double round_to(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

// The same angle as 2 atan(d / 2f), through the law of cosines of the triangle formed by
// the lens centre and the two ends of the extent: cos(FOV) = (4f^2 - d^2) / (4f^2 + d^2).
double fov_by_cosine_deg(double extent_mm, double focal_mm) {
  const double four_f2 = 4.0 * focal_mm * focal_mm;
  const double d2 = extent_mm * extent_mm;
  return std::acos((four_f2 - d2) / (four_f2 + d2)) * 180.0 / std::numbers::pi;
}

template <class T>
void expect_invalid(const Result<T>& result, std::string_view name) {
  ASSERT_FALSE(result.ok()) << name;
  EXPECT_EQ(result.error().code, kErrInvalidArgument);
  EXPECT_NE(result.error().message.find(name), std::string::npos) << result.error().message;
  EXPECT_NE(result.error().message.find("> 0"), std::string::npos) << result.error().message;
}

TEST(OpticsFieldOfView, FullFrameDiagonalMatchesPrintedFigures) {
  auto ff = find_sensor_format("full-frame");
  ASSERT_TRUE(ff.ok());
  const auto fov17 = field_of_view(17.0, ff->width_mm, ff->height_mm);
  const auto fov50 = field_of_view(50.0, ff->width_mm, ff->height_mm);
  const auto fov200 = field_of_view(200.0, ff->width_mm, ff->height_mm);
  ASSERT_TRUE(fov17.ok() && fov50.ok() && fov200.ok());
  EXPECT_DOUBLE_EQ(round_to(fov17->diagonal_deg, 1), 103.7);
  EXPECT_DOUBLE_EQ(round_to(fov50->diagonal_deg, 1), 46.8);
  EXPECT_DOUBLE_EQ(round_to(fov200->diagonal_deg, 2), 12.35);
}

TEST(OpticsFieldOfView, AgreesWithLawOfCosinesForm) {
  for (const double focal_mm : {4.0, 17.0, 35.0, 50.0, 85.0, 200.0, 600.0}) {
    for (const double extent_mm : {3.42, 15.8, 24.0, 36.0, 43.27, 67.08}) {
      auto fov = field_of_view_deg(extent_mm, focal_mm);
      ASSERT_TRUE(fov.ok());
      EXPECT_NEAR(*fov, fov_by_cosine_deg(extent_mm, focal_mm), 1e-9)
          << extent_mm << " mm at " << focal_mm << " mm";
    }
  }
}

TEST(OpticsFieldOfView, ComponentsUseWidthHeightAndDiagonal) {
  auto fov = field_of_view(35.0, 23.6, 15.8);
  ASSERT_TRUE(fov.ok());
  EXPECT_DOUBLE_EQ(fov->horizontal_deg, *field_of_view_deg(23.6, 35.0));
  EXPECT_DOUBLE_EQ(fov->vertical_deg, *field_of_view_deg(15.8, 35.0));
  EXPECT_DOUBLE_EQ(fov->diagonal_deg, *field_of_view_deg(std::hypot(23.6, 15.8), 35.0));
  // The diagonal is the widest; the tangents of the half angles add like the sides.
  const auto half_tan = [](double deg) { return std::tan(deg * std::numbers::pi / 360.0); };
  EXPECT_NEAR(std::hypot(half_tan(fov->horizontal_deg), half_tan(fov->vertical_deg)),
              half_tan(fov->diagonal_deg), 1e-12);
}

TEST(OpticsFieldOfView, LongerFocalNarrowerLargerSensorWider) {
  double previous_deg = 180.0;
  for (double focal_mm = 1.0; focal_mm < 2000.0; focal_mm *= 1.3) {
    const double fov_deg = *field_of_view_deg(43.27, focal_mm);
    EXPECT_LT(fov_deg, previous_deg);
    previous_deg = fov_deg;
  }
  previous_deg = 180.0;
  for (const SensorFormat& format : sensor_formats()) {  // largest first
    const double fov_deg = field_of_view(50.0, format.width_mm, format.height_mm)->diagonal_deg;
    EXPECT_LT(fov_deg, previous_deg) << format.name;
    previous_deg = fov_deg;
  }
}

TEST(OpticsFieldOfView, ExtremeInputsStayInOpenRange) {
  for (const double focal_mm : {1e-300, 1e-6, 1.0, 1e6, 1e300}) {
    for (const double extent_mm : {1e-300, 1e-6, 1.0, 1e6, 1e300}) {
      auto fov = field_of_view_deg(extent_mm, focal_mm);
      ASSERT_TRUE(fov.ok());
      EXPECT_FALSE(std::isnan(*fov));
      EXPECT_GE(*fov, 0.0);
      EXPECT_LE(*fov, 180.0);
    }
  }
}

TEST(OpticsFieldOfView, RejectsInvalidInputs) {
  for (const double bad : {0.0, -5.0, kNaN, kInfinity, -kInfinity}) {
    expect_invalid(field_of_view_deg(36.0, bad), "focal_mm");
    expect_invalid(field_of_view_deg(bad, 50.0), "extent_mm");
    expect_invalid(field_of_view(bad, 36.0, 24.0), "focal_mm");
    expect_invalid(field_of_view(50.0, bad, 24.0), "sensor_width_mm");
    expect_invalid(field_of_view(50.0, 36.0, bad), "sensor_height_mm");
    expect_invalid(crop_factor(bad, 24.0), "sensor_width_mm");
    expect_invalid(crop_factor(36.0, bad), "sensor_height_mm");
    expect_invalid(equivalent_focal_mm(bad, 36.0, 24.0), "focal_mm");
    expect_invalid(equivalent_focal_mm(50.0, 36.0, bad), "sensor_height_mm");
  }
}

TEST(OpticsSensorFormats, FullFrameIsNominalAndMatchesReferenceDiagonal) {
  EXPECT_DOUBLE_EQ(kFullFrameDiagonal_mm, std::sqrt(36.0 * 36.0 + 24.0 * 24.0));
  auto ff = find_sensor_format("full-frame");
  ASSERT_TRUE(ff.ok());
  EXPECT_EQ(ff->width_mm, 36.0);
  EXPECT_EQ(ff->height_mm, 24.0);
  EXPECT_DOUBLE_EQ(*crop_factor(ff->width_mm, ff->height_mm), 1.0);
}

TEST(OpticsSensorFormats, CropFactorsMatchLectureTable) {
  // The table's printed row, in the table's order; each to its printed decimals.
  struct Printed {
    double crop;
    int decimals;
  };
  constexpr std::array<Printed, 9> kPrinted = {{{0.64, 2},
                                                {1.0, 1},
                                                {1.29, 2},
                                                {1.52, 2},
                                                {2.0, 1},
                                                {2.7, 1},
                                                {4.3, 1},
                                                {5.62, 2},
                                                {7.61, 2}}};
  const auto formats = sensor_formats();
  ASSERT_EQ(formats.size(), kPrinted.size());
  for (std::size_t i = 0; i < formats.size(); ++i) {
    const double crop = *crop_factor(formats[i].width_mm, formats[i].height_mm);
    // Half a unit of the last printed digit, plus slack for the table's own rounding
    // of medium format (0.6450 printed as 0.64).
    const double half_unit = 0.5 * std::pow(10.0, -kPrinted[i].decimals);
    EXPECT_NEAR(crop, kPrinted[i].crop, half_unit * 1.01) << formats[i].name;
  }
  auto apsc = find_sensor_format("aps-c");
  ASSERT_TRUE(apsc.ok());
  EXPECT_DOUBLE_EQ(round_to(*crop_factor(apsc->width_mm, apsc->height_mm), 2), 1.52);
}

TEST(OpticsSensorFormats, CropTimesDiagonalIsFullFrameDiagonal) {
  for (const SensorFormat& format : sensor_formats()) {
    const double crop = *crop_factor(format.width_mm, format.height_mm);
    EXPECT_NEAR(crop * diagonal_mm(format.width_mm, format.height_mm), kFullFrameDiagonal_mm, 1e-12)
        << format.name;
  }
}

TEST(OpticsSensorFormats, EquivalentFocalGivesSameDiagonalViewOnFullFrame) {
  for (const SensorFormat& format : sensor_formats()) {
    for (const double focal_mm : {4.5, 12.0, 25.0, 50.0}) {
      const double equivalent_mm =
          *equivalent_focal_mm(focal_mm, format.width_mm, format.height_mm);
      const double on_sensor_deg =
          field_of_view(focal_mm, format.width_mm, format.height_mm)->diagonal_deg;
      const double on_full_frame_deg = *field_of_view_deg(kFullFrameDiagonal_mm, equivalent_mm);
      EXPECT_NEAR(on_sensor_deg, on_full_frame_deg, 1e-10) << format.name << " " << focal_mm;
    }
  }
}

TEST(OpticsSensorFormats, TableIsLargestFirstAndNamesRoundTrip) {
  double previous_mm = kInfinity;
  for (const SensorFormat& format : sensor_formats()) {
    const double diag_mm = diagonal_mm(format.width_mm, format.height_mm);
    EXPECT_LT(diag_mm, previous_mm) << format.name;
    previous_mm = diag_mm;
    for (const std::string_view spelling : {format.name, format.label}) {
      auto found = find_sensor_format(spelling);
      ASSERT_TRUE(found.ok()) << spelling;
      EXPECT_EQ(found->name, format.name) << spelling;
    }
  }
}

TEST(OpticsSensorFormats, AcceptsCommonSpellings) {
  const std::array<std::pair<std::string_view, std::string_view>, 16> kCases = {{
      {"FF", "full-frame"},
      {"35mm", "full-frame"},
      {"Full Frame", "full-frame"},
      {"APS-C", "aps-c"},
      {"apsc", "aps-c"},
      {"aps_h", "aps-h"},
      {"4/3", "four-thirds"},
      {"m43", "four-thirds"},
      {"1\"", "1in"},
      {"1 inch", "1in"},
      {"1/2.3\"", "1/2.3in"},
      {"1/2.3", "1/2.3in"},
      {"1/1.63in", "1/1.63in"},
      {"1/3.2 in", "1/3.2in"},
      {"medium format", "medium-format"},
      {"Medium-Format", "medium-format"},
  }};
  for (const auto& [spelling, name] : kCases) {
    auto found = find_sensor_format(spelling);
    ASSERT_TRUE(found.ok()) << spelling;
    EXPECT_EQ(found->name, name) << spelling;
  }
}

TEST(OpticsSensorFormats, UnknownNameListsKnownFormats) {
  for (const std::string_view bad : {"", "apsq", "1/2.5in", "super35"}) {
    auto found = find_sensor_format(bad);
    ASSERT_FALSE(found.ok()) << bad;
    EXPECT_EQ(found.error().code, kErrUnknownSensor);
    EXPECT_NE(found.error().message.find("aps-c"), std::string::npos);
    EXPECT_NE(found.error().message.find(std::string("\"") + std::string(bad) + "\""),
              std::string::npos);
  }
}

}  // namespace fov_test
}  // namespace
}  // namespace camlab::optics
