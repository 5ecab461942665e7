// Dark bars 4 to 40 px wide under disks up to 3x their width, drawn here by a generator
// that shares nothing with the analysis: each pixel the mean of 4 x 4 point samples, each
// sample the exact share of a disk on the light side of the bar (the area of a circular
// segment), plus Gaussian noise at contrast-to-noise 50. Both edges are listed, as a
// capture's truth lists them. Each edge's diameter must be within 2% (or 0.05 px) of the
// truth, or within its interval widened 2x, or flagged (not measured, with the reason):
// never a tight interval on a wrong value.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "analysis/edge/edge_finder.h"
#include "analysis/edge/edge_measure.h"

namespace camlab::analysis {
namespace {

// The share of a disk of radius r whose centre lies at signed distance d from a line that
// falls on the line's positive side: (r^2 acos(-d/r) + d sqrt(r^2 - d^2)) / (pi r^2).
double disk_share_beyond(double d, double r) {
  if (d >= r) return 1;
  if (d <= -r) return 0;
  return (r * r * std::acos(-d / r) + d * std::sqrt(r * r - d * d)) / (M_PI * r * r);
}

struct Bar {
  cv::Mat image;
  std::vector<EdgeSegment> edges;  // left, right
};

// A dark bar (level 200) on light ground (1000), `width` px wide, 3 deg off the pixel
// columns, under a disk of `diameter` px.
Bar draw_bar(double width, double diameter, unsigned seed) {
  // Edges listed over D + 30 px each side of the middle (at least 70): room for a window
  // clear of twice the blur from the listed ends (edge/edge_measure.h), and no larger, as a longer
  // window costs time and tells nothing more.
  const double half = std::max(70.0, diameter + 30);
  const int size = static_cast<int>(std::max({200.0, 2 * (diameter + width) + 90, 2 * half + 40}));
  const double angle = 93.0 * M_PI / 180.0, c = std::cos(angle), s = std::sin(angle);
  const double cx = 0.5 * size + 0.3 - 0.5 * width, cy = 0.5 * size;
  Bar bar;
  bar.image.create(size, size, CV_32F);
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0, 800.0 / 50);
  for (int y = 0; y < size; ++y)
    for (int x = 0; x < size; ++x) {
      double light = 0;
      for (int sy = 0; sy < 4; ++sy)
        for (int sx = 0; sx < 4; ++sx) {
          const double px = x - 0.5 + (sx + 0.5) / 4, py = y - 0.5 + (sy + 0.5) / 4;
          const double u = (px - cx) * s - (py - cy) * c;  // across the bar, from its left edge
          const double in_bar =
              disk_share_beyond(u, 0.5 * diameter) - disk_share_beyond(u - width, 0.5 * diameter);
          light += 1 - in_bar;
        }
      bar.image.at<float>(y, x) = static_cast<float>(200 + 800 * light / 16 + noise(rng));
    }
  for (double offset : {0.0, width}) {
    const double ox = cx + offset * s, oy = cy - offset * c;
    bar.edges.push_back({offset == 0 ? "left" : "right", ox - half * c, oy - half * s,
                         ox + half * c, oy + half * s, 0});
  }
  return bar;
}

TEST(BarGrid, DiameterRightOrFlaggedForBarsAsNarrowAsAThirdOfTheBlur) {
  int measured = 0, flagged = 0;
  unsigned seed = 1;
  for (double width : {4.0, 8.0, 16.0, 30.0, 40.0})
    for (double ratio : {0.5, 1.5, 3.0}) {
      const double truth = ratio * width;
      const Bar bar = draw_bar(width, truth, seed++);
      for (const EdgeSegment& edge : bar.edges) {
        auto m = measure_edge(bar.image, edge, bar.edges, {});
        ASSERT_TRUE(m.ok()) << m.error().message;
        if (m->status != kEdgeOk) {
          ++flagged;
          EXPECT_FALSE(m->message.empty());
          std::printf("bar %4.0f px, D %5.1f px, %-5s: flagged %s\n", width, truth,
                      edge.name.c_str(), m->status.c_str());
          continue;
        }
        ++measured;
        const double error = m->diameter_px - truth;
        const double tolerance = std::max(0.05, 0.02 * truth);
        const double low = m->diameter_px - 2 * (m->diameter_px - m->ci_low_px),
                     high = m->diameter_px + 2 * (m->ci_high_px - m->diameter_px);
        std::printf("bar %4.0f px, D %5.1f px, %-5s: %.3f px (%+.2f%%), 95%% [%.3f, %.3f]%s\n",
                    width, truth, edge.name.c_str(), m->diameter_px, 100 * error / truth,
                    m->ci_low_px, m->ci_high_px, m->joint_with.empty() ? "" : ", joint");
        EXPECT_TRUE(std::fabs(error) <= tolerance || (truth >= low && truth <= high))
            << "bar " << width << " px, D " << truth << " px, " << edge.name << ": "
            << m->diameter_px << " [" << m->ci_low_px << ", " << m->ci_high_px << "]";
      }
    }
  // Flagging is the exception, not the way the test passes: where the bar is 2/3 of the
  // blur its width and the blur trade (the joint fit is ill-conditioned) and both edges
  // are flagged; at half and three times the width both are measured (20 of 30 edges; on
  // a finer grid, 38 of 50, flagged from 1 to 1.5x).
  EXPECT_GE(measured, 2 * flagged);
}

// The same bars with no geometry given, as a capture whose truth lists no edges: the edge
// finder sees a bar narrower than its detection scale (20 px) as one line, and a
// single-edge fit of that line read a dark 8 px bar under D = 3, 6 and 12 px as 2.4 px
// (-20%, a tight interval) or not at all. The finder now reads the line's profile, finds
// the bar, and hands over its two edges, which are fitted jointly.
TEST(BarGrid, FoundWithoutGeometryABarIsTwoEdgesRightOrFlagged) {
  int measured = 0, flagged = 0;
  unsigned seed = 100;
  for (double width : {4.0, 8.0, 16.0})
    for (double diameter : {0.375 * width, 0.75 * width, 1.5 * width}) {
      const Bar bar = draw_bar(width, diameter, seed++);
      const std::vector<EdgeSegment> found = find_edges(bar.image, {});
      ASSERT_FALSE(found.empty()) << "bar " << width << " px, D " << diameter << " px";
      int measured_here = 0;
      for (const EdgeSegment& edge : found) {
        auto m = measure_edge(bar.image, edge, found, {});
        ASSERT_TRUE(m.ok()) << m.error().message;
        if (m->status != kEdgeOk) {
          ++flagged;
          std::printf("found, bar %4.0f px, D %5.2f px, %s: flagged %s\n", width, diameter,
                      edge.name.c_str(), m->status.c_str());
          continue;
        }
        ++measured, ++measured_here;
        const double error = m->diameter_px - diameter;
        const double low = m->diameter_px - 2 * (m->diameter_px - m->ci_low_px),
                     high = m->diameter_px + 2 * (m->ci_high_px - m->diameter_px);
        std::printf("found, bar %4.0f px, D %5.2f px, %s: %.3f px (%+.2f%%), 95%% [%.3f, %.3f]%s\n",
                    width, diameter, edge.name.c_str(), m->diameter_px, 100 * error / diameter,
                    m->ci_low_px, m->ci_high_px, m->joint_with.empty() ? "" : ", joint");
        EXPECT_TRUE(std::fabs(error) <= std::max(0.05, 0.02 * diameter) ||
                    (diameter >= low && diameter <= high))
            << "bar " << width << " px, D " << diameter << " px, " << edge.name << ": "
            << m->diameter_px << " [" << m->ci_low_px << ", " << m->ci_high_px << "]";
      }
      // Where the blur is under the bar's width both edges are found and measured.
      if (diameter < width) {
        EXPECT_EQ(measured_here, 2) << "bar " << width << ", D " << diameter;
      }
    }
  EXPECT_GE(measured, 2 * flagged);
}

}  // namespace
}  // namespace camlab::analysis
