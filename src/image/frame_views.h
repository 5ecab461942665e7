// Views of a stored frame that measurements read: its luminance (for finding corners and
// edges in colour frames) and, for a raw Bayer mosaic, its colour planes at half
// resolution (for measuring each channel on the samples the sensor really took).
//
// Reentrant: pure functions.
#pragma once

#include <array>
#include <opencv2/core.hpp>
#include <string>

#include "base/result.h"
#include "image/capture_folder.h"

namespace camlab::image {

// One channel of luminance with the stored depth (CV_8UC1 or CV_16UC1): mono frames as
// they are; mosaics demosaiced (bilinear, OpenCV) and weighted 0.299 R + 0.587 G + 0.114 B;
// rgb frames weighted the same. For corners and edge geometry, not for radiometry.
Result<cv::Mat> luminance_view(const cv::Mat& stored, const FrameSidecar& sidecar);

// A frame whose DN carry the curve the camera declared (sidecar.transfer sRGB or BT.709,
// a webcam's YUYV or MJPEG), decoded to light: 16-bit DN proportional to light, black 0,
// white 65535 (the code range between the frame's black and white levels; codes outside
// it clip), transfer linear; `linear` stays false for a JPEG (lossy). 16 bits keep every
// 8-bit code apart after decoding. A linear frame comes back as it is (decoded false);
// "not_linear" for a curve camlab does not know (transfer other).
struct LightFrame {
  cv::Mat stored;
  FrameSidecar sidecar;
  bool decoded = false;
};
Result<LightFrame> decode_to_light(const cv::Mat& stored, const FrameSidecar& sidecar);
// The sidecar decode_to_light gives a frame of `sidecar` (the same for a linear one).
FrameSidecar light_sidecar(const FrameSidecar& sidecar);

// The frame as a picture, with the stored depth: mono frames as they are (one channel),
// mosaics demosaiced (bilinear, OpenCV) to B, G, R, rgb frames as they are (B, G, R).
// For display, not for radiometry.
Result<cv::Mat> picture_view(const cv::Mat& stored, const FrameSidecar& sidecar);

// A mosaic's four sample planes in the order the pattern names them (RGGB: R, G, G, B),
// each (rows/2) x (cols/2), the samples unchanged. Plane k holds the samples at
// (2 y + k / 2, 2 x + k % 2).
struct CfaPlanes {
  std::array<cv::Mat, 4> planes;
  std::array<char, 4> colours{};  // 'R', 'G' or 'B' for each plane
};
Result<CfaPlanes> cfa_planes(const cv::Mat& stored, const FrameSidecar& sidecar);

}  // namespace camlab::image
