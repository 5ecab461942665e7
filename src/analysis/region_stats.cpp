#include "analysis/region_stats.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "analysis/dn_histogram.h"

namespace camlab::analysis {

namespace {

// Welford's update: one pass, no cancellation of a large mean against its square.
struct Moments {
  uint64_t n = 0;
  double mean = 0, m2 = 0;
  int min = std::numeric_limits<int>::max(), max = std::numeric_limits<int>::min();

  void add(int dn) {
    ++n;
    const double delta = dn - mean;
    mean += delta / static_cast<double>(n);
    m2 += delta * (dn - mean);
    min = std::min(min, dn);
    max = std::max(max, dn);
  }
};

int sample_at(const cv::Mat& image, int x, int y, int plane) {
  const int planes = image.channels();
  if (image.depth() == CV_8U) return image.ptr<uint8_t>(y)[x * planes + plane];
  return image.ptr<uint16_t>(y)[x * planes + plane];
}

}  // namespace

Result<RegionStats> region_stats(const cv::Mat& stored, const image::FrameSidecar& sidecar,
                                 const cv::Rect& rect) {
  if (stored.empty()) return make_error("invalid_argument", "the frame is empty");
  if (stored.depth() != CV_8U && stored.depth() != CV_16U)
    return make_error("invalid_argument", "region statistics need 8- or 16-bit samples");
  const cv::Rect frame(0, 0, stored.cols, stored.rows);
  if (rect.width < 1 || rect.height < 1 || (rect & frame) != rect)
    return make_error("out_of_range",
                      "the region x " + std::to_string(rect.x) + ", y " + std::to_string(rect.y) +
                          ", " + std::to_string(rect.width) + " x " + std::to_string(rect.height) +
                          " px is not a non-empty rectangle inside the frame of " +
                          std::to_string(stored.cols) + " x " + std::to_string(stored.rows) +
                          " px");

  // Which channel each sample is: per 2x2 site for a mosaic, per plane for RGB.
  std::vector<std::string> names;
  std::array<int, 4> channel_of_site{0, 0, 0, 0};
  const bool mosaic = sidecar.layout == image::FrameLayout::kMosaic;
  if (mosaic) {
    if (stored.channels() != 1)
      return make_error("invalid_argument",
                        "a mosaic frame has one plane, not " + std::to_string(stored.channels()));
    std::array<std::string, 4> sites;
    if (!cfa_site_names(sidecar.cfa_pattern, &sites))
      return make_error("invalid_argument", "unknown colour filter pattern '" +
                                                sidecar.cfa_pattern +
                                                "' (one of RGGB, BGGR, GRBG, GBRG)");
    names = {"R", "Gr", "Gb", "B"};
    for (size_t site = 0; site < 4; ++site)
      channel_of_site[site] =
          static_cast<int>(std::find(names.begin(), names.end(), sites[site]) - names.begin());
  } else if (stored.channels() == 3) {
    names = {"R", "G", "B"};
  } else if (stored.channels() == 1) {
    names = {"Y"};
  } else {
    return make_error("invalid_argument", "a frame of " + std::to_string(stored.channels()) +
                                              " planes has no named channels");
  }

  std::vector<Moments> moments(names.size());
  RegionStats out;
  out.rect = rect;
  const int planes = stored.channels();
  const bool list = rect.area() * planes <= kMaxListedRegionSamples;
  for (int y = rect.y; y < rect.y + rect.height; ++y) {
    for (int x = rect.x; x < rect.x + rect.width; ++x) {
      for (int p = 0; p < planes; ++p) {
        // Stored B, G, R; named R, G, B.
        const size_t c =
            mosaic
                ? static_cast<size_t>(channel_of_site[static_cast<size_t>((y & 1) * 2 + (x & 1))])
                : static_cast<size_t>(planes == 3 ? 2 - p : 0);
        const int dn = sample_at(stored, x, y, p);
        moments[c].add(dn);
        if (list) out.samples.push_back({x, y, names[c], dn});
      }
    }
  }
  for (size_t c = 0; c < names.size(); ++c) {
    const Moments& m = moments[c];
    if (m.n == 0) continue;  // a 1-px region of a mosaic holds one site only
    RegionChannelStats s;
    s.channel = names[c];
    s.samples = m.n;
    s.mean_dn = m.mean;
    s.sd_dn = m.n > 1 ? std::sqrt(m.m2 / static_cast<double>(m.n - 1)) : 0.0;
    if (s.sd_dn > 0) s.snr = (m.mean - sidecar.black_level_dn) / s.sd_dn;
    s.min_dn = m.min;
    s.max_dn = m.max;
    out.channels.push_back(std::move(s));
  }
  return out;
}

}  // namespace camlab::analysis
