// The virtual camera's image processor: what a simple camera ISP makes of the sensor's
// raw DN for the formats that carry colour pictures (RGB3, BGR3, NV12, YUYV, MJPG).
//
//   1. Black subtracted and scaled to 8 bits: v = 255 (DN - black) / (2^bits - 1 - black),
//      linear in light, not rounded yet.
//   2. Bilinear demosaic: at each pixel a colour it lacks is the mean of its nearest
//      pixels of that colour (the 2 or 4 neighbours in its 3x3 block, those inside the
//      frame at its edges); its own colour is kept.
//   No white balance, colour matrix or gamma: each channel stays its own raw channel,
//   so its mean over a uniform area is the raw channel's mean, scaled.
//   3. For YCbCr (BT.601, limited range): Y = 16 + 219 Y' / 255 with
//      Y' = 0.299 R + 0.587 G + 0.114 B; Cb = 128 + 224 (B - Y') / (1.772 x 255),
//      Cr = 128 + 224 (R - Y') / (1.402 x 255); each chroma sample from the mean R, G, B
//      of the pixels it covers (a pair for YUYV, a 2x2 block for NV12).
//
// Binning (the device's half-size frames) happens before, on the raw data: a mosaic is
// binned per colour, so it stays a mosaic of the same order.
//
// Reentrant: pure functions.
#pragma once

#include <opencv2/core.hpp>

#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

// 2x2 binning of a CV_32F Bayer mosaic (even width and height), whatever its order:
// output pixel (x, y) is the mean of the four pixels of its colour nearest the binned
// cell, source columns 4 (x / 2) + (x % 2) + {0, 2} and rows likewise (at an edge that
// cuts a 4x4 cell, the one inside the frame twice).
cv::Mat bin_bayer(const cv::Mat& mosaic);

// A CV_32F mosaic of raw DN to CV_32FC3 R, G, B in 0..255 (steps 1 and 2, unrounded).
cv::Mat demosaic_to_rgb(const cv::Mat& mosaic, const SensorSpec& sensor);

// A value 0..255 rounded to a byte (half up), clipped.
inline uint8_t to_byte(double v) {
  return static_cast<uint8_t>(v <= 0 ? 0 : v >= 255 ? 255 : static_cast<int>(v + 0.5));
}

// BT.601 limited-range Y, Cb, Cr (unrounded) of linear 0..255 R, G, B (step 3).
struct Ycbcr {
  double y, cb, cr;
};
inline Ycbcr ycbcr_601_limited(double r, double g, double b) {
  const double luma = 0.299 * r + 0.587 * g + 0.114 * b;
  return {16 + 219.0 / 255.0 * luma, 128 + 224.0 / 255.0 * (b - luma) / 1.772,
          128 + 224.0 / 255.0 * (r - luma) / 1.402};
}

}  // namespace camlab::mock
