#include "analysis/clip_level.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "analysis/focus/focus_stack.h"  // laplacian_noise_floor: 20 sigma_n^2

namespace camlab::analysis {

std::optional<ClipPlateau> detect_clip_plateau(const cv::Mat& image, double black_level_dn) {
  if (image.empty() || image.channels() != 1 || (image.depth() != CV_8U && image.depth() != CV_16U))
    return std::nullopt;
  const int levels = image.depth() == CV_8U ? 256 : 65536;
  std::vector<int64_t> histogram(static_cast<size_t>(levels), 0);
  for (int y = 0; y < image.rows; ++y) {
    if (image.depth() == CV_8U) {
      const uint8_t* row = image.ptr<uint8_t>(y);
      for (int x = 0; x < image.cols; ++x) ++histogram[row[x]];
    } else {
      const uint16_t* row = image.ptr<uint16_t>(y);
      for (int x = 0; x < image.cols; ++x) ++histogram[row[x]];
    }
  }
  const int64_t total = static_cast<int64_t>(image.total());
  // Robust maximum: all but 0.01% of the pixels (a few hot pixels) lie at or below it.
  const int64_t above_allowed = total / 10000;
  int top = levels - 1;
  for (int64_t above = 0; top > 0; --top) {
    above += histogram[static_cast<size_t>(top)];
    if (above > above_allowed) break;
  }
  const double sigma = std::sqrt(laplacian_noise_floor(image) / 20.0);
  // Without noise (a noise-free render, quantisation only) nothing tells a clip from a
  // flat bright area.
  if (!(sigma >= 1.0)) return std::nullopt;
  const double range = std::max(1.0, top - black_level_dn);
  const int band = static_cast<int>(std::ceil(std::max({2.0, 0.005 * range, 3.0 * sigma})));
  auto count = [&](int from, int to) {  // pixels with from <= value <= to
    int64_t n = 0;
    for (int v = std::max(0, from); v <= std::min(to, levels - 1); ++v)
      n += histogram[static_cast<size_t>(v)];
    return n;
  };
  const int64_t in_band = count(top - band + 1, top);
  const int64_t below = count(top - 5 * band + 1, top - band);
  const double band_density = static_cast<double>(in_band) / band;
  const double below_density = static_cast<double>(below) / (4.0 * band);
  if (in_band < total / 100 || band_density < 5.0 * below_density) return std::nullopt;
  // The spike's own spread: clipped pixels carry only the read noise added after the
  // clip (or none), less than half the frame's noise; an unclipped flat area spreads by
  // the frame's noise.
  double sum = 0, sum2 = 0;
  for (int v = top - band + 1; v <= top; ++v) {
    const double n = static_cast<double>(histogram[static_cast<size_t>(v)]);
    sum += n * v;
    sum2 += n * v * v;
  }
  const double mean = sum / in_band;
  const double spread = std::sqrt(std::max(0.0, sum2 / in_band - mean * mean));
  if (spread >= 0.5 * sigma) return std::nullopt;
  ClipPlateau plateau;
  plateau.level_dn = top - band + 1;
  plateau.top_dn = top;
  plateau.mean_dn = mean;
  plateau.fraction = static_cast<double>(in_band) / static_cast<double>(total);
  return plateau;
}

}  // namespace camlab::analysis
