#include "analysis/channel_signal.h"

#include <limits>

#include "image/frame_views.h"

namespace camlab::analysis {

using image::FrameLayout;

Result<std::vector<std::string>> measurable_channels(const image::FrameSidecar& sidecar) {
  if (!sidecar.linear) return image::check_mono_linear(sidecar, "the capture").error();
  if (sidecar.layout == FrameLayout::kMono) return std::vector<std::string>{""};
  return std::vector<std::string>{"R", "G", "B"};
}

Result<cv::Mat> channel_signal(const cv::Mat& stored, const image::FrameSidecar& sidecar,
                               const std::string& channel) {
  cv::Mat signal;
  if (sidecar.layout != FrameLayout::kMosaic) {  // mono, or one plane of RGB: every pixel
    auto samples = channel_samples(stored, sidecar, channel);
    if (!samples) return samples.error();
    samples->convertTo(signal, CV_32F, 1.0, -sidecar.black_level_dn);
    return signal;
  }
  if (stored.empty()) return make_error("bad_image", "the frame is empty");
  if (channel.size() != 1 || std::string("RGB").find(channel[0]) == std::string::npos ||
      stored.channels() != 1 || !image::is_bayer_pattern(sidecar.cfa_pattern))
    return make_error("invalid_argument", "a mosaic has channels R, G, B, not '" + channel + "'");
  stored.convertTo(signal, CV_32F, 1.0, -sidecar.black_level_dn);
  const int wanted = channel == "R" ? 0 : channel == "G" ? 1 : 2;
  const float nan = std::numeric_limits<float>::quiet_NaN();
  for (int y = 0; y < signal.rows; ++y) {
    float* row = signal.ptr<float>(y);
    for (int x = 0; x < signal.cols; ++x)
      if (image::cfa_colour_at(sidecar.cfa_pattern, x, y) != wanted) row[x] = nan;
  }
  return signal;
}

Result<cv::Mat> channel_samples(const cv::Mat& stored, const image::FrameSidecar& sidecar,
                                const std::string& channel) {
  if (stored.empty()) return make_error("bad_image", "the frame is empty");
  if (sidecar.layout == FrameLayout::kMono) {
    if (!channel.empty() || stored.channels() != 1)
      return make_error("invalid_argument", "a mono frame has no channel '" + channel + "'");
    return stored;
  }
  if (sidecar.layout == FrameLayout::kRgb) {
    const int index = channel == "R" ? 2 : channel == "G" ? 1 : channel == "B" ? 0 : -1;
    if (index < 0 || stored.channels() != 3)
      return make_error("invalid_argument",
                        "an RGB frame has channels R, G, B, not '" + channel + "'");
    cv::Mat plane;
    cv::extractChannel(stored, plane, index);  // stored B, G, R
    return plane;
  }
  auto planes = image::cfa_planes(stored, sidecar);
  if (!planes) return planes.error();
  std::vector<cv::Mat> mine;
  for (size_t k = 0; k < 4; ++k)
    if (channel.size() == 1 && planes->colours[k] == channel[0]) mine.push_back(planes->planes[k]);
  if (mine.empty())
    return make_error("invalid_argument", "a mosaic has channels R, G, B, not '" + channel + "'");
  cv::Mat samples;
  cv::hconcat(mine, samples);
  return samples;
}

}  // namespace camlab::analysis
