#include "analysis/edge/segment_extent.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <optional>

#include <opencv2/core.hpp>
#include <opencv2/core/utility.hpp>

namespace camlab::analysis {
namespace {

constexpr double kProfileStepPx = 0.5;        // samples across the line
constexpr double kMinContrastFraction = 0.5;  // of the segment's own profiles' median
constexpr int kSmoothPx = 2;                  // profiles averaged each side along the edge
constexpr double kBackOffPx = 2;  // the grown end's distance from the half-contrast point

// Bilinear sample; nullopt off the image.
std::optional<double> sample(const cv::Mat& image, double x, double y) {
  if (!(x >= 0 && y >= 0 && x <= image.cols - 1 && y <= image.rows - 1)) return std::nullopt;
  const int x0 = std::min(static_cast<int>(x), image.cols - 2),
            y0 = std::min(static_cast<int>(y), image.rows - 2);
  const double fx = x - x0, fy = y - y0;
  const float* r0 = image.ptr<float>(y0);
  const float* r1 = image.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) +
         fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

struct Profile {
  double contrast = 0;  // far side minus near side (along the normal)
  double centre = 0;    // px along the normal from the line: the derivative's centroid
};

// The segment's middle, its unit direction and its unit normal.
struct Geometry {
  double mid_x, mid_y, ux, uy, nx, ny;
};

// The profile across the line at `along` px from the middle: nullopt where it leaves the
// image or shows no step.
std::optional<Profile> profile_at(const cv::Mat& image, const Geometry& g, double along,
                                  double half_width_px) {
  const int n = static_cast<int>(std::lround(2 * half_width_px / kProfileStepPx)) + 1;
  double values[128];
  if (n > 128) return std::nullopt;
  for (int k = 0; k < n; ++k) {
    const double t = -half_width_px + k * kProfileStepPx;
    const auto v =
        sample(image, g.mid_x + along * g.ux + t * g.nx, g.mid_y + along * g.uy + t * g.ny);
    if (!v) return std::nullopt;
    values[k] = *v;
  }
  // The contrast: the outer quarters' means.
  const int quarter = std::max(1, n / 4);
  double near = 0, far = 0;
  for (int k = 0; k < quarter; ++k) near += values[k], far += values[n - 1 - k];
  Profile p;
  p.contrast = (far - near) / quarter;
  // The derivative's centroid, signed by the step so that it weighs the step's own slope.
  double moment = 0, mass = 0;
  for (int k = 1; k + 1 < n; ++k) {
    const double d = (values[k + 1] - values[k - 1]) * (p.contrast > 0 ? 1 : -1);
    if (d <= 0) continue;
    moment += d * (-half_width_px + k * kProfileStepPx), mass += d;
  }
  if (!(mass > 0) || p.contrast == 0) return std::nullopt;
  p.centre = moment / mass;
  return p;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  const auto middle = v.begin() + static_cast<long>(v.size() / 2);
  std::nth_element(v.begin(), middle, v.end());
  return *middle;
}

EdgeSegment extend(const cv::Mat& image, const EdgeSegment& s, const SegmentExtentOptions& o) {
  const double dx = s.end_x_px - s.start_x_px, dy = s.end_y_px - s.start_y_px;
  const double length = std::hypot(dx, dy);
  if (!(length >= 8)) return s;
  Geometry g{0.5 * (s.start_x_px + s.end_x_px),
             0.5 * (s.start_y_px + s.end_y_px),
             dx / length,
             dy / length,
             -dy / length,
             dx / length};
  const double half = 0.5 * length, hw = o.profile_half_width_px;
  // The segment's own profiles: its step's contrast and the line its centres lie on
  // (t = a + b s; the finder's reduced-scale line can lean a few degrees off the edge).
  std::vector<double> along, centre, contrast;
  // Every other pixel: the median and the line need no more, and on a 12 MP chart these
  // profiles were most of the growth's time.
  for (double a = -half; a <= half; a += 2)
    if (const auto p = profile_at(image, g, a, hw)) {
      along.push_back(a), centre.push_back(p->centre), contrast.push_back(p->contrast);
    }
  if (along.size() < 8) return s;
  const double reference = median(contrast);
  if (!(std::fabs(reference) > 0)) return s;
  double sa = 0, sc = 0, saa = 0, sac = 0;
  const double n = static_cast<double>(along.size());
  for (size_t k = 0; k < along.size(); ++k)
    sa += along[k], sc += centre[k], saa += along[k] * along[k], sac += along[k] * centre[k];
  const double det = n * saa - sa * sa;
  if (!(det > 0)) return s;
  const double slope = (n * sac - sa * sc) / det, offset = (sc - slope * sa) / n;
  std::vector<double> deviation;
  for (size_t k = 0; k < along.size(); ++k)
    deviation.push_back(std::fabs(centre[k] - offset - slope * along[k]));
  const double tolerance = std::max(0.5, 6 * 1.4826 * median(deviation));
  // From the end outward (the segment's own span is the edge already), on profiles
  // averaged over kSmoothPx each side along the edge: single profiles' noise moved the
  // end by pixels from one noise draw to the next, and with it every frame's region.
  auto reach = [&](double direction) {
    const int growth = static_cast<int>(o.max_growth * length);
    const int first = -kSmoothPx;  // index i is the profile at half + 1 + first + i
    // Read as the walk needs them: it stops at the side's end, mostly long before the
    // growth's bound.
    std::vector<double> step, off_line;
    auto at = [&](int i) {
      while (static_cast<int>(step.size()) <= i) {
        const double a = half + 1 + first + static_cast<double>(step.size());
        const auto p = profile_at(image, g, direction * a, hw);
        step.push_back(p ? p->contrast / reference : 0.0);
        off_line.push_back(p ? std::fabs(p->centre - offset - slope * direction * a) : NAN);
      }
      return std::pair{step[static_cast<size_t>(i)], off_line[static_cast<size_t>(i)]};
    };
    const int count = growth + 2 * kSmoothPx + 1;
    double kept = half;
    for (int i = kSmoothPx; i + kSmoothPx < count; ++i) {
      double contrast = 0, deviation = 0;
      int valid = 0;
      for (int j = i - kSmoothPx; j <= i + kSmoothPx; ++j) {
        const auto [step_j, off_line_j] = at(j);
        contrast += step_j / (2 * kSmoothPx + 1);
        if (!std::isnan(off_line_j)) deviation += off_line_j, ++valid;
      }
      if (contrast < kMinContrastFraction || valid <= kSmoothPx || deviation / valid > tolerance)
        break;
      kept = half + 1 + first + i;
    }
    // Back off the corner: the half-contrast point is where the next side's blur begins.
    return std::max(half, kept - kBackOffPx);
  };
  const double lo = -reach(-1), hi = reach(+1);
  // Along the fitted line, so that the grown ends stay on the edge.
  auto point = [&](double a, double* x, double* y) {
    const double t = offset + slope * a;
    *x = g.mid_x + a * g.ux + t * g.nx, *y = g.mid_y + a * g.uy + t * g.ny;
  };
  EdgeSegment grown = s;
  point(lo, &grown.start_x_px, &grown.start_y_px);
  point(hi, &grown.end_x_px, &grown.end_y_px);
  return grown;
}

double length_of(const EdgeSegment& e) {
  return std::hypot(e.end_x_px - e.start_x_px, e.end_y_px - e.start_y_px);
}

}  // namespace

bool piece_of_edge(const EdgeSegment& e, const EdgeSegment& k) {
  const double len = length_of(k);
  if (!(len > 0) || !(length_of(e) > 0)) return false;
  const double ux = (k.end_x_px - k.start_x_px) / len, uy = (k.end_y_px - k.start_y_px) / len;
  const double ex = e.end_x_px - e.start_x_px, ey = e.end_y_px - e.start_y_px;
  const double sine = std::fabs(ex * uy - ey * ux) / std::hypot(ex, ey);
  const double mx = 0.5 * (e.start_x_px + e.end_x_px) - k.start_x_px,
               my = 0.5 * (e.start_y_px + e.end_y_px) - k.start_y_px;
  const double a = mx * ux + my * uy, across = std::fabs(mx * uy - my * ux);
  return sine < std::sin(3.0 * std::numbers::pi / 180.0) && across < 3.0 && a >= 0 && a <= len;
}

std::vector<EdgeSegment> extend_along_edges(const cv::Mat& image,
                                            const std::vector<EdgeSegment>& segments,
                                            const SegmentExtentOptions& options) {
  if (image.empty() || image.type() != CV_32FC1) return segments;
  // Side by side on OpenCV's threads, as the SFR measures them (extend is reentrant).
  std::vector<EdgeSegment> grown(segments.size());
  cv::parallel_for_(cv::Range(0, static_cast<int>(segments.size())), [&](const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k)
      grown[static_cast<size_t>(k)] = extend(image, segments[static_cast<size_t>(k)], options);
  });
  // The longest first claims its side; the output keeps the input's order.
  std::vector<size_t> by_length(grown.size());
  for (size_t k = 0; k < grown.size(); ++k) by_length[k] = k;
  std::stable_sort(by_length.begin(), by_length.end(),
                   [&](size_t a, size_t b) { return length_of(grown[a]) > length_of(grown[b]); });
  std::vector<bool> kept(grown.size(), false);
  std::vector<size_t> claimed;
  for (size_t k : by_length)
    if (std::none_of(claimed.begin(), claimed.end(),
                     [&](size_t c) { return piece_of_edge(grown[k], grown[c]); }))
      kept[k] = true, claimed.push_back(k);
  std::vector<EdgeSegment> out;
  for (size_t k = 0; k < grown.size(); ++k)
    if (kept[k]) out.push_back(std::move(grown[k]));
  return out;
}

}  // namespace camlab::analysis
