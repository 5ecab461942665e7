// JPEG frames (MJPG cameras, and the virtual camera's MJPEG output) through libjpeg-turbo's
// TurboJPEG API: about 2x faster than OpenCV's imdecode on the same data, with identical
// pixels (1280x720: 2.7 ms against 5.6 ms per frame; docs/BENCHMARKS.md,
// tests/bench/format_bench), and it can
// decode at 1/8 scale from the DC coefficients alone, which is how a frame's mean is read
// while a capture watches its settings settle.
//
// Images are OpenCV's: CV_8UC1 for a greyscale JPEG, CV_8UC3 in B, G, R order for colour.
// A truncated or corrupt stream is an error ("bad_image"), never a partly grey picture.
//
// Reentrant: each call uses a TurboJPEG handle of its thread.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <span>
#include <vector>

#include "base/result.h"

namespace camlab::image {

struct JpegHeader {
  int width = 0;
  int height = 0;
  bool greyscale = false;
};

Result<JpegHeader> read_jpeg_header(std::span<const uint8_t> jpeg);

// The full-resolution image.
Result<cv::Mat> decode_jpeg(std::span<const uint8_t> jpeg);

// The mean over all pixels and channels, from a 1/8-scale decode (each 8x8 block's DC
// term: the block means, so the overall mean differs from the full decode's by the
// rounding of the inverse transform only, well under 1 DN).
Result<double> jpeg_mean_fast(std::span<const uint8_t> jpeg);

// `image` CV_8UC1 or CV_8UC3 (B, G, R); quality 1..100; chroma subsampled 4:2:2 as UVC
// cameras send it.
Result<std::vector<uint8_t>> encode_jpeg(const cv::Mat& image, int quality);

// The most bytes encode_jpeg can produce for a width x height image at any quality
// (TurboJPEG's worst case, tjBufSize): what a driver reports as an MJPEG frame's sizeimage.
uint64_t jpeg_buffer_bound(int width, int height);

}  // namespace camlab::image
