#include "calib/corners/board_ring.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <opencv2/imgproc.hpp>

#include "calib/corners/tone_sampling.h"

namespace camlab::calib {

namespace {

// A ring alternates along a side when this share of its cells do: a hand or a clip over
// part of an edge square leaves the rest.
constexpr double kAlternatingShare = 0.7;

// A cell's tone: the mean of five samples (its centre, and 25% of the way from it to
// each corner), and their spread (max - min).
struct CellTone {
  float mean = 0, spread = 0;
};
CellTone cell_tone(const cv::Mat& f, const std::array<cv::Point2f, 4>& corners) {
  const cv::Point2f centre = 0.25f * (corners[0] + corners[1] + corners[2] + corners[3]);
  float lo = sample_bilinear(f, centre), hi = lo, sum = lo;
  for (const auto& c : corners) {
    const float v = sample_bilinear(f, centre + 0.25f * (c - centre));
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    sum += v;
  }
  return {sum / 5, hi - lo};
}

bool inside_image(const cv::Mat& f, cv::Point2f p) {
  return p.x >= 0 && p.y >= 0 && p.x <= f.cols - 1 && p.y <= f.rows - 1;
}

}  // namespace

cv::Mat ring_tone_image(const cv::Mat& gray8, double sigma_px) {
  cv::Mat tone;
  gray8.convertTo(tone, CV_32F, 1.0 / 255);
  cv::GaussianBlur(tone, tone, cv::Size(), sigma_px);
  return tone;
}

std::array<double, 4> ring_alternation(const cv::Mat& tone,
                                       const std::function<cv::Point2f(int, int)>& corner, int w,
                                       int h, int ring) {
  // One side: edge corners (i, j) + s (di, dj), s = 0..len-1; (ni, nj) steps inward.
  auto side = [&](int i, int j, int di, int dj, int ni, int nj, int len) {
    // Line k of the side: k = 0 its corners, k < 0 inward, k > 0 outward by straight steps.
    // Outward, each step is the last one scaled by the ratio of the last two (squares
    // shrink or grow geometrically under perspective: a straight step overshoots by 15%
    // of a square on a steep view's far side), where the grid has three corners inward.
    const int depth = (ni != 0 ? w : h);
    auto line = [&](int s, int k) {
      const int a = i + s * di, b = j + s * dj;
      const cv::Point2f p0 = corner(a, b), p1 = corner(a + ni, b + nj);
      if (k <= 0) return k == 0 ? p0 : p0 + static_cast<float>(k) * (p0 - p1);
      float ratio = 1;
      if (depth >= 3) {
        const float last = static_cast<float>(cv::norm(p0 - p1)),
                    before = static_cast<float>(cv::norm(p1 - corner(a + 2 * ni, b + 2 * nj)));
        if (before > 0) ratio = std::clamp(last / before, 0.7f, 1.3f);
      }
      float steps = 0, step = 1;
      for (int m = 0; m < k; ++m) steps += (step *= ratio);
      return p0 + steps * (p0 - p1);
    };
    // Ring r's cell between corners s and s + 1: its four corners.
    auto cell = [&](int s, int r) {
      return std::array<cv::Point2f, 4>{line(s, r - 1), line(s + 1, r - 1), line(s + 1, r),
                                        line(s, r)};
    };
    int cells = 0, alternating = 0;
    float previous_tone = 0, previous_contrast = 0;
    bool previous_inside = false;
    for (int s = 0; s + 1 < len; ++s) {
      ++cells;
      const auto out = cell(s, ring), in = cell(s, ring - 1);
      if (!std::all_of(out.begin(), out.end(),
                       [&](cv::Point2f p) { return inside_image(tone, p); })) {
        previous_inside = false;
        continue;
      }
      // The board's contrast beside the cell: across the grid's outermost line, between an
      // edge square and the square inward of it (always of opposite tones). Not at the
      // cell's own border: past a light edge square the margin continues its tone, the
      // contrast there is the paper's grain, and a quarter of it calls any shade a change.
      const cv::Point2f a = line(s, 0), b = line(s + 1, 0);
      const float contrast =
          contrast_around(tone, 0.5f * (a + b), 0.35f * static_cast<float>(cv::norm(b - a)));
      const CellTone tone_out = cell_tone(tone, out), tone_in = cell_tone(tone, in);
      // Past the edge squares a square is one tone across: a cell across the border of a
      // margin and the background (a margin half a square wide puts that border at ring
      // 2's centre) is not. Ring 1's cells are the edge squares, read at their centre only:
      // on a steep view the steps out miss their outer side by a fifth of a square.
      const bool uniform = ring == 1 || tone_out.spread < 0.25f * contrast;
      const bool unlike_inward =
          uniform && std::fabs(tone_out.mean - tone_in.mean) > 0.25f * contrast;
      const bool unlike_previous =
          !previous_inside ||
          std::fabs(tone_out.mean - previous_tone) > 0.25f * std::min(contrast, previous_contrast);
      if (unlike_inward && unlike_previous) ++alternating;
      previous_tone = tone_out.mean;
      previous_contrast = contrast;
      previous_inside = true;
    }
    return cells > 0 ? static_cast<double>(alternating) / cells : 0.0;
  };
  return {side(0, 0, 1, 0, 0, 1, w), side(0, h - 1, 1, 0, 0, -1, w), side(0, 0, 0, 1, 1, 0, h),
          side(w - 1, 0, 0, 1, -1, 0, h)};
}

bool ringed_by_squares(const std::array<double, 4>& ring1_shares) {
  return std::all_of(ring1_shares.begin(), ring1_shares.end(),
                     [](double s) { return s >= kAlternatingShare; });
}

bool board_goes_on(const std::array<double, 4>& ring2_shares) {
  return std::any_of(ring2_shares.begin(), ring2_shares.end(),
                     [](double s) { return s >= kAlternatingShare; });
}

}  // namespace camlab::calib
