// f-stop series and exposure arithmetic: H = T x E with E ~ 1/N^2, gain linear in ISO.
#include <array>
#include <cmath>
#include <cstddef>
#include <limits>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <gtest/gtest.h>

#include "optics/optics.h"

namespace camlab::optics {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace exposure_test {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

constexpr std::array<double, 11> kFullMarks = {1, 1.4, 2, 2.8, 4, 5.6, 8, 11, 16, 22, 32};

template <class T>
void expect_invalid(const Result<T>& result, std::string_view name) {
  ASSERT_FALSE(result.ok()) << name;
  EXPECT_EQ(result.error().code, kErrInvalidArgument);
  EXPECT_NE(result.error().message.find(name), std::string::npos) << result.error().message;
}

TEST(OpticsFStops, SeriesLengthsEndAtF32) {
  const std::array<std::pair<StopIncrement, std::size_t>, 3> kCases = {
      {{StopIncrement::kFull, 11}, {StopIncrement::kHalf, 21}, {StopIncrement::kThird, 31}}};
  for (const auto& [increment, count] : kCases) {
    const std::vector<FStop> series = f_stop_series(increment);
    ASSERT_EQ(series.size(), count);
    EXPECT_EQ(series.front().exact, 1.0);
    EXPECT_EQ(series.back().exact, 32.0);
    EXPECT_EQ(series.back().marked, 32.0);
  }
}

TEST(OpticsFStops, ExactStopsAreRootTwoPowersAndMarksAreClose) {
  for (const StopIncrement increment :
       {StopIncrement::kFull, StopIncrement::kHalf, StopIncrement::kThird}) {
    const int n = static_cast<int>(increment);
    const std::vector<FStop> series = f_stop_series(increment);
    for (std::size_t k = 0; k < series.size(); ++k) {
      // sqrt(2)^(k/n) through pow rather than exp2.
      EXPECT_NEAR(series[k].exact, std::pow(std::sqrt(2.0), static_cast<double>(k) / n), 1e-12);
      // The engraved marks round the exact value by at most 5% (1.2 for 1.26, 13 for 13.45).
      EXPECT_NEAR(series[k].marked / series[k].exact, 1.0, 0.05) << k;
      if (k > 0) {
        EXPECT_GT(series[k].marked, series[k - 1].marked);
        // Each step is 1/n stop: the light changes by 2^(1/n).
        const double light_ratio = std::pow(series[k].exact / series[k - 1].exact, 2.0);
        EXPECT_NEAR(light_ratio, std::exp2(1.0 / n), 1e-12);
      }
    }
  }
}

TEST(OpticsFStops, FullStopsAppearInHalfAndThirdSeries) {
  const std::vector<FStop> full = f_stop_series(StopIncrement::kFull);
  const std::vector<FStop> half = f_stop_series(StopIncrement::kHalf);
  const std::vector<FStop> third = f_stop_series(StopIncrement::kThird);
  for (std::size_t j = 0; j < kFullMarks.size(); ++j) {
    EXPECT_EQ(full[j].marked, kFullMarks[j]);
    EXPECT_EQ(half[2 * j].marked, kFullMarks[j]);
    EXPECT_EQ(third[3 * j].marked, kFullMarks[j]);
    EXPECT_DOUBLE_EQ(half[2 * j].exact, full[j].exact);
    EXPECT_DOUBLE_EQ(third[3 * j].exact, full[j].exact);
  }
  // Spot checks of the intermediate marks from the table.
  EXPECT_EQ(half[3].marked, 1.7);
  EXPECT_EQ(half[13].marked, 9.5);
  EXPECT_EQ(third[1].marked, 1.1);
  EXPECT_EQ(third[16].marked, 6.3);
  EXPECT_EQ(third[29].marked, 29.0);
}

TEST(OpticsFStops, MaximumLimitsTheSeries) {
  const std::vector<FStop> to_f8 = f_stop_series(StopIncrement::kFull, 8.0);
  ASSERT_EQ(to_f8.size(), 7u);
  EXPECT_EQ(to_f8.back().marked, 8.0);
  // f/22's exact value is 22.63: a maximum typed as 22 stops at f/16.
  EXPECT_EQ(f_stop_series(StopIncrement::kFull, 22.0).back().marked, 16.0);
  // Beyond the table: exact powers of sqrt 2, marked to two digits.
  const std::vector<FStop> to_f64 = f_stop_series(StopIncrement::kFull, 64.0);
  ASSERT_EQ(to_f64.size(), 13u);
  EXPECT_NEAR(to_f64[11].exact, 32.0 * std::sqrt(2.0), 1e-12);
  EXPECT_EQ(to_f64[11].marked, 45.0);
  EXPECT_EQ(to_f64[12].marked, 64.0);
  // Nonsense maxima give no stops rather than garbage.
  EXPECT_TRUE(f_stop_series(StopIncrement::kFull, 0.5).empty());
  EXPECT_TRUE(f_stop_series(StopIncrement::kFull, kNaN).empty());
  EXPECT_TRUE(f_stop_series(StopIncrement::kFull, -1.0).empty());
  EXPECT_LE(f_stop_series(StopIncrement::kThird, kInfinity).size(), 61u);  // bounded
}

TEST(OpticsExposure, ExposureValueMatchesDefinition) {
  EXPECT_EQ(*exposure_value(1.0, 1.0), 0.0);
  // Sunny 16: f/16 at 1/100 s is EV 14.64.
  EXPECT_NEAR(*exposure_value(16.0, 0.01), std::log2(16.0 * 16.0 / 0.01), 1e-12);
  EXPECT_NEAR(*exposure_value(16.0, 0.01), 14.64, 0.005);
  // One stop: half the time, or N x sqrt 2, is +1 EV.
  EXPECT_NEAR(*exposure_value(5.6, 1.0 / 250) - *exposure_value(5.6, 1.0 / 125), 1.0, 1e-12);
  EXPECT_NEAR(*exposure_value(4.0 * std::sqrt(2.0), 0.01) - *exposure_value(4.0, 0.01), 1.0, 1e-12);
  // Extremes: the log of the ratio, computed without forming the ratio.
  auto extreme = exposure_value(1e200, 1e-200);
  ASSERT_TRUE(extreme.ok());
  EXPECT_NEAR(*extreme, 3.0 * 200.0 * std::log2(10.0), 1e-9);
}

TEST(OpticsExposure, RelativeExposureIsTimeOverNSquared) {
  EXPECT_EQ(*relative_exposure(1.0, 1.0), 1.0);
  EXPECT_DOUBLE_EQ(*relative_exposure(4.0, 0.5), 0.5 / 16.0);
  // EV and relative exposure carry the same information: EV = -log2(T / N^2).
  for (const double n : {1.4, 2.8, 8.0, 22.0}) {
    for (const double t_s : {1e-4, 1.0 / 60, 2.0}) {
      EXPECT_NEAR(*exposure_value(n, t_s), -std::log2(*relative_exposure(n, t_s)), 1e-12);
    }
  }
}

TEST(OpticsExposure, EquivalentExposureKeepsSignalConstant) {
  // f/2.8 -> f/5.6 is two stops: four times the time.
  EXPECT_NEAR(*equivalent_exposure_s(0.01, 2.8, 1.0, 5.6, 1.0), 0.04, 1e-15);
  // ISO 100 -> 200 halves the time.
  const double g100 = *gain_from_iso(100.0);
  const double g200 = *gain_from_iso(200.0);
  EXPECT_DOUBLE_EQ(*equivalent_exposure_s(0.01, 4.0, g100, 4.0, g200), 0.005);
  // The invariant: signal ~ gain x T / N^2 is the same before and after.
  for (const double n2 : {1.0, 2.0, 3.3, 11.0, 32.0}) {
    for (const double iso2 : {50.0, 100.0, 640.0, 6400.0}) {
      const double g2 = *gain_from_iso(iso2);
      const double t2_s = *equivalent_exposure_s(1.0 / 125, 8.0, g100, n2, g2);
      EXPECT_NEAR(g2 * *relative_exposure(n2, t2_s) / (g100 * *relative_exposure(8.0, 1.0 / 125)),
                  1.0, 1e-13);
      // And it round-trips.
      EXPECT_NEAR(*equivalent_exposure_s(t2_s, n2, g2, 8.0, g100) * 125.0, 1.0, 1e-13);
    }
  }
}

TEST(OpticsExposure, GainAndPhotometricExposure) {
  EXPECT_EQ(*gain_from_iso(400.0), 4.0);
  EXPECT_EQ(*gain_from_iso(400.0, 200.0), 2.0);
  EXPECT_EQ(*photometric_exposure_lux_s(1000.0, 0.01), 10.0);
}

TEST(OpticsExposure, RejectsInvalidInputs) {
  for (const double bad : {0.0, -1.0, kNaN, kInfinity, -kInfinity}) {
    expect_invalid(exposure_value(bad, 0.01), "f_number");
    expect_invalid(exposure_value(8.0, bad), "exposure_s");
    expect_invalid(relative_exposure(bad, 0.01), "f_number");
    expect_invalid(relative_exposure(8.0, bad), "exposure_s");
    expect_invalid(photometric_exposure_lux_s(bad, 0.01), "illuminance_lux");
    expect_invalid(photometric_exposure_lux_s(100.0, bad), "exposure_s");
    expect_invalid(equivalent_exposure_s(bad, 8.0, 1.0, 4.0, 1.0), "exposure_s");
    expect_invalid(equivalent_exposure_s(0.01, bad, 1.0, 4.0, 1.0), "f_number");
    expect_invalid(equivalent_exposure_s(0.01, 8.0, bad, 4.0, 1.0), "gain");
    expect_invalid(equivalent_exposure_s(0.01, 8.0, 1.0, bad, 1.0), "new_f_number");
    expect_invalid(equivalent_exposure_s(0.01, 8.0, 1.0, 4.0, bad), "new_gain");
    expect_invalid(gain_from_iso(bad), "iso");
    expect_invalid(gain_from_iso(100.0, bad), "base_iso");
  }
  // A result beyond double is an error, not infinity or NaN.
  auto overflow = equivalent_exposure_s(1e300, 1e-100, 1.0, 1e100, 1.0);
  ASSERT_FALSE(overflow.ok());
  EXPECT_EQ(overflow.error().code, kErrInvalidArgument);
}

}  // namespace exposure_test
}  // namespace
}  // namespace camlab::optics
