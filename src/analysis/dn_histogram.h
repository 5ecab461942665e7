// Histograms of a frame's raw values (DN) per colour channel, for setting exposure: where
// the signal sits between the black level and the white level, and how many samples are
// clipped at either end. A Bayer mosaic is counted per site of its colour filter array (R,
// Gr, Gb, B: the two greens apart, since a difference between them is a sensor or
// crosstalk fault worth seeing); a mono frame as one channel (Y); an RGB frame as R, G, B.
//
// Units: DN of the frame's bit depth, black level included (what the ADC gave). The bins
// cover [0, 2^bit_depth) in equal widths of a whole number of DN, so no bin mixes the
// rounding of two neighbours.
//
// Reentrant: pure functions.
#pragma once

#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/result.h"
#include "image/pixel_format.h"

namespace camlab::analysis {

inline constexpr int kMaxHistogramBins = 4096;

struct ChannelHistogram {
  std::string channel;           // "Y", "R", "Gr", "Gb", "B", "G"
  std::vector<uint64_t> counts;  // bins of bin_width_dn DN from 0
  uint64_t samples = 0;
  uint64_t at_or_above_white = 0;  // clipped high: DN >= white_level_dn
  uint64_t at_or_below_black = 0;  // DN <= black_level_dn (no signal, or clipped low)
  double mean_dn = 0;
  int min_dn = 0, max_dn = 0;
};

struct DnHistogram {
  int bit_depth = 8;
  int black_level_dn = 0;
  int white_level_dn = 255;
  int bin_width_dn = 1;
  int bins = 256;
  std::vector<ChannelHistogram> channels;
};

struct DnHistogramInput {
  cv::Mat image;  // CV_8UC1 / CV_16UC1 (mono or mosaic), CV_8UC3 / CV_16UC3 (B, G, R)
  image::FrameLayout layout = image::FrameLayout::kMono;
  std::string cfa_pattern;  // "RGGB", "BGGR", "GRBG", "GBRG" for a mosaic
  int bit_depth = 8;        // 1..16
  int black_level_dn = 0;
  int white_level_dn = 255;
};

// The channel of each site of a 2x2 block of colour filter `pattern` ("RGGB", ...),
// row-major: "R", "Gr", "Gb" or "B" (the green on a red row is Gr). False for anything but
// the four Bayer patterns.
bool cfa_site_names(const std::string& pattern, std::array<std::string, 4>* names);

// `bins`: 1..kMaxHistogramBins; fewer are used when the bit depth has fewer values.
// Errors "invalid_argument" (empty image, a depth the type cannot hold, a mosaic without
// a known pattern or with an odd size, bins out of range).
Result<DnHistogram> dn_histogram(const DnHistogramInput& input, int bins);

}  // namespace camlab::analysis
