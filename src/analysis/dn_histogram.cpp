#include "analysis/dn_histogram.h"

#include <algorithm>
#include <array>
#include <limits>

namespace camlab::analysis {

// Names of the four sites of a 2x2 CFA block, row-major, for a pattern such as "RGGB":
// the green on a red row is Gr, the one on a blue row Gb.
bool cfa_site_names(const std::string& pattern, std::array<std::string, 4>* names) {
  if (!image::is_bayer_pattern(pattern)) return false;  // the greens on a diagonal
  for (int site = 0; site < 4; ++site) {
    const char c = pattern[static_cast<size_t>(site)];
    if (c == 'R' || c == 'B') {
      (*names)[static_cast<size_t>(site)] = std::string(1, c);
    } else if (c == 'G') {
      // The other site on the same row says which row this is.
      const char neighbour = pattern[static_cast<size_t>(site ^ 1)];
      if (neighbour != 'R' && neighbour != 'B') return false;
      (*names)[static_cast<size_t>(site)] = neighbour == 'R' ? "Gr" : "Gb";
    } else {
      return false;
    }
  }
  std::array<std::string, 4> sorted = *names;
  std::sort(sorted.begin(), sorted.end());
  return sorted == std::array<std::string, 4>{"B", "Gb", "Gr", "R"};
}

namespace {

struct Accumulator {
  ChannelHistogram* out;
  int bin_width_dn;
  int black, white;
  double sum = 0;
  int min = std::numeric_limits<int>::max(), max = std::numeric_limits<int>::min();

  void add(int dn) {
    const size_t bin = std::min(static_cast<size_t>(dn / bin_width_dn), out->counts.size() - 1);
    ++out->counts[bin];
    ++out->samples;
    out->at_or_above_white += dn >= white;
    out->at_or_below_black += dn <= black;
    sum += dn;
    min = std::min(min, dn);
    max = std::max(max, dn);
  }
  void finish() {
    out->mean_dn = out->samples ? sum / static_cast<double>(out->samples) : 0;
    out->min_dn = out->samples ? min : 0;
    out->max_dn = out->samples ? max : 0;
  }
};

template <class T>
void count(const cv::Mat& image, const DnHistogramInput& input,
           const std::vector<int>& channel_of_site, std::vector<Accumulator>& acc) {
  const int planes = image.channels();
  for (int y = 0; y < image.rows; ++y) {
    const T* row = image.ptr<T>(y);
    if (input.layout == image::FrameLayout::kMosaic) {
      const int* sites = &channel_of_site[static_cast<size_t>((y & 1) * 2)];
      for (int x = 0; x < image.cols; ++x)
        acc[static_cast<size_t>(sites[x & 1])].add(static_cast<int>(row[x]));
    } else if (planes == 1) {
      for (int x = 0; x < image.cols; ++x) acc[0].add(static_cast<int>(row[x]));
    } else {
      // Stored B, G, R; reported R, G, B.
      for (int x = 0; x < image.cols; ++x)
        for (int c = 0; c < 3; ++c)
          acc[static_cast<size_t>(2 - c)].add(static_cast<int>(row[x * planes + c]));
    }
  }
}

}  // namespace

Result<DnHistogram> dn_histogram(const DnHistogramInput& input, int bins) {
  const cv::Mat& image = input.image;
  if (image.empty()) return make_error("invalid_argument", "the frame is empty");
  const int depth = image.depth();
  if (depth != CV_8U && depth != CV_16U)
    return make_error("invalid_argument", "a histogram of DN needs 8- or 16-bit samples");
  if (image.channels() != 1 && image.channels() != 3)
    return make_error("invalid_argument", "a histogram of DN needs 1 or 3 channels, not " +
                                              std::to_string(image.channels()));
  const int max_depth = depth == CV_8U ? 8 : 16;
  if (input.bit_depth < 1 || input.bit_depth > max_depth)
    return make_error("invalid_argument", "bit depth " + std::to_string(input.bit_depth) +
                                              " is outside [1, " + std::to_string(max_depth) +
                                              "] for these samples");
  if (bins < 1 || bins > kMaxHistogramBins)
    return make_error("invalid_argument", "bins = " + std::to_string(bins) +
                                              " is outside the allowed range [1, " +
                                              std::to_string(kMaxHistogramBins) + "]");
  const int levels = 1 << input.bit_depth;
  DnHistogram out;
  out.bit_depth = input.bit_depth;
  out.black_level_dn = std::clamp(input.black_level_dn, 0, levels - 1);
  out.white_level_dn = std::clamp(input.white_level_dn, 1, levels - 1);
  // Whole DN per bin, and never more bins than values.
  out.bin_width_dn = (levels + std::min(bins, levels) - 1) / std::min(bins, levels);
  out.bins = (levels + out.bin_width_dn - 1) / out.bin_width_dn;

  std::vector<std::string> names;
  std::vector<int> channel_of_site(4, 0);
  if (input.layout == image::FrameLayout::kMosaic) {
    if (image.channels() != 1)
      return make_error("invalid_argument", "a mosaic frame has one channel");
    if (image.rows % 2 || image.cols % 2)
      return make_error("invalid_argument", "a mosaic frame has an even width and height, not " +
                                                std::to_string(image.cols) + "x" +
                                                std::to_string(image.rows));
    std::array<std::string, 4> sites;
    if (!cfa_site_names(input.cfa_pattern, &sites))
      return make_error("invalid_argument", "unknown colour filter pattern '" + input.cfa_pattern +
                                                "' (one of RGGB, BGGR, GRBG, GBRG)");
    names = {"R", "Gr", "Gb", "B"};
    for (int site = 0; site < 4; ++site)
      channel_of_site[static_cast<size_t>(site)] = static_cast<int>(
          std::find(names.begin(), names.end(), sites[static_cast<size_t>(site)]) - names.begin());
  } else if (image.channels() == 3) {
    names = {"R", "G", "B"};
  } else {
    names = {"Y"};
  }
  out.channels.resize(names.size());
  std::vector<Accumulator> acc;
  for (size_t c = 0; c < names.size(); ++c) {
    out.channels[c].channel = names[c];
    out.channels[c].counts.assign(static_cast<size_t>(out.bins), 0);
    acc.push_back({&out.channels[c], out.bin_width_dn, out.black_level_dn, out.white_level_dn});
  }
  if (depth == CV_8U)
    count<uint8_t>(image, input, channel_of_site, acc);
  else
    count<uint16_t>(image, input, channel_of_site, acc);
  for (Accumulator& a : acc) a.finish();
  return out;
}

}  // namespace camlab::analysis
