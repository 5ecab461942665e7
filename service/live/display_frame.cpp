#include "service/live/display_frame.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "image/frame_views.h"
#include "image/jpeg_codec.h"

namespace camlab::service {

namespace {

// DN -> display value for every DN the bit depth holds: (dn - black) / (white - black),
// clamped to 0..1, to the power 1/2.2 when the DN are linear in light, times 255.
cv::Mat display_lut(int bit_depth, int black_dn, int white_dn, bool linear) {
  const double power = linear ? 1 / 2.2 : 1.0;
  const int levels = 1 << bit_depth;
  cv::Mat lut(1, levels, CV_8UC1);
  const double span = std::max(1, white_dn - black_dn);
  for (int dn = 0; dn < levels; ++dn) {
    const double v = std::clamp((dn - black_dn) / span, 0.0, 1.0);
    lut.at<uint8_t>(0, dn) = static_cast<uint8_t>(std::lround(255.0 * std::pow(v, power)));
  }
  return lut;
}

// `image` (8U or 16U, any channels) through a lookup table of 2^bit_depth entries.
cv::Mat apply_lut(const cv::Mat& image, const cv::Mat& lut) {
  if (image.depth() == CV_8U && lut.cols == 256) {
    cv::Mat out;
    cv::LUT(image, lut, out);
    return out;
  }
  cv::Mat out(image.size(), CV_MAKETYPE(CV_8U, image.channels()));
  const uint8_t* table = lut.ptr<uint8_t>(0);
  const int last = lut.cols - 1;
  const int n = image.cols * image.channels();
  for (int y = 0; y < image.rows; ++y) {
    uint8_t* to = out.ptr<uint8_t>(y);
    if (image.depth() == CV_8U) {
      const uint8_t* from = image.ptr<uint8_t>(y);
      for (int i = 0; i < n; ++i) to[i] = table[std::min<int>(from[i], last)];
    } else {
      const uint16_t* from = image.ptr<uint16_t>(y);
      for (int i = 0; i < n; ++i) to[i] = table[std::min<int>(from[i], last)];
    }
  }
  return out;
}

// 255 where any channel of a pixel is at or beyond `level` (above: >=, else <=), per raw
// sample; for a mosaic each sample is a pixel of the mask.
cv::Mat level_mask(const cv::Mat& raw, int level, bool above) {
  cv::Mat per_channel;
  if (above)
    cv::compare(raw, cv::Scalar::all(level), per_channel, cv::CMP_GE);
  else
    cv::compare(raw, cv::Scalar::all(level), per_channel, cv::CMP_LE);
  if (per_channel.channels() == 1) return per_channel;
  std::vector<cv::Mat> planes;
  cv::split(per_channel, planes);
  cv::Mat any = planes[0] | planes[1] | planes[2];
  return any;
}

// A mask at the display's size: a display pixel is marked when any sample under it is
// (INTER_AREA averages; anything above 0 had a marked sample).
cv::Mat mask_to_display(const cv::Mat& mask, cv::Size display) {
  if (mask.size() == display) return mask;
  cv::Mat scaled;
  cv::resize(mask, scaled, display, 0, 0, cv::INTER_AREA);
  return scaled > 0;
}

}  // namespace

Result<cv::Mat> display_image(const capture::ConvertedFrame& frame, const DisplayOptions& options) {
  const int max_width = std::clamp(options.max_width_px, kMinDisplayWidthPx, kMaxDisplayWidthPx);
  cv::Mat picture;  // display values before scaling, 8-bit
  cv::Mat clipped_high, clipped_low;
  if (!frame.jpeg.empty()) {
    auto decoded = image::decode_jpeg(frame.jpeg);
    if (!decoded) return decoded.error();
    picture = *decoded;
    if (options.clipping) {
      clipped_high = level_mask(picture, 255, true);
      clipped_low = level_mask(picture, 0, false);
    }
  } else {
    const cv::Mat& raw = frame.image;
    if (raw.empty() || (raw.depth() != CV_8U && raw.depth() != CV_16U))
      return make_error("bad_frame", "the frame has no 8- or 16-bit samples to show");
    const int bit_depth = std::clamp(frame.bit_depth, 1, raw.depth() == CV_8U ? 8 : 16);
    image::FrameSidecar layout;
    layout.layout = frame.layout;
    layout.cfa_pattern = frame.cfa_pattern;
    auto colour = image::picture_view(raw, layout);
    if (!colour) return make_error("bad_frame", colour.error().message);
    picture = apply_lut(
        *colour, display_lut(bit_depth, frame.black_level_dn, frame.white_level_dn, frame.linear));
    if (options.clipping) {
      clipped_high = level_mask(raw, frame.white_level_dn, true);
      clipped_low = level_mask(raw, frame.black_level_dn, false);
    }
  }

  cv::Mat shown = picture;
  if (picture.cols > max_width) {
    const int height = std::max(1, static_cast<int>(std::lround(static_cast<double>(picture.rows) *
                                                                max_width / picture.cols)));
    cv::resize(picture, shown, cv::Size(max_width, height), 0, 0, cv::INTER_AREA);
  }
  if (!options.clipping && !options.focus_peaking) return shown;

  cv::Mat luminance;
  if (shown.channels() == 3) {
    cv::cvtColor(shown, luminance, cv::COLOR_BGR2GRAY);
  } else {
    luminance = shown;
    cv::cvtColor(shown, shown, cv::COLOR_GRAY2BGR);
  }
  if (options.focus_peaking) {
    cv::Mat gx, gy, magnitude;
    cv::Sobel(luminance, gx, CV_32F, 1, 0, 3);
    cv::Sobel(luminance, gy, CV_32F, 0, 1, 3);
    cv::magnitude(gx, gy, magnitude);
    shown.setTo(cv::Scalar(0, 255, 0), magnitude > options.peaking_threshold);
  }
  if (options.clipping) {
    shown.setTo(cv::Scalar(255, 64, 0), mask_to_display(clipped_low, shown.size()));
    shown.setTo(cv::Scalar(0, 0, 255), mask_to_display(clipped_high, shown.size()));
  }
  return shown;
}

Result<std::vector<uint8_t>> display_jpeg(const capture::ConvertedFrame& frame,
                                          const DisplayOptions& options) {
  auto shown = display_image(frame, options);
  if (!shown) return shown.error();
  return image::encode_jpeg(*shown, std::clamp(options.jpeg_quality, 1, 100));
}

}  // namespace camlab::service
