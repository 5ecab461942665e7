#include "analysis/sfr/slanted_edge_sfr.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "analysis/sfr/esf_to_sfr.h"
#include "base/format.h"

namespace camlab::analysis {
namespace {

constexpr double kNearAxisDeg = 2.0;
constexpr int kMinRows = 16;
// How far inside the place where the edge leaves its line (straight_extent) the region
// stops, px: the blur carries the bend that far.
constexpr double kBendMarginPx = 2.0;
// The half width of the windows that look for the bend (px across the edge).
constexpr double kBendWindowPx = 6.0;
// The blocks of rows the MTF50's jackknife leaves out one at a time.
constexpr int kJackknifeBlocks = 10;

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
  double mid_x = 0, mid_y = 0, b = 0, norm = 1, lo = 0, hi = 0;  // lo <= 0 <= hi, px
  bool inside(double x, double y) const {
    const double position = ((x - mid_x) * b + (y - mid_y)) / norm;
    return position >= lo && position <= hi;
  }
};

struct RowCentroid {
  int row = 0;
  double x = 0;
};

// Where the edge stays on its line: from the row nearest `mid_y` outward, the rows whose
// centroid lies within the tolerance of the line through the middle half's centroids (6
// robust standard deviations of the middle half's, at least 0.5 px), until three in a row
// do not (a row that showed no step counts as one that did not). Returns the along-edge positions
// (px from the middle, as AlongEdge's) of the last row kept each way, or the region's own
// bound where the rows ran out first. A segment the finder ran past a corner, or past the
// vertex where a star's side meets the next, ends where the edge bends, not where it
// was drawn.
std::pair<double, double> straight_extent(const std::vector<RowCentroid>& rows, double mid_y,
                                          double norm, double lo, double hi) {
  if (rows.size() < 8) return {lo, hi};
  // The line the rows are held to: through the middle half of the rows alone, which lie on
  // the edge even where the segment runs past a corner. A line through every row leaned
  // towards the centroids of the plain ground past the corner (a pixel off the edge there,
  // on a segment drawn 30 px past it), and the tolerance, from the rows' deviations, grew
  // to 4 px: the ground's rows passed.
  const double quarter = 0.25 * (rows.back().row - rows.front().row);
  double sy = 0, sx = 0, syy = 0, sxy = 0, n = 0;
  for (const RowCentroid& c : rows)
    if (std::fabs(c.row - mid_y) <= quarter)
      sy += c.row, sx += c.x, syy += double(c.row) * c.row, sxy += double(c.row) * c.x, ++n;
  const double det = n * syy - sy * sy;
  if (n < 4 || !(det > 0)) return {lo, hi};
  RowLine line;
  line.b = (n * sxy - sy * sx) / det;
  line.a = (sx - line.b * sy) / n;
  std::vector<double> deviation, central;
  for (const RowCentroid& c : rows) {
    deviation.push_back(std::fabs(c.x - line.x_at(c.row)));
    if (std::fabs(c.row - mid_y) <= quarter) central.push_back(deviation.back());
  }
  std::nth_element(central.begin(), central.begin() + static_cast<long>(central.size() / 2),
                   central.end());
  const double tolerance = std::max(0.5, 6 * 1.4826 * central[central.size() / 2]);
  size_t middle = 0;
  for (size_t k = 1; k < rows.size(); ++k)
    if (std::fabs(rows[k].row - mid_y) < std::fabs(rows[middle].row - mid_y)) middle = k;
  auto walk = [&](int direction, double bound) {
    size_t kept = middle;
    int misses = 0;
    for (long k = static_cast<long>(middle) + direction;
         k >= 0 && k < static_cast<long>(rows.size()); k += direction) {
      // Rows between this centroid and the last showed no step (fit_edge_line skips them):
      // past a corner the line runs on over plain ground. Each is a miss.
      misses += std::abs(rows[static_cast<size_t>(k)].row -
                         rows[static_cast<size_t>(k - direction)].row) -
                1;
      if (misses >= 3) return (rows[kept].row - mid_y) * norm;
      if (deviation[static_cast<size_t>(k)] > tolerance) {
        if (++misses == 3) return (rows[kept].row - mid_y) * norm;
      } else {
        misses = 0, kept = static_cast<size_t>(k);
      }
    }
    return bound;
  };
  return {walk(-1, lo), walk(+1, hi)};
}

// Step 2: the per-row centroids of the windowed derivative, and the line through them.
// Rows whose window leaves the image, or whose derivative sums to nothing, are skipped.
std::optional<RowLine> fit_edge_line(const WorkingView& view, const RowLine& guess, int row_lo,
                                     int row_hi, double half_x, const AlongEdge& along,
                                     int* rows_used, std::vector<RowCentroid>* centroids) {
  centroids->clear();
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
    // The Hamming window's cos(pi u) by a rotating phasor, one step a pixel: a cos call
    // per pixel was a quarter of the SFR's time.
    const double step = std::numbers::pi / half_x;
    const double step_cos = std::cos(step), step_sin = std::sin(step);
    double phase_cos = std::cos(step * (lo - c)), phase_sin = std::sin(step * (lo - c));
    double num = 0, den = 0;
    for (int x = lo; x <= hi; ++x) {
      if (std::fabs(x - c) <= half_x) {
        const double w = 0.54 + 0.46 * phase_cos;
        const double d = 0.5 * (view.at(y, x + 1) - view.at(y, x - 1));
        num += x * d * w;
        den += d * w;
      }
      const double next_cos = phase_cos * step_cos - phase_sin * step_sin;
      phase_sin = phase_sin * step_cos + phase_cos * step_sin, phase_cos = next_cos;
    }
    if (!(std::fabs(den) > 1e-12)) continue;
    const double centroid = num / den;
    if (!(std::fabs(centroid - c) <= half_x)) continue;
    centroids->push_back({y, centroid});
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

// The region's half length along a segment `length_px` long: the option's, or the
// segment's half less 4 px (its ends are where the finder placed the corners).
double region_half_length(double length_px, const SfrOptions& options) {
  return options.half_length_px > 0 ? options.half_length_px : std::max(0.0, 0.5 * length_px - 4);
}

}  // namespace

std::optional<NeighbourInRegion> neighbour_in_region(const std::vector<EdgeSegment>& edges,
                                                     size_t self, const SfrOptions& options) {
  constexpr double kEndMarginPx = 6, kSameEdgeSine = 0.05, kSameEdgePx = 3;  // 0.05: 3 deg
  if (self >= edges.size()) return std::nullopt;
  const EdgeSegment& a = edges[self];
  const double length = std::hypot(a.end_x_px - a.start_x_px, a.end_y_px - a.start_y_px);
  if (!(length > 0)) return std::nullopt;
  const double ux = (a.end_x_px - a.start_x_px) / length, uy = (a.end_y_px - a.start_y_px) / length;
  const double mx = 0.5 * (a.start_x_px + a.end_x_px), my = 0.5 * (a.start_y_px + a.end_y_px);
  const double half_length = region_half_length(length, options) - kEndMarginPx;
  if (half_length <= 0) return std::nullopt;
  std::optional<NeighbourInRegion> nearest;
  for (size_t k = 0; k < edges.size(); ++k) {
    if (k == self) continue;
    const EdgeSegment& b = edges[k];
    // Along and across the edge's line at b's ends; both linear along b.
    const double a0 = (b.start_x_px - mx) * ux + (b.start_y_px - my) * uy,
                 a1 = (b.end_x_px - mx) * ux + (b.end_y_px - my) * uy;
    const double c0 = (b.start_y_px - my) * ux - (b.start_x_px - mx) * uy,
                 c1 = (b.end_y_px - my) * ux - (b.end_x_px - mx) * uy;
    const double b_length = std::hypot(b.end_x_px - b.start_x_px, b.end_y_px - b.start_y_px);
    if (!(b_length > 0)) continue;
    if (std::fabs(c1 - c0) / b_length < kSameEdgeSine && std::fabs(c0) < kSameEdgePx &&
        std::fabs(c1) < kSameEdgePx)
      continue;  // a collinear piece of the same edge
    // The part of b with |along| <= half_length: t in [lo, hi] of b's start-to-end.
    double lo = 0, hi = 1;
    if (std::fabs(a1 - a0) < 1e-12) {
      if (std::fabs(a0) > half_length) continue;
    } else {
      double t0 = (-half_length - a0) / (a1 - a0), t1 = (half_length - a0) / (a1 - a0);
      if (t0 > t1) std::swap(t0, t1);
      lo = std::max(lo, t0), hi = std::min(hi, t1);
      if (lo > hi) continue;
    }
    const double c_lo = c0 + lo * (c1 - c0), c_hi = c0 + hi * (c1 - c0);
    const double distance =
        (c_lo > 0) != (c_hi > 0) ? 0.0 : std::min(std::fabs(c_lo), std::fabs(c_hi));
    if (distance < options.half_width_px && (!nearest || distance < nearest->distance_px))
      nearest = NeighbourInRegion{k, distance};
  }
  return nearest;
}

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
  const double half_length = region_half_length(length, options);
  const double hw = options.half_width_px;
  double along_lo = -half_length, along_hi = half_length;  // the region along the edge, px
  auto row_range = [&](const RowLine& l, int* lo, int* hi) {
    const double norm = std::sqrt(1 + l.b * l.b);
    *lo = std::max(0, static_cast<int>(std::ceil(mid_y + along_lo / norm)));
    *hi = std::min(view.rows() - 1, static_cast<int>(std::floor(mid_y + along_hi / norm)));
  };
  auto along_edge = [&](const RowLine& l) {
    return AlongEdge{l.x_at(mid_y), mid_y, l.b, std::sqrt(1 + l.b * l.b), along_lo, along_hi};
  };
  int row_lo = 0, row_hi = 0, rows_used = 0;
  std::vector<RowCentroid> centroids;
  // Twice on the whole segment, then, where the edge leaves its line before the segment's
  // end (straight_extent), once more on the straight part alone.
  for (int pass = 0; pass < 3; ++pass) {
    row_range(line, &row_lo, &row_hi);
    const auto fitted =
        fit_edge_line(line_view, line, row_lo, row_hi, hw * std::sqrt(1 + line.b * line.b),
                      along_edge(line), &rows_used, &centroids);
    if (!fitted) {
      r.status = std::string(kSfrNoEdge);
      r.message =
          "no edge found in the region: " + std::to_string(rows_used) + " rows show a transition";
      return r;
    }
    line = *fitted;
    if (pass == 1) {
      // Every row of the whole segment, windows reaching past its ends allowed, and
      // narrow (kBendWindowPx each side) so that they reach along the edge little past
      // their row: near a vertex the window meets the next side, and the centroids leave
      // the line there.
      const double norm_now = std::sqrt(1 + line.b * line.b), full = 0.5 * length;
      const int full_lo = std::max(0, static_cast<int>(std::ceil(mid_y - full / norm_now))),
                full_hi = std::min(view.rows() - 1,
                                   static_cast<int>(std::floor(mid_y + full / norm_now)));
      AlongEdge anywhere = along_edge(line);
      anywhere.lo = -1e9, anywhere.hi = 1e9;
      int whole_used = 0;
      fit_edge_line(line_view, line, full_lo, full_hi, std::min(hw, kBendWindowPx) * norm_now,
                    anywhere, &whole_used, &centroids);
      const auto [lo, hi] = straight_extent(centroids, mid_y, norm_now, -full - 1, full + 1);
      // The region stops kBendMarginPx inside where the edge leaves its line (the blur
      // carries the bend that far), and never beyond its own ends.
      const double new_lo = std::max(along_lo, lo + kBendMarginPx),
                   new_hi = std::min(along_hi, hi - kBendMarginPx);
      if (new_lo == along_lo && new_hi == along_hi) break;
      if (!(new_hi - new_lo > 8)) {
        r.status = std::string(kSfrTooFewRows);
        r.message = "the edge leaves its line within " +
                    format_significant(std::max(0.0, new_hi - new_lo), 3) +
                    " px: a corner or another edge is in the way";
        return r;
      }
      along_lo = new_lo, along_hi = new_hi;
    }
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

  // Step 3: the ESF.
  const int os = options.oversampling;
  const int bins = static_cast<int>(std::lround(2 * hw * os));
  // The rows read: those whose whole width lies in the image.
  auto row_window = [&](int y) {
    const double c = line.x_at(y);
    return std::pair{static_cast<int>(std::floor(c - hw * norm)),
                     static_cast<int>(std::ceil(c + hw * norm))};
  };
  std::vector<int> rows_read;
  for (int y = row_lo; y <= row_hi; ++y)
    if (const auto [lo, hi] = row_window(y); lo >= 0 && hi <= view.cols() - 1)
      rows_read.push_back(y);
  const int rows = static_cast<int>(rows_read.size());
  {
    // The edge's place: the middle of the region read, not of the segment. The bend check
    // above trims the region where the edge leaves its line, often at one end only, and the
    // image's border takes rows; a lens map places each edge in the field by it (a
    // field-curvature sag of 15 focus units at the corner moves best focus 0.2 units for
    // 3 px along the radius there).
    double read_lo = along_lo, read_hi = along_hi;
    if (!rows_read.empty()) {
      read_lo = std::max(read_lo, (rows_read.front() - mid_y) * norm);
      read_hi = std::min(read_hi, (rows_read.back() - mid_y) * norm);
    }
    const double cy_w = mid_y + (read_hi >= read_lo ? 0.5 * (read_lo + read_hi) / norm : 0.0);
    const double cx_w = line.x_at(cy_w);
    r.centre_x_px = transposed ? cy_w : cx_w;
    r.centre_y_px = transposed ? cx_w : cy_w;
  }
  bool clipped = false;
  const AlongEdge along = along_edge(line);
  // Row y's pixels into `into`, each with `weight` (-1 takes them out again).
  auto bin_row = [&](int y, EsfBins& into, double weight) {
    const double c = line.x_at(y);
    const auto [lo, hi] = row_window(y);
    for (int x = lo; x <= hi; ++x) {
      const double d = (x - c) / norm;
      const int bin = static_cast<int>(std::floor((d + hw) * os));
      if (bin < 0 || bin >= bins || !along.inside(x, y)) continue;
      const double v = view.at(y, x);
      if (!std::isfinite(v)) continue;  // a site of another colour
      if (options.saturation_level > 0 && v >= options.saturation_level) clipped = true;
      into.add(bin, v, (d + hw) * os - 0.5, weight);  // place: bins, from bin 0's centre
    }
  };
  EsfBins binned(bins);
  for (int y : rows_read) bin_row(y, binned, 1);
  if (rows < kMinRows || rows * std::tan(slant) < 1.0) {
    r.status = std::string(kSfrTooFewRows);
    r.message = std::to_string(rows) + " rows at a slant of " + format_significant(r.slant_deg, 3) +
                " deg do not sweep the edge through a whole pixel (needs at least " +
                std::to_string(std::max(
                    kMinRows, static_cast<int>(std::ceil(1 / std::tan(std::max(slant, 1e-3)))))) +
                ")";
    return r;
  }
  EsfSfr curve = esf_to_sfr(binned, os, hw);
  if (!curve.status.empty()) {
    r.status = curve.status;
    r.message = curve.message;
    return r;
  }
  r.contrast = curve.contrast;
  r.rise_10_90_px = curve.rise_10_90_px;
  if (curve.has_centroid) {
    // Back to a distance from the line: bin k holds d = (k + 0.5) / os - hw. d grows along
    // the working view's +x, so along (1, -b) / norm there, (-b, 1) / norm in a transposed
    // view.
    const double d = (curve.windowed_centroid_bins + 0.5) / os - hw;
    r.offset_x_px = d * (transposed ? -line.b : 1.0) / norm;
    r.offset_y_px = d * (transposed ? 1.0 : -line.b) / norm;
  }
  r.frequency_cy_px = std::move(curve.frequency_cy_px);
  r.sfr = std::move(curve.sfr);
  r.mtf50_cy_px = curve.mtf50_cy_px;
  r.mtf30_cy_px = curve.mtf30_cy_px;
  r.mtf10_cy_px = curve.mtf10_cy_px;
  const std::vector<double>& lsf = curve.windowed_lsf;
  // The MTF50's standard error: the delete-a-block jackknife over blocks of adjacent rows
  // (each block's noise apart from the others' even where the pixels' noise is not white),
  // steps 3-5 run again on the bins less each block. A block is taken out by binning its
  // rows again with weight -1: ten blocks' bins kept side by side were 250 KB a call at
  // 48 px each side, which the allocator mapped and the kernel zeroed on every call.
  if (r.mtf50_cy_px && rows >= kJackknifeBlocks) {
    std::vector<double> replicates;
    EsfBins rest(bins);
    for (int block = 0; block < kJackknifeBlocks; ++block) {
      rest = binned;
      for (int k = block * rows / kJackknifeBlocks; k < (block + 1) * rows / kJackknifeBlocks; ++k)
        bin_row(rows_read[static_cast<size_t>(k)], rest, -1);
      const EsfSfr replicate = esf_to_sfr(rest, os, hw, r.mtf50_cy_px);
      if (!replicate.status.empty() || !replicate.mtf50_cy_px) break;
      replicates.push_back(*replicate.mtf50_cy_px);
    }
    if (replicates.size() == static_cast<size_t>(kJackknifeBlocks)) {
      double mean = 0, squares = 0;
      for (double m : replicates) mean += m / replicates.size();
      for (double m : replicates) squares += (m - mean) * (m - mean);
      r.mtf50_standard_error_cy_px =
          std::sqrt((kJackknifeBlocks - 1.0) / kJackknifeBlocks * squares);
    }
  }

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
  } else if (const double off_diagonal = std::fabs(std::fabs(line.b) - 1);
             rows * off_diagonal < 1.0) {
    // At 45 deg every pixel centre lies x - y apart from the line, a lattice 0.71 px apart
    // across it (coarser than the ESF's half-pixel Nyquist spacing for a pixel's own
    // blur): the bins between stay empty and the ESF is interpolated over them. Off 45 deg
    // the rows drift across that lattice by |1 - |b|| each; they must drift a whole step.
    r.status = std::string(kSfrNearDiagonal);
    // |1 - tan(45 deg + d)| is about 2 d (rad): rows x 2 d >= 1.
    r.message = "the edge is " + format_significant(std::fabs(45 - r.slant_deg), 2) +
                " deg off 45 deg: the pixel centres lie on a lattice 0.71 px apart across it, "
                "and its " +
                std::to_string(rows) + " rows do not drift across that lattice (turn it " +
                format_significant(90 / std::numbers::pi / std::max(rows, 1), 2) +
                " deg or more from 45)";
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
