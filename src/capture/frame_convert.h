// From a driver buffer to the capture folder's single-channel image of raw DN
// (docs/capture-folder.md), in one pass that is also the one copy out of the buffer (the
// buffer goes back to the driver before the frame is written).
//
//   GREY  -> CV_8UC1, 8 bits
//   YUYV  -> CV_8UC1 of the Y samples, 8 bits
//   Y16   -> CV_16UC1: the sensor's DN right-aligned (Y16 carries them MSB-aligned) when
//            its bit depth is known, else the 16-bit values unchanged (bit depth 16)
// The black level follows the bit depth (a 12-bit sensor's 64 DN is 4 DN in GREY).
//
// Reentrant: pure functions.
#pragma once

#include <opencv2/core.hpp>
#include <string>

#include "base/result.h"
#include "device/camera.h"

namespace camlab::capture {

struct ConvertedFrame {
  cv::Mat image;  // owns its pixels
  int bit_depth = 8;
  int black_level_dn = 0;    // in DN of bit_depth bits
  std::string pixel_format;  // what the DN are: "GREY", "Y10", "Y12", "Y14" or "Y16"
};

// Whether convert_frame and frame_mean read this V4L2 fourcc ("GREY", "Y16 ", "YUYV").
bool can_convert(const std::string& fourcc);

// Whether a buffer holds a whole frame of `format` in a format convert_frame knows.
// Errors "bad_frame" (buffer shorter than the format says), "unsupported" (another fourcc).
Status check_frame(const device::Frame& frame, const device::StreamFormat& format);

// `sensor_bit_depth` / `black_level_dn`: the sensor's, 0 when unknown. Errors
// "bad_frame" (buffer shorter than the format says), "unsupported" (another fourcc).
Result<ConvertedFrame> convert_frame(const device::Frame& frame, const device::StreamFormat& format,
                                     int sensor_bit_depth, int black_level_dn);

// The mean value of a frame's samples in the units of its format (the Y samples of
// YUYV), read in place; for watching the signal change frame by frame.
Result<double> frame_mean(const device::Frame& frame, const device::StreamFormat& format);

}  // namespace camlab::capture
