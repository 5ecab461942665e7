// One rendered frame in the bytes of a V4L2 pixel format (virtual_v4l2_formats.h), as a
// driver's buffer holds it: rows at bytesperline, 16-bit samples little endian, MIPI
// packing, planes one after the other, or a JPEG stream.
//
// From the renderer's raw DN (the sensor's full frame):
//   size      2x2 binned when the format's size is half the sensor's (a monochrome frame
//             area-averaged, a mosaic per colour: virtual_isp.h), cropped to the format's
//             even width/height where it has one
//   GREY      DN x 2^(8 - bits), rounded, clipped         Y16   DN x 2^(16 - bits), rounded
//   YUYV      monochrome: Y = 16 + 219 v / 255 of the GREY value v (unrounded), U = V = 128;
//             colour: BT.601 limited range of the ISP's R, G, B
//   Bayer     DN x 2^(format bits - sensor bits), rounded, clipped: every bit for a
//             format as deep as the sensor, the top bits for a shallower one; 16-bit
//             Bayer MSB-aligned
//   RGB3, BGR3, NV12, MJPG   the ISP's image (virtual_isp.h); MJPG at `jpeg_quality`
//
// Reentrant: pure functions (the JPEG encoder uses a handle of the calling thread).
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/v4l2/virtual_v4l2_formats.h"

namespace camlab::mock {

// `raw_dn`: CV_8UC1 or CV_16UC1 of the sensor's size; `pix` from fill_pix_format. Returns
// the frame's bytes: sizeimage of them, or the JPEG's length (at most sizeimage) for MJPG.
// The processed formats carry the ISP's curve (isp.transfer); raw formats stay linear.
Result<std::vector<uint8_t>> encode_frame(const cv::Mat& raw_dn, const SensorSpec& sensor,
                                          const IspSpec& isp, const OfferedFormat& format,
                                          const v4l2_pix_format& pix);

}  // namespace camlab::mock
