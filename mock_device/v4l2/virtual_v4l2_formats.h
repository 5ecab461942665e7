// The pixel formats the virtual V4L2 device offers for its camera, how a frame of each is
// sized (bytesperline and sizeimage as the kernel's v4l2_fill_pixfmt gives them), and
// what its colorspace fields declare (docs/virtual-camera.md, "As a V4L2 device").
//
//   monochrome sensor   GREY, Y16, YUYV (grey: U = V = 128)
//   Bayer sensor        in the sensor's own CFA order (a sensor offers its own order):
//                       raw 8, 10 and 12 bits (10/12 unpacked: LSB-aligned in 16 bits),
//                       16 bits (MSB-aligned, as Y16), MIPI-packed 10 and 12 bits; only
//                       depths the sensor has, fewer bits being its top bits, rounded.
//                       From the image processor (a bilinear demosaic, black subtracted,
//                       linear 8 bits): RGB3, BGR3, NV12, YUYV, and MJPG (libjpeg-turbo at
//                       isp.jpeg_quality).
//
// Every format comes in two sizes: the sensor's, and 2x2 binned (half width and height;
// a Bayer sensor bins the four nearest pixels of each colour, so the binned frame is a
// mosaic of the same order). YUYV and NV12 take an even width, NV12 an even height.
//
// Reentrant: plain values.
#pragma once

#include <linux/videodev2.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

// How a format's bytes are made from the sensor's DN.
enum class FormatKind {
  kGrey,         // 8 bits: DN of a monochrome sensor's top 8 bits
  kY16,          // 16 bits little endian: DN << (16 - bits)
  kYuyv,         // 4:2:2 YCbCr, BT.601 limited range
  kBayer8,       // one byte per sample
  kBayer16Low,   // 10 or 12 significant bits in 16, LSB-aligned, little endian
  kBayer16High,  // the sensor's DN in the top bits of 16, little endian
  kBayerMipi10,  // MIPI CSI-2 RAW10: 4 samples in 5 bytes
  kBayerMipi12,  // MIPI CSI-2 RAW12: 2 samples in 3 bytes
  kRgb24,        // R, G, B bytes
  kBgr24,        // B, G, R bytes
  kNv12,         // Y plane, then interleaved Cb Cr at half resolution; BT.601 limited
  kMjpeg,        // a JPEG (JFIF, 4:2:2) of the demosaiced image
};

struct OfferedFormat {
  uint32_t fourcc = 0;
  FormatKind kind = FormatKind::kGrey;
  int bits = 8;             // significant bits per raw sample (Bayer); 8 otherwise
  std::string description;  // as the kernel names it ("10-bit Bayer RGRG/GBGB Packed")

  bool is_bayer() const {
    return kind == FormatKind::kBayer8 || kind == FormatKind::kBayer16Low ||
           kind == FormatKind::kBayer16High || kind == FormatKind::kBayerMipi10 ||
           kind == FormatKind::kBayerMipi12;
  }
  bool compressed() const { return kind == FormatKind::kMjpeg; }
};

// The formats a camera offers, in VIDIOC_ENUM_FMT's order.
std::vector<OfferedFormat> offered_formats(const SensorSpec& sensor);

// What S_FMT falls back to for a format the device does not offer (and the format a
// device starts with): Y16 or GREY for a monochrome sensor, the raw Bayer format of the
// sensor's depth (16 bits above 12) for a colour one.
uint32_t default_fourcc(const SensorSpec& sensor);

// Frame size `index` (0: the sensor's, 1: 2x2 binned) of a format, aligned as the format
// needs; nullopt for another index.
struct FrameSize {
  uint32_t width = 0;
  uint32_t height = 0;
};
std::optional<FrameSize> frame_size(const OfferedFormat& format, const SensorSpec& sensor,
                                    uint32_t index);

// bytesperline, sizeimage and the colorspace fields of a `size` frame (one of
// frame_size's) of `format`. MJPG: bytesperline 0, sizeimage an upper bound of any JPEG
// of that size (each frame's length is its buffer's bytesused). `isp.transfer`: the curve
// of the processed formats (raw ones are linear whatever it is), declared unless
// `isp.declares_colour_space` is false.
void fill_pix_format(const OfferedFormat& format, FrameSize size, v4l2_pix_format* pix,
                     const IspSpec& isp = IspSpec{});

}  // namespace camlab::mock
