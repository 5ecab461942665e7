// A found segment grown along its edge (src/analysis/edge/segment_extent.h), on squares
// drawn by a generator that shares nothing with it or the SFR (sfr_edges.h: a
// Gaussian-blurred square in closed form, 8 x 8 samples a pixel, noise at contrast-to-noise
// 50). The pieces stand in for the edge finder's: shorter than the side, a pixel off it and
// a few degrees askew, as its reduced-scale lines are.
#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "analysis/edge/segment_extent.h"
#include "analysis/sfr/slanted_edge_sfr.h"
#include "sfr_edges.h"

namespace camlab::analysis {
namespace {

using namespace sfr_edges;

// The middle `length_px` of the side from a to b, moved `offset_px` across it and turned
// `skew_deg` about its middle.
EdgeSegment piece(cv::Point2d a, cv::Point2d b, double length_px, double offset_px,
                  double skew_deg) {
  const cv::Point2d mid = 0.5 * (a + b), along = (b - a) / cv::norm(b - a);
  const double s = skew_deg * kPi / 180;
  const cv::Point2d turned{along.x * std::cos(s) - along.y * std::sin(s),
                           along.x * std::sin(s) + along.y * std::cos(s)};
  const cv::Point2d centre = mid + offset_px * cv::Point2d{-along.y, along.x};
  const cv::Point2d p = centre - 0.5 * length_px * turned, q = centre + 0.5 * length_px * turned;
  return {"piece", p.x, p.y, q.x, q.y, 0};
}

// Where `p` lies along the side from a to b (px from a) and how far off its line.
std::pair<double, double> on_side(cv::Point2d a, cv::Point2d b, cv::Point2d p) {
  const cv::Point2d along = (b - a) / cv::norm(b - a);
  const cv::Point2d d = p - a;
  return {d.dot(along), std::fabs(d.x * along.y - d.y * along.x)};
}

// A 44 px piece of each side of an 80 px square turned 37 deg (what the finder gave on the
// lens-map chart): the SFR reads no row of it (each row's 24 px window reaches 18 px along
// the edge, past the piece's ends), and grown it reaches within 8 px of both corners,
// never past them, on the side's line, and the SFR measures it to the truth.
TEST(SegmentExtent, APieceOfASideGrowsToTheWholeSide) {
  const Optics optics{false, 0.7};
  std::vector<cv::Point2d> corners;
  const cv::Mat image = draw_square(optics, 37, 80, 160, 5, 50, &corners);
  const double truth = true_mtf50(optics, 37);
  for (size_t k = 0; k < 4; ++k) {
    const cv::Point2d a = corners[k], b = corners[(k + 1) % 4];
    const EdgeSegment found = piece(a, b, 44, k % 2 ? 1.0 : -1.0, k < 2 ? 3.0 : -3.0);
    const auto before = slanted_edge_sfr(image, found);
    ASSERT_TRUE(before.ok());
    EXPECT_NE(before->status, "ok") << "side " << k;
    const std::vector<EdgeSegment> grown = extend_along_edges(image, {found});
    ASSERT_EQ(grown.size(), 1u);
    const EdgeSegment& g = grown.front();
    EXPECT_EQ(g.name, "piece");
    const auto [start_along, start_off] = on_side(a, b, {g.start_x_px, g.start_y_px});
    const auto [end_along, end_off] = on_side(a, b, {g.end_x_px, g.end_y_px});
    std::printf(
        "side %zu: grown from %.1f-%.1f px to %.1f-%.1f px of 0-80 (off the line %.2f, "
        "%.2f px)\n",
        k, 18.0, 62.0, start_along, end_along, start_off, end_off);
    EXPECT_GT(start_along, 0.0) << "side " << k;
    EXPECT_LT(start_along, 8.0) << "side " << k;
    EXPECT_GT(end_along, 72.0) << "side " << k;
    EXPECT_LT(end_along, 80.0) << "side " << k;
    EXPECT_LT(start_off, 0.5) << "side " << k;
    EXPECT_LT(end_off, 0.5) << "side " << k;
    const auto after = slanted_edge_sfr(image, g);
    ASSERT_TRUE(after.ok());
    ASSERT_EQ(after->status, "ok") << "side " << k << ": " << after->message;
    ASSERT_TRUE(after->mtf50_cy_px.has_value());
    EXPECT_NEAR(*after->mtf50_cy_px / truth, 1, 0.04) << "side " << k;
  }
}

// Two pieces of one side, grown, are that side once; pieces of different sides stay.
TEST(SegmentExtent, PiecesOfOneSideAreOneEdge) {
  const Optics optics{false, 0.7};
  std::vector<cv::Point2d> corners;
  const cv::Mat image = draw_square(optics, 30, 90, 160, 6, 50, &corners);
  EdgeSegment left = piece(corners[0], 0.7 * corners[0] + 0.3 * corners[1], 24, 0, 0);
  EdgeSegment right = piece(0.3 * corners[0] + 0.7 * corners[1], corners[1], 24, 0.5, 1);
  EdgeSegment other = piece(corners[1], corners[2], 40, 0, 0);
  left.name = "left", right.name = "right", other.name = "other";
  const std::vector<EdgeSegment> grown = extend_along_edges(image, {left, other, right});
  ASSERT_EQ(grown.size(), 2u);
  // The input's order kept: the side's surviving piece stands where it stood.
  const bool left_kept = grown[0].name == "left";
  EXPECT_EQ(grown[left_kept ? 1 : 0].name, "other");
  const EdgeSegment& side = grown[left_kept ? 0 : 1];
  EXPECT_TRUE(side.name == "left" || side.name == "right") << side.name;
  const auto [start_along, start_off] =
      on_side(corners[0], corners[1], {side.start_x_px, side.start_y_px});
  const auto [end_along, end_off] = on_side(corners[0], corners[1], {side.end_x_px, side.end_y_px});
  EXPECT_LT(std::min(start_along, end_along), 8.0);
  EXPECT_GT(std::max(start_along, end_along), 82.0);
}

// Two squares whose sides lie on one line, 20 px apart: a side grows to its own corners
// and not across the gap onto the other square's side; and a side that runs off the image
// stops inside it.
TEST(SegmentExtent, ASideStopsAtAGapAndAtTheImagesBorder) {
  constexpr int kWidth = 200, kHeight = 120;
  constexpr double kSigma = 0.8, kHalf = 40;
  const double angle = 12 * kPi / 180, ux = std::cos(angle), uy = std::sin(angle);
  // Centres along the shared direction: the first square's top side ends 20 px before the
  // second's begins; the second runs off the image's right border.
  const cv::Point2d first{70, 60}, second = first + (2 * kHalf + 20) * cv::Point2d{ux, uy};
  auto inside = [&](double t) {
    return 0.5 * (std::erf((t + kHalf) / (std::sqrt(2.0) * kSigma)) -
                  std::erf((t - kHalf) / (std::sqrt(2.0) * kSigma)));
  };
  cv::Mat image(kHeight, kWidth, CV_32F);
  std::mt19937 rng(9);
  std::normal_distribution<double> noise(0, 800.0 / 50);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x) {
      double sum = 0;
      for (int sy = 0; sy < kSub; ++sy)
        for (int sx = 0; sx < kSub; ++sx)
          for (const cv::Point2d& c : {first, second}) {
            const double px = x - 0.5 + (sx + 0.5) / kSub - c.x,
                         py = y - 0.5 + (sy + 0.5) / kSub - c.y;
            sum += inside(px * ux + py * uy) * inside(-px * uy + py * ux);
          }
      image.at<float>(y, x) = static_cast<float>(1000 - 800 * sum / (kSub * kSub) + noise(rng));
    }
  // The first square's top side, from its corner (-h, -h) to (h, -h) in its own axes.
  auto corner = [&](const cv::Point2d& c, double su, double sv) {
    return c + kHalf * cv::Point2d{su * ux - sv * uy, su * uy + sv * ux};
  };
  const cv::Point2d a = corner(first, -1, -1), b = corner(first, 1, -1);
  const std::vector<EdgeSegment> grown = extend_along_edges(image, {piece(a, b, 40, 0.5, 2)});
  ASSERT_EQ(grown.size(), 1u);
  const auto [start_along, start_off] = on_side(a, b, {grown[0].start_x_px, grown[0].start_y_px});
  const auto [end_along, end_off] = on_side(a, b, {grown[0].end_x_px, grown[0].end_y_px});
  std::printf("first square's top side grown to %.1f-%.1f px of 0-80\n", start_along, end_along);
  EXPECT_GT(start_along, 0.0);
  EXPECT_LT(end_along, 2 * kHalf);  // not over the 20 px gap
  EXPECT_GT(end_along, 2 * kHalf - 8);
  // The second square's top side leaves the image: grown, it stays on it.
  const cv::Point2d c = corner(second, -1, -1), d = corner(second, 1, -1);
  const std::vector<EdgeSegment> off =
      extend_along_edges(image, {piece(c, c + 0.5 * (d - c), 30, 0, 0)});
  ASSERT_EQ(off.size(), 1u);
  for (const double x : {off[0].start_x_px, off[0].end_x_px}) {
    EXPECT_GE(x, 0.0);
    EXPECT_LE(x, kWidth - 1.0);
  }
  for (const double y : {off[0].start_y_px, off[0].end_y_px}) {
    EXPECT_GE(y, 0.0);
    EXPECT_LE(y, kHeight - 1.0);
  }
}

}  // namespace
}  // namespace camlab::analysis
