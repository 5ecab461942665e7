// Statistics of a rectangle of a stored frame's raw values (DN), per colour channel, as a
// viewer shows them: the DN under the cursor and an ROI's mean, standard deviation and SNR.
// Channels are named as the histogram names them (dn_histogram.h): Y for mono, R, Gr, Gb,
// B for a Bayer mosaic (by each pixel's own filter site), R, G, B for an RGB frame.
//
// Units: DN as stored, black level included. sd is the sample standard deviation over the
// channel's samples in the rectangle (spatial noise and signal variation together: an ROI
// on a flat patch gives the noise); SNR = (mean - black level) / sd, the signal above black
// per unit of that spread, absent when sd is 0.
//
// Reentrant: pure functions.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "image/capture_folder.h"

namespace camlab::analysis {

// At most this many samples are listed one by one (an 8 x 8 mono region; a 4 x 4 RGB one).
inline constexpr int kMaxListedRegionSamples = 64;

struct RegionChannelStats {
  std::string channel;
  uint64_t samples = 0;
  double mean_dn = 0;
  double sd_dn = 0;           // 0 for a single sample
  std::optional<double> snr;  // (mean - black) / sd; none when sd is 0
  int min_dn = 0, max_dn = 0;
};

struct RegionSample {
  int x = 0, y = 0;     // frame pixel
  std::string channel;  // the channel this value belongs to
  int dn = 0;
};

struct RegionStats {
  cv::Rect rect;  // frame pixels
  std::vector<RegionChannelStats> channels;
  // Every sample of the rectangle when it holds at most kMaxListedRegionSamples, else none.
  std::vector<RegionSample> samples;
};

// `stored`: the frame as read from its folder (8- or 16-bit, 1 or 3 planes stored B, G, R).
// Errors "out_of_range" (the rectangle empty or not wholly inside the frame, saying the
// frame's size), "invalid_argument" (an unknown colour filter pattern, a type the
// sidecar's layout cannot hold).
Result<RegionStats> region_stats(const cv::Mat& stored, const image::FrameSidecar& sidecar,
                                 const cv::Rect& rect);

}  // namespace camlab::analysis
