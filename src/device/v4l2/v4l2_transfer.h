// The transfer function a V4L2 format declares (v4l2_pix_format's xfer_func), resolved
// as the kernel's V4L2_MAP_XFER_FUNC_DEFAULT does when the driver leaves it at DEFAULT:
// raw colour spaces are linear, sRGB and JPEG are sRGB-encoded, Adobe RGB, SMPTE 240M and
// DCI-P3 their own curves, every other colour space (BT.709, BT.601, BT.2020) BT.709's.
// So a webcam's YUYV or MJPEG, which declares sRGB or BT.709 or leaves the curve to its
// colour space, is not linear; only an explicit V4L2_XFER_FUNC_NONE or a raw colour space
// is. A driver that leaves the colour space at DEFAULT too declares nothing (the kernel
// asks drivers never to; V4L2_MAP_XFER_FUNC_DEFAULT would read it as BT.709, a guess):
// unknown, for capture to resolve by the format (raw samples are linear,
// base/transfer_function.h).
//
// Reentrant: a pure function.
#pragma once

#include <linux/videodev2.h>

#include <cstdint>

#include "base/transfer_function.h"

namespace camlab::device {

constexpr TransferFunction transfer_function_of(uint32_t colorspace, uint32_t xfer_func) {
  if (xfer_func == V4L2_XFER_FUNC_DEFAULT) {
    switch (colorspace) {
      case V4L2_COLORSPACE_DEFAULT:
        return TransferFunction::kUnknown;
      case V4L2_COLORSPACE_RAW:
        return TransferFunction::kLinear;
      case V4L2_COLORSPACE_SRGB:
      case V4L2_COLORSPACE_JPEG:
        return TransferFunction::kSrgb;
      case V4L2_COLORSPACE_OPRGB:
      case V4L2_COLORSPACE_SMPTE240M:
      case V4L2_COLORSPACE_DCI_P3:
        return TransferFunction::kOther;
      default:
        return TransferFunction::kBt709;
    }
  }
  switch (xfer_func) {
    case V4L2_XFER_FUNC_NONE:
      return TransferFunction::kLinear;
    case V4L2_XFER_FUNC_SRGB:
      return TransferFunction::kSrgb;
    case V4L2_XFER_FUNC_709:
      return TransferFunction::kBt709;
    default:  // OPRGB, SMPTE240M, SMPTE2084 (PQ), DCI_P3
      return TransferFunction::kOther;
  }
}

}  // namespace camlab::device
