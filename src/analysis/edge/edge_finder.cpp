// Slanted-edge finder: reduced-scale Canny + probabilistic Hough, collinear merge.
#include "analysis/edge/edge_finder.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

}  // namespace

std::vector<EdgeSegment> find_edges(const cv::Mat& image, const EdgeFinderOptions& options) {
  std::vector<EdgeSegment> out;
  if (image.empty() || image.channels() != 1) return out;
  const int scale = std::clamp(options.scale, 1, 16);
  cv::Mat f, small;
  image.convertTo(f, CV_32F);
  if (scale > 1 && f.cols / scale >= 16 && f.rows / scale >= 16)
    cv::resize(f, small, cv::Size(f.cols / scale, f.rows / scale), 0, 0, cv::INTER_AREA);
  else
    small = f;
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
  // A second pass joins pieces that only met through later growth.
  for (size_t i = 0; i < merged.size(); ++i)
    for (size_t j = i + 1; j < merged.size();)
      if (try_merge(&merged[i], merged[j]))
        merged.erase(merged.begin() + static_cast<long>(j));
      else
        ++j;
  std::sort(merged.begin(), merged.end(),
            [](const Line& a, const Line& b) { return a.length() > b.length(); });
  // A blurred edge's gradient has a flat top (a disk's line spread is a half-ellipse), on
  // which non-maximum suppression can leave two or three parallel ridges: lines within 3
  // degrees whose overlapping parts lie within 5 reduced px of each other are one edge
  // (the longest is kept; the fit finds the true position).
  std::vector<Line> kept;
  for (const Line& l : merged) {
    bool duplicate = false;
    for (const Line& k : kept) {
      if (angle_between(k, l) > 3.0 * std::numbers::pi / 180.0) continue;
      const double mx = 0.5 * (l.ax + l.bx), my = 0.5 * (l.ay + l.by);
      const double len = k.length(), ux = (k.bx - k.ax) / len, uy = (k.by - k.ay) / len;
      const double t = (mx - k.ax) * ux + (my - k.ay) * uy;
      if (t < 0 || t > len) continue;
      if (line_distance(k, mx, my) < 5.0) {
        duplicate = true;
        break;
      }
    }
    if (!duplicate) kept.push_back(l);
  }
  merged = std::move(kept);
  // Back to full resolution: reduced pixel i covers full pixels [i s, i s + s - 1].
  const double shift = 0.5 * (s - 1.0);
  for (const Line& l : merged) {
    if (l.length() * s < options.min_length_px) continue;
    if (static_cast<int>(out.size()) >= options.max_edges) break;
    EdgeSegment e;
    e.name = "edge_" + std::to_string(out.size());
    e.start_x_px = l.ax * s + shift;
    e.start_y_px = l.ay * s + shift;
    e.end_x_px = l.bx * s + shift;
    e.end_y_px = l.by * s + shift;
    out.push_back(e);
  }
  return out;
}

}  // namespace camlab::analysis
