// The pixel formats camlab captures, by V4L2 fourcc: what the bytes of a buffer are and
// what a capture folder stores from them (docs/capture-folder.md, "Pixel formats").
//
//   mono     GREY, Y16, Y10P, Y12P (MIPI-packed), and YUYV's Y samples
//   mosaic   raw Bayer in the four CFA orders: 8 bits, 10/12 bits in 16 (LSB-aligned),
//            16 bits, and MIPI-packed 10/12 bits (pRAA, pRCC, ...)
//   rgb      RGB3/BGR3, and NV12/YU12 converted with the quantization they declare
//   jpeg     MJPG/JPEG: stored as delivered, not linear in light
//
// Reentrant: a constant table.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

namespace camlab::image {

// What a stored frame's samples are.
enum class FrameLayout {
  kMono,    // one channel of luminance DN
  kMosaic,  // one channel, the raw colour filter array (cfa_pattern says which colour)
  kRgb,     // three channels R, G, B (stored as PNG, or as the camera's JPEG)
};

// How a buffer's samples are laid out in memory.
enum class SamplePacking {
  k8,       // one byte per sample
  k16Low,   // 16-bit little-endian, the DN in the low bits (Bayer 10/12 unpacked)
  k16High,  // 16-bit little-endian, the DN in the high bits (Y16, Bayer 16)
  kMipi10,  // 4 samples in 5 bytes: 4 high bytes, then the 2-bit remainders
  kMipi12,  // 2 samples in 3 bytes: 2 high bytes, then the 4-bit remainders
  kYuyv,    // Y0 U Y1 V, 4 bytes per 2 pixels
  kRgb24,   // R G B
  kBgr24,   // B G R
  kNv12,    // Y plane, then one plane of interleaved U V at half resolution
  kYuv420,  // Y plane, U plane, V plane (YU12), chroma at half resolution
  kJpeg,    // a JPEG stream (MJPG/JPEG)
};

struct PixelFormatInfo {
  std::string_view fourcc;  // as V4L2 spells it, 4 characters ("pRAA", "Y16 ")
  std::string_view name;    // as V4L2's documentation names it ("SRGGB10P")
  FrameLayout layout = FrameLayout::kMono;
  SamplePacking packing = SamplePacking::k8;
  int bits_per_sample = 8;  // significant bits of the DN as delivered
  std::string_view cfa;     // "RGGB", "BGGR", "GRBG", "GBRG" for mosaics, else ""
  bool linear = true;       // false for JPEG: gamma-encoded, lossy
};

// The format a fourcc names, or nullopt when camlab cannot capture it.
std::optional<PixelFormatInfo> pixel_format_info(std::string_view fourcc);

// Every format camlab captures (for messages and the virtual camera's list).
const std::vector<PixelFormatInfo>& capturable_pixel_formats();

// "GREY, Y16, YUYV, ...": the capturable fourccs, for an error message.
std::string capturable_fourcc_list();

// The bytes one row of `width` pixels takes without padding (for planar YUV, the luma
// row), or 0 for JPEG (variable length).
uint64_t packed_row_bytes(const PixelFormatInfo& format, uint32_t width);

// The bytes a whole frame takes at `bytes_per_line` (>= packed_row_bytes), for every
// plane; 0 for JPEG.
uint64_t frame_bytes(const PixelFormatInfo& format, uint32_t width, uint32_t height,
                     uint32_t bytes_per_line);

// The colour of the mosaic sample at (x, y): 0 = R, 1 = G, 2 = B; for cfa "RGGB" etc.
int cfa_colour_at(std::string_view cfa, int x, int y);

// What a capture folder calls the stored DN of a monochrome frame of `bit_depth` bits:
// GREY, Y10, Y12, Y14, or Y16 for any other depth (docs/capture-folder.md).
std::string_view mono_pixel_format(int bit_depth);

// Whether `cfa` is one of the four Bayer orders.
bool is_bayer_pattern(std::string_view cfa);

}  // namespace camlab::image
