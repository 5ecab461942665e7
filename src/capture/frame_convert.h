// From a driver buffer to what the capture folder stores (docs/capture-folder.md), in one
// pass that is also the one copy out of the buffer (the buffer goes back to the driver
// before the frame is written).
//
//   GREY, YUYV (its Y samples)       -> CV_8UC1, 8 bits
//   Y16, Bayer 16                    -> CV_16UC1: the sensor's DN right-aligned (they arrive
//                                       MSB-aligned) when its bit depth is known, else the
//                                       16-bit values unchanged (bit depth 16)
//   Y10P, Y12P, Bayer 10/12 (packed  -> CV_16UC1 of the DN, nothing rescaled; Bayer stays
//   or not), Bayer 8                    the raw mosaic (CV_8UC1 for 8 bits)
//   RGB3, BGR3, NV12, YU12           -> CV_8UC3 (B, G, R), YUV converted as declared
//   MJPG, JPEG                       -> the stream's bytes as delivered, not linear
//
// The black level follows the bit depth (a 12-bit sensor's 64 DN is 4 DN in GREY).
//
// Reentrant: pure functions.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "base/result.h"
#include "device/camera.h"
#include "image/pixel_format.h"

namespace camlab::capture {

struct ConvertedFrame {
  cv::Mat image;              // owns its pixels; empty for JPEG
  std::vector<uint8_t> jpeg;  // the stream as delivered, for MJPG/JPEG
  image::FrameLayout layout = image::FrameLayout::kMono;
  std::string cfa_pattern;  // "RGGB" ... for a mosaic, else ""
  int bit_depth = 8;
  int black_level_dn = 0;    // in DN of bit_depth bits
  int white_level_dn = 255;  // the largest DN the format can carry: 2^bit_depth - 1
                             // (235 for limited-range YUYV luma)
  bool linear = true;        // false for JPEG and for a declared curve (transfer)
  TransferFunction transfer = TransferFunction::kLinear;  // the format's, as declared
  std::string pixel_format;      // what the stored DN are: "GREY", "Y12", "SRGGB10", "RGB3", "MJPG"
  std::string delivered_format;  // the V4L2 fourcc as the camera sent it ("pRAA", "NV12")
};

// Whether convert_frame and frame_mean read this V4L2 fourcc.
bool can_convert(const std::string& fourcc);

// Whether a buffer holds a whole frame of `format` in a format convert_frame knows (for
// JPEG: a stream whose header decodes to the format's size). Errors "bad_frame" (buffer
// shorter than the format says, or a JPEG that is not one), "unsupported" (another fourcc).
Status check_frame(const device::Frame& frame, const device::StreamFormat& format);

// `sensor_bit_depth` / `black_level_dn`: the sensor's, 0 when unknown;
// `isp_subtracts_black`: YUYV's black is the format's own, not the sensor's pedestal
// (capture_plan.h, CameraTraits). Errors "bad_frame" (buffer shorter than the format says),
// "unsupported" (another fourcc).
Result<ConvertedFrame> convert_frame(const device::Frame& frame, const device::StreamFormat& format,
                                     int sensor_bit_depth, int black_level_dn,
                                     bool isp_subtracts_black = false);

// The mean value of a frame's samples in the units of its format (the Y samples of YUYV,
// every channel of colour formats, a 1/8-scale decode of JPEG), read without keeping a
// copy; for watching the signal change frame by frame.
Result<double> frame_mean(const device::Frame& frame, const device::StreamFormat& format);

}  // namespace camlab::capture
