// Slanted-edge finder: reduced-scale Canny + probabilistic Hough, collinear merge.
#include "analysis/edge/edge_finder.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/edge/segment_extent.h"

namespace camlab::analysis {
namespace {

struct Line {
  double ax, ay, bx, by;  // endpoints (reduced scale)
  double length() const { return std::hypot(bx - ax, by - ay); }
};

// Distance of a point from the infinite line through l.
double line_distance(const Line& l, double x, double y) {
  const double dx = l.bx - l.ax, dy = l.by - l.ay, len = std::hypot(dx, dy);
  return std::fabs((x - l.ax) * dy - (y - l.ay) * dx) / len;
}

double angle_of(const Line& l) { return std::atan2(l.by - l.ay, l.bx - l.ax); }

// Angle between undirected lines, in [0, pi/2].
double angle_between(const Line& a, const Line& b) {
  double d = std::fabs(std::remainder(angle_of(a) - angle_of(b), std::numbers::pi));
  return d;
}

// Merges b into a when collinear and overlapping or nearly touching: a's extent grows
// to cover both (projected on a's direction).
bool try_merge(Line* a, const Line& b) {
  constexpr double kMaxAngle = 2.0 * std::numbers::pi / 180.0, kMaxOffset = 2.0, kMaxGap = 4.0;
  if (angle_between(*a, b) > kMaxAngle) return false;
  if (line_distance(*a, b.ax, b.ay) > kMaxOffset || line_distance(*a, b.bx, b.by) > kMaxOffset)
    return false;
  const double len = a->length(), ux = (a->bx - a->ax) / len, uy = (a->by - a->ay) / len;
  auto t_of = [&](double x, double y) { return (x - a->ax) * ux + (y - a->ay) * uy; };
  const double t0 = t_of(b.ax, b.ay), t1 = t_of(b.bx, b.by);
  const double lo = std::min(t0, t1), hi = std::max(t0, t1);
  if (lo > len + kMaxGap || hi < -kMaxGap) return false;
  const double new_lo = std::min(0.0, lo), new_hi = std::max(len, hi);
  const double ox = a->ax, oy = a->ay;
  a->ax = ox + ux * new_lo;
  a->ay = oy + uy * new_lo;
  a->bx = ox + ux * new_hi;
  a->by = oy + uy * new_hi;
  return true;
}

// Whether parallel lines k and l are two ridges of one wide blurred edge rather than two
// edges: along their overlap, the smoothed image rises (or falls) steadily from k's line
// through the midway line to l's, in the same direction as the gradient at both lines. Two
// edges of a bar have opposite gradients; one wide edge (its gradient's flat top leaves
// ridges up to the blur's width apart) is a single ramp.
bool one_ramp(const cv::Mat& smooth, const Line& k, const Line& l) {
  const double len = k.length(), ux = (k.bx - k.ax) / len, uy = (k.by - k.ay) / len;
  const double lx = 0.5 * (l.ax + l.bx), ly = 0.5 * (l.ay + l.by);
  // Unit normal from k towards l.
  double nx = -uy, ny = ux;
  const double gap = (lx - k.ax) * nx + (ly - k.ay) * ny;
  if (gap < 0) nx = -nx, ny = -ny;
  const double d = std::fabs(gap);
  auto at = [&](double x, double y) {
    const int xi = std::clamp(static_cast<int>(std::lround(x)), 0, smooth.cols - 1);
    const int yi = std::clamp(static_cast<int>(std::lround(y)), 0, smooth.rows - 1);
    return static_cast<double>(smooth.at<float>(yi, xi));
  };
  int rising = 0, falling = 0, samples = 0;
  for (double t = 0.2; t <= 0.8; t += 0.1) {
    // A point on k within the overlap, and the points d/4 outside k, midway, and d/4
    // beyond l along the normal: four values that a single ramp orders monotonically.
    const double px = k.ax + ux * t * len, py = k.ay + uy * t * len;
    const double v[4] = {at(px - 0.25 * d * nx, py - 0.25 * d * ny), at(px, py),
                         at(px + 0.5 * d * nx, py + 0.5 * d * ny),
                         at(px + 1.25 * d * nx, py + 1.25 * d * ny)};
    ++samples;
    rising += v[0] < v[1] && v[1] < v[2] && v[2] < v[3];
    falling += v[0] > v[1] && v[1] > v[2] && v[2] > v[3];
  }
  return samples > 0 && std::max(rising, falling) >= samples - 1;
}

// Whether collinear pieces a and b (within 3 degrees, 3 reduced px of one line) are one
// edge with a gap in the detected pixels between them, as a wide blur's weak gradient
// leaves: at every point of the gap the image across the line steps the same way, by at
// least half the step at the pieces.
bool continues_across_gap(const cv::Mat& smooth, const Line& a, const Line& b) {
  if (angle_between(a, b) > 3.0 * std::numbers::pi / 180.0) return false;
  if (line_distance(a, b.ax, b.ay) > 3.0 || line_distance(a, b.bx, b.by) > 3.0) return false;
  const double len = a.length(), ux = (a.bx - a.ax) / len, uy = (a.by - a.ay) / len;
  const double nx = -uy, ny = ux, w = 3.0;
  auto at = [&](double x, double y) {
    const int xi = std::clamp(static_cast<int>(std::lround(x)), 0, smooth.cols - 1);
    const int yi = std::clamp(static_cast<int>(std::lround(y)), 0, smooth.rows - 1);
    return static_cast<double>(smooth.at<float>(yi, xi));
  };
  auto step_at = [&](double t) {
    const double px = a.ax + ux * t, py = a.ay + uy * t;
    return at(px + w * nx, py + w * ny) - at(px - w * nx, py - w * ny);
  };
  auto t_of = [&](double x, double y) { return (x - a.ax) * ux + (y - a.ay) * uy; };
  const double tb0 = t_of(b.ax, b.ay), tb1 = t_of(b.bx, b.by);
  const double gap_lo = tb0 > len ? len : std::max(tb0, tb1);
  const double gap_hi = tb0 > len ? std::min(tb0, tb1) : 0.0;
  const double from = std::min(gap_lo, gap_hi), to = std::max(gap_lo, gap_hi);
  if (to - from > len + b.length()) return false;  // a gap longer than the pieces
  const double reference = 0.5 * (step_at(0.5 * len) + step_at(0.5 * (tb0 + tb1)));
  if (std::fabs(reference) < 1e-6) return false;
  for (double t = from; t <= to; t += 1.0)
    if (step_at(t) / reference < 0.5) return false;
  return true;
}

// A bar narrower than the detection's scale (two edges within 5 reduced px) is found as
// one line, and a single-edge fit of it measures the bar's profile as one blurred step:
// a wrong diameter with a tight interval. So each line's profile across it is read at full
// resolution (the mean over the middle 60% of its length, every half pixel out to
// kBarReachPx): where both far ends lie at one level and the profile between them departs
// from it once (one dip or one peak, crossing its half level exactly twice), the line is
// a bar, and its two edges, at the half-level crossings, replace it; measure_edge() then
// fits them jointly (edge_pair.h), offsets included.
constexpr double kBarReachPx = 40.0, kBarFarBandPx = 6.0;

struct BarEdges {
  double first_px = 0, second_px = 0;  // offsets along the line's normal, first < second
};

std::optional<BarEdges> bar_across(const cv::Mat& full, const EdgeSegment& e) {
  const double dx = e.end_x_px - e.start_x_px, dy = e.end_y_px - e.start_y_px;
  const double len = std::hypot(dx, dy);
  if (len < 8) return std::nullopt;
  const double ux = dx / len, uy = dy / len, nx = -uy, ny = ux;
  constexpr double kStep = 0.5;
  const int n = static_cast<int>(2 * kBarReachPx / kStep) + 1;
  std::vector<double> profile(static_cast<size_t>(n), 0.0);
  int rows = 0;
  for (double t = 0.2 * len; t <= 0.8 * len; t += 1.0, ++rows)
    for (int k = 0; k < n; ++k) {
      const double o = -kBarReachPx + k * kStep;
      const double x = e.start_x_px + ux * t + nx * o, y = e.start_y_px + uy * t + ny * o;
      if (x < 0 || y < 0 || x > full.cols - 1 || y > full.rows - 1) return std::nullopt;
      const int x0 = std::min(static_cast<int>(x), full.cols - 2),
                y0 = std::min(static_cast<int>(y), full.rows - 2);
      const double ax = x - x0, ay = y - y0;
      profile[static_cast<size_t>(k)] +=
          (1 - ay) * ((1 - ax) * full.at<float>(y0, x0) + ax * full.at<float>(y0, x0 + 1)) +
          ay * ((1 - ax) * full.at<float>(y0 + 1, x0) + ax * full.at<float>(y0 + 1, x0 + 1));
    }
  if (rows == 0) return std::nullopt;
  for (double& v : profile) v /= rows;
  const int band = static_cast<int>(kBarFarBandPx / kStep);
  auto band_mean = [&](int from) {
    double sum = 0;
    for (int k = from; k < from + band; ++k) sum += profile[static_cast<size_t>(k)];
    return sum / band;
  };
  const double left = band_mean(0), right = band_mean(n - band);
  const double base = 0.5 * (left + right);
  double extreme = base;
  for (int k = band; k < n - band; ++k)
    if (std::fabs(profile[static_cast<size_t>(k)] - base) > std::fabs(extreme - base))
      extreme = profile[static_cast<size_t>(k)];
  const double depth = extreme - base;
  // One level both sides (a step's sides differ by its whole contrast), flat there (the
  // far bands' spread well under the depth), and a departure from it.
  double far_spread = 0;
  for (int k = 0; k < band; ++k)
    far_spread = std::max({far_spread, std::fabs(profile[static_cast<size_t>(k)] - left),
                           std::fabs(profile[static_cast<size_t>(n - 1 - k)] - right)});
  if (!(std::fabs(depth) > 0) || std::fabs(left - right) > 0.25 * std::fabs(depth) ||
      far_spread > 0.25 * std::fabs(depth))
    return std::nullopt;
  const double half = base + 0.5 * depth;
  std::vector<double> crossings;
  for (int k = 0; k + 1 < n; ++k) {
    const double a = profile[static_cast<size_t>(k)] - half,
                 b = profile[static_cast<size_t>(k + 1)] - half;
    if ((a < 0) != (b < 0)) crossings.push_back(-kBarReachPx + (k + a / (a - b)) * kStep);
  }
  if (crossings.size() != 2) return std::nullopt;
  return BarEdges{crossings[0], crossings[1]};
}

}  // namespace

std::vector<EdgeSegment> find_edges(const cv::Mat& image, const EdgeFinderOptions& options) {
  std::vector<EdgeSegment> out;
  if (image.empty() || image.channels() != 1) return out;
  const int scale = std::clamp(options.scale, 1, 16);
  // A float image is read in place: on a 12 MP frame the copy (48 MB, page-faulted in
  // afresh each call) cost more than finding the edges.
  cv::Mat f = image, small;
  if (image.type() != CV_32F) image.convertTo(f, CV_32F);
  if (scale > 1 && f.cols / scale >= 16 && f.rows / scale >= 16)
    cv::resize(f, small, cv::Size(f.cols / scale, f.rows / scale), 0, 0, cv::INTER_AREA);
  else
    small = f.clone();  // blurred in place below
  const double s = static_cast<double>(f.cols) / small.cols;
  cv::GaussianBlur(small, small, cv::Size(), 1.0);
  double lo = 0, hi = 0;
  cv::minMaxLoc(small, &lo, &hi);
  if (!(hi > lo)) return out;
  cv::Mat u8;
  small.convertTo(u8, CV_8U, 255.0 / (hi - lo), -255.0 * lo / (hi - lo));

  // Canny thresholds: above the noise of the Sobel gradient (kernel norm sqrt 12) and
  // above a fraction of the strongest edge.
  const cv::Matx33f mask(1, -2, 1, -2, 4, -2, 1, -2, 1);
  cv::Mat r, gx, gy, mag;
  cv::filter2D(u8, r, CV_32F, mask);
  const double sigma = std::sqrt(std::numbers::pi / 2.0) * cv::mean(cv::abs(r))[0] / 6.0;
  cv::Sobel(u8, gx, CV_32F, 1, 0);
  cv::Sobel(u8, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, mag);
  double max_mag = 0;
  cv::minMaxLoc(mag, nullptr, &max_mag);
  const double high = std::max(8.0 * sigma * std::sqrt(12.0), 0.15 * max_mag);
  cv::Mat edges;
  cv::Canny(u8, edges, 0.5 * high, high, 3, true);

  const double min_len_small = std::max(8.0, options.min_length_px / s);
  std::vector<cv::Vec4i> raw;
  cv::HoughLinesP(edges, raw, 1, std::numbers::pi / 360, static_cast<int>(min_len_small / 2),
                  0.5 * min_len_small, 3);
  std::vector<Line> lines;
  for (const cv::Vec4i& v : raw)
    lines.push_back({double(v[0]), double(v[1]), double(v[2]), double(v[3])});
  std::sort(lines.begin(), lines.end(),
            [](const Line& a, const Line& b) { return a.length() > b.length(); });
  std::vector<Line> merged;
  for (const Line& l : lines) {
    bool absorbed = false;
    for (Line& m : merged)
      if (try_merge(&m, l)) {
        absorbed = true;
        break;
      }
    if (!absorbed) merged.push_back(l);
  }
  // A second pass joins pieces that only met through later growth, and collinear pieces
  // the image shows to be one edge across a gap (continues_across_gap).
  for (size_t i = 0; i < merged.size(); ++i)
    for (size_t j = i + 1; j < merged.size();)
      if (try_merge(&merged[i], merged[j])) {
        merged.erase(merged.begin() + static_cast<long>(j));
      } else if (continues_across_gap(small, merged[i], merged[j])) {
        Line joined = merged[i];
        const double len = joined.length();
        const double ux = (joined.bx - joined.ax) / len, uy = (joined.by - joined.ay) / len;
        auto t_of = [&](double x, double y) { return (x - joined.ax) * ux + (y - joined.ay) * uy; };
        const double lo =
            std::min({0.0, t_of(merged[j].ax, merged[j].ay), t_of(merged[j].bx, merged[j].by)});
        const double hi =
            std::max({len, t_of(merged[j].ax, merged[j].ay), t_of(merged[j].bx, merged[j].by)});
        merged[i] = {joined.ax + ux * lo, joined.ay + uy * lo, joined.ax + ux * hi,
                     joined.ay + uy * hi};
        merged.erase(merged.begin() + static_cast<long>(j));
      } else {
        ++j;
      }
  std::sort(merged.begin(), merged.end(),
            [](const Line& a, const Line& b) { return a.length() > b.length(); });
  // A blurred edge's gradient has a flat top (a disk's line spread is a half-ellipse), on
  // which non-maximum suppression can leave two or three parallel ridges: lines within 3
  // degrees whose overlapping parts lie within 5 reduced px of each other are one edge,
  // and so are such lines farther apart (up to 40) when the image between them is one
  // ramp (a blur of tens of px; one_ramp). The longest is kept; the fit finds the true
  // position.
  std::vector<Line> kept;
  for (const Line& l : merged) {
    bool duplicate = false;
    for (const Line& k : kept) {
      if (angle_between(k, l) > 3.0 * std::numbers::pi / 180.0) continue;
      const double mx = 0.5 * (l.ax + l.bx), my = 0.5 * (l.ay + l.by);
      const double len = k.length(), ux = (k.bx - k.ax) / len, uy = (k.by - k.ay) / len;
      const double t = (mx - k.ax) * ux + (my - k.ay) * uy;
      if (t < 0 || t > len) continue;
      const double distance = line_distance(k, mx, my);
      if (distance < 5.0 || (distance < 40.0 && one_ramp(small, k, l))) {
        duplicate = true;
        break;
      }
    }
    if (!duplicate) kept.push_back(l);
  }
  merged = std::move(kept);
  // Back to full resolution: reduced pixel i covers full pixels [i s, i s + s - 1].
  const double shift = 0.5 * (s - 1.0);
  std::vector<EdgeSegment> found;
  for (const Line& l : merged) {
    if (l.length() * s < options.min_length_px) continue;
    EdgeSegment e;
    e.start_x_px = l.ax * s + shift;
    e.start_y_px = l.ay * s + shift;
    e.end_x_px = l.bx * s + shift;
    e.end_y_px = l.by * s + shift;
    const auto bar = bar_across(f, e);
    if (!bar) {
      found.push_back(e);
      continue;
    }
    const double len = std::hypot(e.end_x_px - e.start_x_px, e.end_y_px - e.start_y_px);
    const double nx = -(e.end_y_px - e.start_y_px) / len, ny = (e.end_x_px - e.start_x_px) / len;
    for (double offset : {bar->first_px, bar->second_px}) {
      EdgeSegment side = e;
      side.start_x_px += nx * offset, side.start_y_px += ny * offset;
      side.end_x_px += nx * offset, side.end_y_px += ny * offset;
      found.push_back(side);
    }
  }
  // A bar found as two lines gives its edges twice (from profiles read a pixel or two
  // apart): an edge parallel to one kept, whose middle lies within 3 px of it and within
  // its extent, is that edge again.
  for (const EdgeSegment& e : found) {
    const bool again = std::any_of(out.begin(), out.end(),
                                   [&](const EdgeSegment& k) { return piece_of_edge(e, k); });
    if (again) continue;
    if (static_cast<int>(out.size()) >= options.max_edges) break;
    out.push_back(e);
    out.back().name = "edge_" + std::to_string(out.size() - 1);
  }
  return out;
}

}  // namespace camlab::analysis
