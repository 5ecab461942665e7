#include "analysis/sfr/esf_to_sfr.h"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "analysis/sfr/slanted_edge_sfr.h"

namespace camlab::analysis {
namespace {

constexpr double kFrequencyStep = 0.005, kMaxFrequency = 1.0;  // cycles/px
// How far below the hint a replicate's search for its MTF50 starts (cycles/px). A
// replicate leaves out a tenth of the rows and lands about a third of a standard error
// from the whole region's MTF50: under 0.003 cycles/px at contrast-to-noise 50.
constexpr double kSearchBelowCyPx = 0.02;
// Where the ESF's tails begin (rises of 10-90% plus a margin from the edge's centre), and
// the widest box that smooths them (half width).
constexpr double kTailCoreRises = 0.75, kTailCoreMarginPx = 1.0, kTailMaxHalfPx = 4.0;

// The ESF's tails smoothed: past `core_bins` from the edge's centre each bin becomes the
// mean of a box centred on it, half as wide as its distance past the core (up to
// `max_half_bins`), kept inside the array so that it stays centred (a linear trend passes
// unchanged). Past the spread the ESF is flat and only noise moves it; the LSF's noise at
// the frequencies MTF50 lies at comes mostly from there (the core holds the signal), and a
// box a few pixels wide removes those frequencies while the level, the zero frequency the
// SFR is normalised by, passes.
void smooth_tails(std::vector<double>* esf, double centre_bin, double core_bins,
                  int max_half_bins) {
  const int n = static_cast<int>(esf->size());
  std::vector<double> prefix(static_cast<size_t>(n) + 1, 0.0);
  for (int k = 0; k < n; ++k)
    prefix[static_cast<size_t>(k) + 1] =
        prefix[static_cast<size_t>(k)] + (*esf)[static_cast<size_t>(k)];
  std::vector<double> out(*esf);
  for (int k = 0; k < n; ++k) {
    const double past = std::fabs(k - centre_bin) - core_bins;
    if (past <= 0) continue;
    const int half = std::min({static_cast<int>(past), max_half_bins, k, n - 1 - k});
    if (half < 1) continue;
    out[static_cast<size_t>(k)] =
        (prefix[static_cast<size_t>(k + half) + 1] - prefix[static_cast<size_t>(k - half)]) /
        (2 * half + 1);
  }
  *esf = std::move(out);
}

double sinc(double x) { return std::fabs(x) < 1e-12 ? 1.0 : std::sin(x) / x; }

}  // namespace

EsfSfr esf_to_sfr(const EsfBins& binned, int oversampling, double half_width_px,
                  std::optional<double> mtf50_near_cy_px) {
  EsfSfr r;
  const int bins = binned.size(), os = oversampling;
  const double hw = half_width_px;
  const auto& [sum, where, where_squared, count] = binned;
  // Each filled bin is the ESF at its samples' mean distance, not at its centre: the
  // slant spreads the samples unevenly within a bin (at 20 deg they cluster), so the bin
  // is no box average of the ESF. The ESF on the bins' centres is interpolated linearly
  // between those points (a box correction instead overstated MTF50 by 1.5% at 20 deg).
  std::vector<double> at, value, spread;
  for (int k = 0; k < bins; ++k)
    if (const double n = count[static_cast<size_t>(k)]; n > 0.5) {
      at.push_back(where[static_cast<size_t>(k)] / n);
      value.push_back(sum[static_cast<size_t>(k)] / n);
      spread.push_back(
          std::max(0.0, where_squared[static_cast<size_t>(k)] / n - at.back() * at.back()));
    }
  if (at.size() < 2) {
    r.status = std::string(kSfrTooFewRows);
    r.message = "the region holds too few pixels for an ESF";
    return r;
  }
  // Each bin centre's smear (bins^2): a bin's mean is the ESF at its samples' mean distance
  // plus half its second derivative times the samples' variance about it, and the linear
  // interpolation between two such points adds t (1 - t) h^2 of it. Both low-pass the ESF
  // like a Gaussian of that variance; step 5 divides the SFR by it (uncorrected, MTF50 of
  // sharp edges, 0.41-0.59 cycles/px, read 0.5% low at 8 bins a pixel, 1.8% at 4).
  std::vector<double> esf(static_cast<size_t>(bins), 0.0), smear(static_cast<size_t>(bins), 0.0);
  size_t next = 0;
  for (int k = 0; k < bins; ++k) {
    while (next < at.size() && at[next] < k) ++next;
    const auto kk = static_cast<size_t>(k);
    if (next == 0) {
      esf[kk] = value.front(), smear[kk] = spread.front();
    } else if (next == at.size()) {
      esf[kk] = value.back(), smear[kk] = spread.back();
    } else {
      const double h = at[next] - at[next - 1], t = (k - at[next - 1]) / h;
      esf[kk] = value[next - 1] + (value[next] - value[next - 1]) * t;
      smear[kk] = (1 - t) * spread[next - 1] + t * spread[next] + t * (1 - t) * h * h;
    }
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
    std::vector<double> prefix(static_cast<size_t>(bins) + 1, 0.0),
        smooth(static_cast<size_t>(bins));
    for (int k = 0; k < bins; ++k)
      prefix[static_cast<size_t>(k) + 1] =
          prefix[static_cast<size_t>(k)] + esf[static_cast<size_t>(k)];
    for (int k = 0; k < bins; ++k) {
      const int lo = std::max(0, k - os / 2), hi = std::min(bins - 1, k + os / 2);
      const double mean =
          (prefix[static_cast<size_t>(hi) + 1] - prefix[static_cast<size_t>(lo)]) / (hi - lo + 1);
      smooth[static_cast<size_t>(k)] = (mean - low) / r.contrast;
    }
    int k10 = 0, k90 = bins - 1;
    while (k10 < bins - 1 && smooth[static_cast<size_t>(k10)] < 0.1) ++k10;
    while (k90 > 0 && smooth[static_cast<size_t>(k90)] > 0.9) --k90;
    r.rise_10_90_px = std::max(0, k90 - k10) / static_cast<double>(os);
    // The tails past the spread (a disk's reaches 0.63 rises from its centre, a Gaussian's
    // 3 sigma 1.2 rises), smoothed by boxes up to 4 px wide each side.
    smooth_tails(&esf, 0.5 * (k10 + k90),
                 (kTailCoreRises * r.rise_10_90_px + kTailCoreMarginPx) * os,
                 static_cast<int>(kTailMaxHalfPx * os));
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
    // The windowed spread's centroid (the noise past the spread left out): where the edge
    // lies across its line (the caller turns it into image px).
    double m = 0, w = 0;
    for (int k = 0; k < bins; ++k)
      m += k * lsf[static_cast<size_t>(k)], w += lsf[static_cast<size_t>(k)];
    if (w > 0) r.windowed_centroid_bins = m / w, r.has_centroid = true;
  }

  // Step 5: the SFR.
  const double bin_px = 1.0 / os;
  double dc = 0, smear_weighted = 0, smear_weight = 0;
  for (int k = 0; k < bins; ++k) {
    const double v = lsf[static_cast<size_t>(k)];
    dc += v;
    smear_weighted += std::fabs(v) * smear[static_cast<size_t>(k)], smear_weight += std::fabs(v);
  }
  // The ESF's smear where the spread is (step 3), px^2.
  const double smear_px2 = smear_weight > 0 ? smear_weighted / smear_weight * bin_px * bin_px : 0.0;
  if (!(std::abs(dc) > 0)) {
    r.status = std::string(kSfrNoEdge);
    r.message = "the edge's line spread sums to nothing";
    return r;
  }
  // Only the window's bins carry weight; each frequency's terms by a rotating phasor.
  int first = 0, last = bins - 1;
  while (first < last && lsf[static_cast<size_t>(first)] == 0) ++first;
  while (last > first && lsf[static_cast<size_t>(last)] == 0) --last;
  // What the central difference and the ESF's smear (step 3) took from frequency fr.
  auto response = [&](double fr) {
    return sinc(2 * std::numbers::pi * fr * bin_px) *
           std::exp(-2 * std::numbers::pi * std::numbers::pi * fr * fr * smear_px2);
  };
  // The SFR at `lanes` frequencies at once, out[j] at fr[j]: each frequency's phasor is a
  // chain of dependent products, and side by side the processor runs them together (one
  // at a time, the whole curve was half the SFR's time). In real arithmetic: std::complex's
  // product goes through libgcc's __muldc3 (its NaN and infinity cases), a tenth of a 12 MP
  // chart's time.
  auto sfr_at = [&]<int lanes>(const double* fr, double* out) {
    double step_re[lanes], step_im[lanes], phasor_re[lanes], phasor_im[lanes];
    double sum_re[lanes] = {}, sum_im[lanes] = {};
    for (int j = 0; j < lanes; ++j) {
      const double w = -2 * std::numbers::pi * fr[j] * bin_px;
      step_re[j] = std::cos(w), step_im[j] = std::sin(w);
      phasor_re[j] = std::cos(w * (first - centroid)),
      phasor_im[j] = std::sin(w * (first - centroid));
    }
    for (int k = first; k <= last; ++k) {
      const double v = lsf[static_cast<size_t>(k)];
      for (int j = 0; j < lanes; ++j) {
        sum_re[j] += v * phasor_re[j], sum_im[j] += v * phasor_im[j];
        const double re = phasor_re[j] * step_re[j] - phasor_im[j] * step_im[j];
        phasor_im[j] = phasor_re[j] * step_im[j] + phasor_im[j] * step_re[j], phasor_re[j] = re;
      }
    }
    for (int j = 0; j < lanes; ++j)
      out[j] = std::hypot(sum_re[j], sum_im[j]) / std::abs(dc) / response(fr[j]);
  };
  auto sfr_at_one = [&](double fr) {
    double out = 0;
    sfr_at.template operator()<1>(&fr, &out);
    return out;
  };
  const int last_step = static_cast<int>(std::lround(kMaxFrequency / kFrequencyStep));
  if (mtf50_near_cy_px) {
    // Only the MTF50, searched from a little below `mtf50_near_cy_px` (a replicate's lies
    // within a few of its standard errors of the whole region's); from 0 if it fell earlier.
    int k = std::clamp(
        static_cast<int>(std::floor((*mtf50_near_cy_px - kSearchBelowCyPx) / kFrequencyStep)), 0,
        last_step);
    double previous = sfr_at_one(k * kFrequencyStep);
    if (previous <= 0.5) k = 0, previous = sfr_at_one(0);
    for (++k; k <= last_step; ++k) {
      const double value = sfr_at_one(k * kFrequencyStep);
      if (value <= 0.5) {
        r.mtf50_cy_px = (k - 1 + (previous - 0.5) / (previous - value)) * kFrequencyStep;
        break;
      }
      previous = value;
    }
    return r;
  }
  constexpr int kLanes = 4;
  r.frequency_cy_px.resize(static_cast<size_t>(last_step) + 1);
  r.sfr.resize(r.frequency_cy_px.size());
  for (int k = 0; k <= last_step; ++k)
    r.frequency_cy_px[static_cast<size_t>(k)] = k * kFrequencyStep;
  int k = 0;
  for (; k + kLanes <= last_step + 1; k += kLanes)
    sfr_at.template operator()<kLanes>(&r.frequency_cy_px[static_cast<size_t>(k)],
                                       &r.sfr[static_cast<size_t>(k)]);
  for (; k <= last_step; ++k)
    r.sfr[static_cast<size_t>(k)] = sfr_at_one(r.frequency_cy_px[static_cast<size_t>(k)]);
  r.mtf50_cy_px = frequency_at(r.frequency_cy_px, r.sfr, 0.5);
  r.mtf30_cy_px = frequency_at(r.frequency_cy_px, r.sfr, 0.3);
  r.mtf10_cy_px = frequency_at(r.frequency_cy_px, r.sfr, 0.1);
  r.windowed_lsf = std::move(lsf);
  return r;
}

}  // namespace camlab::analysis
