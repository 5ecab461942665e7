// NV12 and YU12 (4:2:0 YCbCr) frames to 8-bit R, G, B, with the quantization and encoding
// the driver declared (device::StreamFormat):
//
//   limited range: Y' = (Y - 16) / 219, Cb' = (Cb - 128) / 224, Cr' = (Cr - 128) / 224
//   full range:    Y' = Y / 255,        Cb' = (Cb - 128) / 255, Cr' = (Cr - 128) / 255
//   R = Y' + 2 (1 - Kr) Cr',  B = Y' + 2 (1 - Kb) Cb',  G = (Y' - Kr R - Kb B) / (1 - Kr - Kb)
//   BT.601: Kr = 0.299, Kb = 0.114;  BT.709: Kr = 0.2126, Kb = 0.0722
//
// then x 255, rounded and clipped to 0..255. Each chroma sample covers its 2x2 block of
// luma samples (no interpolation: a frame's and a region's means are exact).
//
// Reentrant: pure functions.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>

#include "device/camera.h"
#include "image/pixel_format.h"

namespace camlab::capture {

// `data` holds a whole frame of `format` (checked by the caller); returns CV_8UC3 in
// OpenCV's B, G, R order.
cv::Mat yuv420_to_bgr(const uint8_t* data, const device::StreamFormat& format,
                      image::SamplePacking packing);

}  // namespace camlab::capture
