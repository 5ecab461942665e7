// Blur at low signal (contrast-to-noise about 4 per pixel), on edges drawn independently
// of camlab's edge model (analytic_edge.h): the measurement carries a low-signal flag and
// its 95% intervals cover the truth in at least 90% of fits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <random>

#include "analysis/edge/edge_measure.h"
#include "analytic_edge.h"

namespace camlab::analysis {
namespace {

TEST(LowSignal, IntervalsCoverTheTruthAndTheFlagIsSet) {
  const int size = 200;
  const double centre = (size - 1) / 2.0;
  const double angle = 4.0 * std::numbers::pi / 180.0, nx = std::cos(angle), ny = -std::sin(angle);
  const double dark = 100, light = 140, noise_dn = 10;  // CNR 4
  std::mt19937 rng(21);
  std::normal_distribution<double> noise(0, noise_dn);
  int fits = 0, covered = 0, flagged = 0;
  double sum_relative = 0;
  for (double diameter : {3.0, 5.0, 8.0, 12.0, 18.0, 26.0})
    for (int draw = 0; draw < 12; ++draw) {
      cv::Mat image(size, size, CV_32F);
      for (int y = 0; y < size; ++y)
        for (int x = 0; x < size; ++x) {
          const double d = (x - centre) * nx + (y - centre) * ny;
          image.at<float>(y, x) = static_cast<float>(
              dark + (light - dark) * testing::pixel_light_fraction(d, diameter, nx, ny, 8) +
              noise(rng));
        }
      EdgeSegment edge;
      edge.name = "edge";
      edge.start_x_px = centre - ny * -80;
      edge.start_y_px = centre + nx * -80;
      edge.end_x_px = centre - ny * 80;
      edge.end_y_px = centre + nx * 80;
      auto m = measure_edge(image, edge, {}, {});
      ASSERT_TRUE(m.ok()) << m.error().message;
      if (m->status != kEdgeOk) continue;
      ++fits;
      covered += m->ci_low_px <= diameter && diameter <= m->ci_high_px;
      flagged += m->low_signal;
      sum_relative += m->diameter_px / diameter - 1;
    }
  if (std::getenv("CAMLAB_EDGE_REPORT"))
    std::cout << fits << " fits, " << covered << " covered by their 95% interval, " << flagged
              << " flagged low-signal, mean relative error " << sum_relative / fits << "\n";
  ASSERT_GE(fits, 60) << "most edges are measured at CNR 4";
  EXPECT_GE(covered, 0.9 * fits);
  EXPECT_EQ(flagged, fits) << "every fit at CNR 4 carries the flag";
}

}  // namespace
}  // namespace camlab::analysis
