// From a slanted edge's binned pixels to its SFR: the ESF on the bin centres, its levels,
// 10-90% rise and smoothed tails, the windowed LSF and its Fourier transform (steps 3-5 of
// slanted_edge_sfr.h, after the binning). Apart from the binning so that the same steps
// run again on the bins less one block of rows: the jackknife behind the MTF50's
// standard error (slanted_edge_sfr.cpp).
//
// Reentrant: no state.
#pragma once

#include <optional>
#include <string>
#include <vector>

namespace camlab::analysis {

// The region's pixels binned by their distance across the edge's line: per bin the sum of
// their values, of their places (in bins, from bin 0's centre) and of those squared, and
// their count.
struct EsfBins {
  std::vector<double> sum, where, where_squared;
  std::vector<double> count;
  explicit EsfBins(int bins = 0)
      : sum(static_cast<size_t>(bins), 0.0),
        where(static_cast<size_t>(bins), 0.0),
        where_squared(static_cast<size_t>(bins), 0.0),
        count(static_cast<size_t>(bins), 0.0) {}
  int size() const { return static_cast<int>(sum.size()); }
  // One sample at `position` (bins) into `bin`, counted `weight` times (-1: taken out).
  void add(int bin, double value, double position, double weight = 1) {
    const auto b = static_cast<size_t>(bin);
    sum[b] += weight * value, where[b] += weight * position;
    where_squared[b] += weight * position * position, count[b] += weight;
  }
};

struct EsfSfr {
  std::string status;  // empty: measured; else kSfrTooFewRows or kSfrNoEdge (slanted_edge_sfr.h)
  std::string message;
  double contrast = 0, rise_10_90_px = 0;
  std::vector<double> windowed_lsf;   // per bin, the sign of the step taken out
  double windowed_centroid_bins = 0;  // the windowed LSF's centroid (bins), when it has mass
  bool has_centroid = false;
  std::vector<double> frequency_cy_px, sfr;
  std::optional<double> mtf50_cy_px, mtf30_cy_px, mtf10_cy_px;
};

// `oversampling` bins a pixel, `half_width_px` each side of the line. Given
// `mtf50_near_cy_px` only the MTF50 is read, the SFR evaluated from a little below that
// frequency until it falls through 0.5 (a jackknife replicate needs no more).
EsfSfr esf_to_sfr(const EsfBins& bins, int oversampling, double half_width_px,
                  std::optional<double> mtf50_near_cy_px = std::nullopt);

}  // namespace camlab::analysis
