// A frame made fit to look at: the raw DN mapped for a screen, scaled down, with the two
// overlays a camera engineer aims and focuses with, encoded as JPEG. For the dashboard's
// live view and the thumbnails of captured frames; never for measuring (the frames and the
// histogram stay raw).
//
// The mapping: DN from the black level to the white level become 0..1, then the sRGB-like
// power 1/2.2 for DN linear in light, so that a linear sensor's mid grey does not look
// black (frames that are not linear, stored JPEG frames, are shown as they are). A mosaic is
// demosaiced (bilinear) before scaling; JPEG frames (MJPEG cameras) are already display
// values and are decoded as they are.
//
// Overlays, computed at full resolution where a pixel's fate is decided and shown at display
// resolution:
// - clipping: samples at or above the white level in red, at or below the black level in
//   blue (any channel of the pixel);
// - focus peaking: pixels of the displayed image whose gradient (Sobel, on the displayed
//   luminance, 0..255) exceeds `peaking_threshold`, in green: an absolute level, so a
//   blurred frame shows none and a sharp one shows its edges.
//
// Reentrant: pure functions.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "base/result.h"
#include "capture/frame_convert.h"

namespace camlab::service {

struct DisplayOptions {
  int max_width_px = 640;  // scaled down to at most this width (never up), aspect kept
  bool clipping = false;
  bool focus_peaking = false;
  // Sobel magnitude on 0..255 luminance: a sharp step of contrast C peaks near 8 C / 2.5
  // sigma for an edge blurred by sigma px, so 150 marks C = 100 edges up to sigma ~2 px.
  int peaking_threshold = 150;
  int jpeg_quality = 80;  // 1..100
};

// Bounds a request may ask for (query parameters of the live view and thumbnails).
inline constexpr int kMinDisplayWidthPx = 16;
inline constexpr int kMaxDisplayWidthPx = 4096;

// CV_8UC3 (B, G, R), or CV_8UC1 for a mono frame without overlays. Errors "bad_frame"
// (an empty or inconsistent frame), "bad_image" (a JPEG that does not decode).
Result<cv::Mat> display_image(const capture::ConvertedFrame& frame, const DisplayOptions& options);

// display_image, encoded.
Result<std::vector<uint8_t>> display_jpeg(const capture::ConvertedFrame& frame,
                                          const DisplayOptions& options);

}  // namespace camlab::service
