#include "analysis/sfr/slanted_edge_sfr.h"

#include <algorithm>
#include <cmath>
#include <complex>
#include <numbers>

#include "base/format.h"

namespace camlab::analysis {
namespace {

constexpr double kNearAxisDeg = 2.0;
constexpr double kFrequencyStep = 0.005, kMaxFrequency = 1.0;  // cycles/px
constexpr int kMinRows = 16;

// The region read in working coordinates: rows cross the edge (the image transposed when
// the edge is nearer horizontal), so the edge runs x = a + b y with |b| <= 1.
class WorkingView {
 public:
  WorkingView(const cv::Mat& image, bool transposed) : image_(image), transposed_(transposed) {}
  int rows() const { return transposed_ ? image_.cols : image_.rows; }
  int cols() const { return transposed_ ? image_.rows : image_.cols; }
  double at(int row, int col) const {
    return transposed_ ? image_.at<float>(col, row) : image_.at<float>(row, col);
  }

 private:
  const cv::Mat& image_;
  bool transposed_;
};

struct RowLine {
  double a = 0, b = 0;  // x = a + b y
  double x_at(double y) const { return a + b * y; }
};

// The region's ends: a pixel belongs to it when its place along the edge, measured from
// the segment's middle, is within the half length. Whole rows would not do: a row crosses
// the edge at the slant, so its ends reach hw tan(slant) along the edge past its crossing
// (14 px at 30 deg for hw 24), over a square's corner into the next side, whose opposite
// step then sits in the ESF.
struct AlongEdge {
  double mid_x = 0, mid_y = 0, b = 0, norm = 1, half_length = 0;
  bool inside(double x, double y) const {
    return std::fabs(((x - mid_x) * b + (y - mid_y)) / norm) <= half_length;
  }
};

// Step 2: the per-row centroids of the windowed derivative, and the line through them.
// Rows whose window leaves the image, or whose derivative sums to nothing, are skipped.
std::optional<RowLine> fit_edge_line(const WorkingView& view, const RowLine& guess, int row_lo,
                                     int row_hi, double half_x, const AlongEdge& along,
                                     int* rows_used) {
  double sy = 0, sx = 0, syy = 0, sxy = 0;
  int n = 0;
  for (int y = row_lo; y <= row_hi; ++y) {
    const double c = guess.x_at(y);
    const int lo = static_cast<int>(std::floor(c - half_x)),
              hi = static_cast<int>(std::ceil(c + half_x));
    if (lo < 1 || hi > view.cols() - 2) continue;
    // Only rows whose whole window lies in the region: a window reaching past a corner
    // holds the next side's step, which would pull the centroid.
    if (!along.inside(lo, y) || !along.inside(hi, y)) continue;
    double num = 0, den = 0;
    for (int x = lo; x <= hi; ++x) {
      const double u = (x - c) / half_x;
      if (std::fabs(u) > 1) continue;
      const double w = 0.54 + 0.46 * std::cos(std::numbers::pi * u);
      const double d = 0.5 * (view.at(y, x + 1) - view.at(y, x - 1));
      num += x * d * w;
      den += d * w;
    }
    if (!(std::fabs(den) > 1e-12)) continue;
    const double centroid = num / den;
    if (!(std::fabs(centroid - c) <= half_x)) continue;
    sy += y, sx += centroid, syy += double(y) * y, sxy += double(y) * centroid;
    ++n;
  }
  *rows_used = n;
  const double det = n * syy - sy * sy;
  if (n < 3 || !(std::fabs(det) > 0)) return std::nullopt;
  RowLine line;
  line.b = (n * sxy - sy * sx) / det;
  line.a = (sx - line.b * sy) / n;
  return line;
}

double sinc(double x) { return std::fabs(x) < 1e-12 ? 1.0 : std::sin(x) / x; }

}  // namespace

std::optional<double> frequency_at(const std::vector<double>& frequency_cy_px,
                                   const std::vector<double>& sfr, double level) {
  for (size_t k = 1; k < sfr.size() && k < frequency_cy_px.size(); ++k)
    if (sfr[k] <= level && sfr[k - 1] > level) {
      const double t = (sfr[k - 1] - level) / (sfr[k - 1] - sfr[k]);
      return frequency_cy_px[k - 1] + t * (frequency_cy_px[k] - frequency_cy_px[k - 1]);
    }
  return std::nullopt;
}

Result<SfrResult> slanted_edge_sfr(const cv::Mat& image, const EdgeSegment& edge,
                                   const SfrOptions& options) {
  return slanted_edge_sfr(image, image, edge, options);
}

Result<SfrResult> slanted_edge_sfr(const cv::Mat& signal, const cv::Mat& geometry,
                                   const EdgeSegment& edge, const SfrOptions& options) {
  if (signal.empty() || signal.channels() != 1 || geometry.empty() || geometry.channels() != 1)
    return make_error("bad_image", "the SFR needs a single-channel image");
  if (signal.size() != geometry.size())
    return make_error("bad_image", "the SFR's signal and geometry images differ in size");
  if (!(options.half_width_px >= 4 && options.half_width_px <= 256) || options.oversampling < 1 ||
      options.oversampling > 16 || options.half_length_px < 0)
    return make_error("invalid_argument",
                      "SFR options out of range: half width 4-256 px, oversampling 1-16, "
                      "half length >= 0");
  const double dx = edge.end_x_px - edge.start_x_px, dy = edge.end_y_px - edge.start_y_px;
  const double length = std::hypot(dx, dy);
  if (!(length >= 8))
    return make_error("invalid_argument", "an edge segment for the SFR must be 8 px or longer");
  // Float images are read in place: a frame's whole copy per edge cost 40 ms an edge on
  // 12 MP (sfr_bench).
  cv::Mat f = signal, g = geometry;
  if (f.type() != CV_32F) signal.convertTo(f, CV_32F);
  if (g.type() != CV_32F) geometry.convertTo(g, CV_32F);

  SfrResult r;
  r.centre_x_px = 0.5 * (edge.start_x_px + edge.end_x_px);
  r.centre_y_px = 0.5 * (edge.start_y_px + edge.end_y_px);
  const bool transposed = std::fabs(dx) > std::fabs(dy);
  const WorkingView view(f, transposed), line_view(g, transposed);
  // Working coordinates: (x, y) = (col, row) of the view.
  const double x0 = transposed ? edge.start_y_px : edge.start_x_px,
               y0 = transposed ? edge.start_x_px : edge.start_y_px;
  const double x1 = transposed ? edge.end_y_px : edge.end_x_px,
               y1 = transposed ? edge.end_x_px : edge.end_y_px;
  RowLine line;
  line.b = (x1 - x0) / (y1 - y0);
  line.a = x0 - line.b * y0;
  const double mid_y = 0.5 * (y0 + y1);
  const double half_length =
      options.half_length_px > 0 ? options.half_length_px : std::max(0.0, 0.5 * length - 4.0);
  const double hw = options.half_width_px;
  auto row_range = [&](const RowLine& l, int* lo, int* hi) {
    const double half_rows = half_length / std::sqrt(1 + l.b * l.b);
    *lo = std::max(0, static_cast<int>(std::ceil(mid_y - half_rows)));
    *hi = std::min(view.rows() - 1, static_cast<int>(std::floor(mid_y + half_rows)));
  };
  auto along_edge = [&](const RowLine& l) {
    return AlongEdge{l.x_at(mid_y), mid_y, l.b, std::sqrt(1 + l.b * l.b), half_length};
  };
  int row_lo = 0, row_hi = 0, rows_used = 0;
  for (int pass = 0; pass < 2; ++pass) {
    row_range(line, &row_lo, &row_hi);
    const auto fitted =
        fit_edge_line(line_view, line, row_lo, row_hi, hw * std::sqrt(1 + line.b * line.b),
                      along_edge(line), &rows_used);
    if (!fitted) {
      r.status = std::string(kSfrNoEdge);
      r.message =
          "no edge found in the region: " + std::to_string(rows_used) + " rows show a transition";
      return r;
    }
    line = *fitted;
  }
  const double norm = std::sqrt(1 + line.b * line.b);
  const double slant = std::atan(std::fabs(line.b));
  // Off the nearest pixel axis (a fitted line may lean past 45 deg from the rows it was read
  // along).
  r.slant_deg = std::min(slant, std::numbers::pi / 2 - slant) * 180 / std::numbers::pi;
  // The edge's direction in the image: (b, 1) in working coordinates.
  const double ex = transposed ? 1.0 : line.b, ey = transposed ? line.b : 1.0;
  r.angle_deg = std::atan2(ey, ex) * 180 / std::numbers::pi;
  if (r.angle_deg <= -90) r.angle_deg += 180;
  if (r.angle_deg > 90) r.angle_deg -= 180;
  const double cy_w = mid_y, cx_w = line.x_at(mid_y);
  r.centre_x_px = transposed ? cy_w : cx_w;
  r.centre_y_px = transposed ? cx_w : cy_w;

  // Step 3: the ESF.
  const int os = options.oversampling;
  const int bins = static_cast<int>(std::lround(2 * hw * os));
  std::vector<double> sum(static_cast<size_t>(bins), 0.0), where(static_cast<size_t>(bins), 0.0);
  std::vector<int> count(static_cast<size_t>(bins), 0);
  int rows = 0;
  bool clipped = false;
  const AlongEdge along = along_edge(line);
  for (int y = row_lo; y <= row_hi; ++y) {
    const double c = line.x_at(y);
    const int lo = static_cast<int>(std::floor(c - hw * norm)),
              hi = static_cast<int>(std::ceil(c + hw * norm));
    if (lo < 0 || hi > view.cols() - 1) continue;
    ++rows;
    for (int x = lo; x <= hi; ++x) {
      const double d = (x - c) / norm;
      const int bin = static_cast<int>(std::floor((d + hw) * os));
      if (bin < 0 || bin >= bins || !along.inside(x, y)) continue;
      const double v = view.at(y, x);
      if (!std::isfinite(v)) continue;  // a site of another colour
      if (options.saturation_level > 0 && v >= options.saturation_level) clipped = true;
      sum[static_cast<size_t>(bin)] += v;
      where[static_cast<size_t>(bin)] += (d + hw) * os - 0.5;
      ++count[static_cast<size_t>(bin)];
    }
  }
  if (rows < kMinRows || rows * std::tan(slant) < 1.0) {
    r.status = std::string(kSfrTooFewRows);
    r.message = std::to_string(rows) + " rows at a slant of " + format_significant(r.slant_deg, 3) +
                " deg do not sweep the edge through a whole pixel (needs at least " +
                std::to_string(std::max(
                    kMinRows, static_cast<int>(std::ceil(1 / std::tan(std::max(slant, 1e-3)))))) +
                ")";
    return r;
  }
  // Each filled bin is the ESF at its samples' mean distance, not at its centre: the
  // slant spreads the samples unevenly within a bin (at 20 deg they cluster), so the bin
  // is no box average of the ESF. The ESF on the bins' centres is interpolated linearly
  // between those points (a box correction instead overstated MTF50 by 1.5% at 20 deg).
  std::vector<double> at, value;
  for (int k = 0; k < bins; ++k)
    if (count[static_cast<size_t>(k)] > 0) {
      at.push_back(where[static_cast<size_t>(k)] / count[static_cast<size_t>(k)]);
      value.push_back(sum[static_cast<size_t>(k)] / count[static_cast<size_t>(k)]);
    }
  if (at.size() < 2) {
    r.status = std::string(kSfrTooFewRows);
    r.message = "the region holds too few pixels for an ESF";
    return r;
  }
  std::vector<double> esf(static_cast<size_t>(bins), 0.0);
  size_t next = 0;
  for (int k = 0; k < bins; ++k) {
    while (next < at.size() && at[next] < k) ++next;
    if (next == 0)
      esf[static_cast<size_t>(k)] = value.front();
    else if (next == at.size())
      esf[static_cast<size_t>(k)] = value.back();
    else
      esf[static_cast<size_t>(k)] = value[next - 1] + (value[next] - value[next - 1]) *
                                                          (k - at[next - 1]) /
                                                          (at[next] - at[next - 1]);
  }
  // Levels: the mean of the outer tenth on each side.
  const int tenth = std::max(1, bins / 10);
  double low = 0, high = 0;
  for (int k = 0; k < tenth; ++k) {
    low += esf[static_cast<size_t>(k)] / tenth;
    high += esf[static_cast<size_t>(bins - 1 - k)] / tenth;
  }
  r.contrast = high - low;
  if (!(std::fabs(r.contrast) > 0)) {
    r.status = std::string(kSfrNoEdge);
    r.message = "the region shows no step across the edge";
    return r;
  }
  // The 10-90% rise on the ESF smoothed over a pixel (the noise's crossings are not the
  // edge's).
  {
    std::vector<double> smooth(static_cast<size_t>(bins), 0.0);
    for (int k = 0; k < bins; ++k) {
      double s = 0;
      int n = 0;
      for (int j = std::max(0, k - os / 2); j <= std::min(bins - 1, k + os / 2); ++j, ++n)
        s += esf[static_cast<size_t>(j)];
      smooth[static_cast<size_t>(k)] = (s / n - low) / r.contrast;
    }
    int k10 = 0, k90 = bins - 1;
    while (k10 < bins - 1 && smooth[static_cast<size_t>(k10)] < 0.1) ++k10;
    while (k90 > 0 && smooth[static_cast<size_t>(k90)] > 0.9) --k90;
    r.rise_10_90_px = std::max(0, k90 - k10) / static_cast<double>(os);
  }

  // Step 4: the LSF, windowed about its centroid.
  std::vector<double> lsf(static_cast<size_t>(bins), 0.0);
  for (int k = 1; k + 1 < bins; ++k)
    lsf[static_cast<size_t>(k)] =
        0.5 * (esf[static_cast<size_t>(k + 1)] - esf[static_cast<size_t>(k - 1)]) *
        (r.contrast > 0 ? 1 : -1);
  lsf[0] = lsf[1];
  lsf[static_cast<size_t>(bins - 1)] = lsf[static_cast<size_t>(bins - 2)];
  double moment = 0, mass = 0;
  for (int k = 0; k < bins; ++k)
    moment += k * lsf[static_cast<size_t>(k)], mass += lsf[static_cast<size_t>(k)];
  const double centroid = mass > 0 ? moment / mass : 0.5 * (bins - 1);
  // The window: flat over the line spread (1.25 rises + 1.5 px each side, which holds a
  // disk's or a Gaussian's whole spread), a cosine taper to twice that (at least 6 px, at
  // most the region's), zero past it, where the LSF is only noise.
  const double window_px = std::clamp(2.5 * r.rise_10_90_px + 3, 6.0, hw);
  const double flat_bins = 0.5 * window_px * os, taper_bins = 0.5 * window_px * os;
  for (int k = 0; k < bins; ++k) {
    const double u = std::fabs(k - centroid);
    const double w = u <= flat_bins ? 1.0
                     : u >= flat_bins + taper_bins
                         ? 0.0
                         : 0.5 * (1 + std::cos(std::numbers::pi * (u - flat_bins) / taper_bins));
    lsf[static_cast<size_t>(k)] *= w;
  }
  {
    // The windowed spread's centroid (the noise past the spread left out), back to a
    // distance from the line: bin k holds d = (k + 0.5) / os - hw. d grows along the
    // working view's +x, so along (1, -b) / norm there, (-b, 1) / norm in a transposed view.
    double m = 0, w = 0;
    for (int k = 0; k < bins; ++k)
      m += k * lsf[static_cast<size_t>(k)], w += lsf[static_cast<size_t>(k)];
    if (w > 0) {
      const double d = (m / w + 0.5) / os - hw;
      r.offset_x_px = d * (transposed ? -line.b : 1.0) / norm;
      r.offset_y_px = d * (transposed ? 1.0 : -line.b) / norm;
    }
  }

  // Step 5: the SFR.
  const double bin_px = 1.0 / os;
  std::complex<double> dc = 0;
  for (int k = 0; k < bins; ++k) dc += lsf[static_cast<size_t>(k)];
  if (!(std::abs(dc) > 0)) {
    r.status = std::string(kSfrNoEdge);
    r.message = "the edge's line spread sums to nothing";
    return r;
  }
  // Only the window's bins carry weight; each frequency's terms by a rotating phasor.
  int first = 0, last = bins - 1;
  while (first < last && lsf[static_cast<size_t>(first)] == 0) ++first;
  while (last > first && lsf[static_cast<size_t>(last)] == 0) --last;
  for (double fr = 0; fr <= kMaxFrequency + 1e-9; fr += kFrequencyStep) {
    std::complex<double> sum_f = 0;
    const double w = -2 * std::numbers::pi * fr * bin_px;
    const std::complex<double> step = std::polar(1.0, w);
    std::complex<double> phasor = std::polar(1.0, w * (first - centroid));
    for (int k = first; k <= last; ++k, phasor *= step)
      sum_f += lsf[static_cast<size_t>(k)] * phasor;
    const double correction = sinc(2 * std::numbers::pi * fr * bin_px);
    r.frequency_cy_px.push_back(fr);
    r.sfr.push_back(std::abs(sum_f) / std::abs(dc) / correction);
  }
  r.mtf50_cy_px = frequency_at(r.frequency_cy_px, r.sfr, 0.5);
  r.mtf30_cy_px = frequency_at(r.frequency_cy_px, r.sfr, 0.3);
  r.mtf10_cy_px = frequency_at(r.frequency_cy_px, r.sfr, 0.1);

  // Flags, most basic first.
  double rise_area = 0, dip_area = 0;
  for (double v : lsf) (v > 0 ? rise_area : dip_area) += std::fabs(v);
  if (dip_area > rise_area / 3 || !r.mtf50_cy_px) {
    r.status = std::string(kSfrNotAStep);
    r.message = r.mtf50_cy_px ? "the profile across it is not one step (its line spread dips " +
                                    format_significant(100 * dip_area / rise_area, 3) +
                                    "% below zero): a bar, a line or texture"
                              : "its SFR never falls to 0.5: the profile across it is not one "
                                "blurred step";
  } else if (r.slant_deg < kNearAxisDeg) {
    r.status = std::string(kSfrNearAxis);
    r.message = "the edge is " + format_significant(r.slant_deg, 3) +
                " deg off a pixel axis: under 2 deg the rows sample too few phases of it";
  } else if (clipped) {
    r.status = std::string(kSfrClipped);
    r.message = "pixels of the region reach the clipping level: the ESF's top is cut";
  } else if (2 * hw < 3 * 1.25 * r.rise_10_90_px) {
    // A disk of diameter D rises 10-90% over about 0.8 D.
    r.status = std::string(kSfrWindowTooShort);
    r.message = "the window, " + format_significant(2 * hw, 3) +
                " px across, is shorter than 3 blur diameters (10-90% rise " +
                format_significant(r.rise_10_90_px, 3) + " px): widen --half-width";
  }
  return r;
}

}  // namespace camlab::analysis
