// Sweeps of `camlab render --sweep`: listed values, added steps, and steps in stops
// multiplied as a photographer reads them (the README's aperture series read f/2, 3.41,
// 4.83 with an added step of 1.41421).
#include <gtest/gtest.h>

#include <cmath>

#include "mock_device/render/render_capture.h"

namespace camlab::mock {
namespace {

TEST(Sweep, StopsMultiplyAsPhotographersRead) {
  auto apertures = parse_sweep("f_number=2:11.4:stops");
  ASSERT_TRUE(apertures.ok()) << apertures.error().message;
  ASSERT_EQ(apertures->values.size(), 6u);
  for (size_t i = 0; i < 6; ++i)
    EXPECT_NEAR(apertures->values[i], 2 * std::pow(std::sqrt(2.0), i), 1e-12) << i;
  auto exposures = parse_sweep("exposure_us=1000:16000:stops");
  ASSERT_TRUE(exposures.ok());
  EXPECT_EQ(exposures->values, (std::vector<double>{1000, 2000, 4000, 8000, 16000}));
  auto thirds = parse_sweep("f_number=2:4:third-stops");
  ASSERT_TRUE(thirds.ok());
  ASSERT_EQ(thirds->values.size(), 7u);  // f/2 to f/4 is two stops: 6 thirds
  EXPECT_NEAR(thirds->values.back(), 4.0, 1e-9);
  auto ratio = parse_sweep("gain=8:1:x0.5");
  ASSERT_TRUE(ratio.ok());
  EXPECT_EQ(ratio->values, (std::vector<double>{8, 4, 2, 1}));
}

TEST(Sweep, AddedStepsAndListsAreAsWritten) {
  auto added = parse_sweep("focus_position=0:200:50");
  ASSERT_TRUE(added.ok());
  EXPECT_EQ(added->values, (std::vector<double>{0, 50, 100, 150, 200}));
  auto listed = parse_sweep("exposure_us=1000,3000");
  ASSERT_TRUE(listed.ok());
  EXPECT_EQ(listed->values, (std::vector<double>{1000, 3000}));
}

TEST(Sweep, BadRangesAreRefusedSayingWhy) {
  for (const char* bad :
       {"f_number=0:8:stops", "f_number=8:2:stops", "f_number=2:8:x1", "f_number=2:8:x-2",
        "f_number=2:8", "f_number=2:8:0", "exposure_us=1:1000000000:x1.0001", "=1,2"}) {
    auto sweep = parse_sweep(bad);
    EXPECT_FALSE(sweep.ok()) << bad;
  }
}

}  // namespace
}  // namespace camlab::mock
