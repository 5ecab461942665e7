#include "capture/raw_unpack.h"

#include <cstring>

namespace camlab::capture {

using image::SamplePacking;

namespace {

uint16_t little_endian_16(const uint8_t* in) { return static_cast<uint16_t>(in[0] | (in[1] << 8)); }

void unpack_mipi10(const uint8_t* in, uint32_t width, uint16_t* out) {
  uint32_t x = 0;
  for (; x + 4 <= width; x += 4, in += 5) {
    const uint8_t low = in[4];
    for (uint32_t i = 0; i < 4; ++i)
      out[x + i] = static_cast<uint16_t>((in[i] << 2) | ((low >> (2 * i)) & 0x3));
  }
  // A width that is not a multiple of 4 ends in a group padded to 4 samples.
  for (uint32_t i = 0; x + i < width; ++i)
    out[x + i] = static_cast<uint16_t>((in[i] << 2) | ((in[4] >> (2 * i)) & 0x3));
}

void unpack_mipi12(const uint8_t* in, uint32_t width, uint16_t* out) {
  uint32_t x = 0;
  for (; x + 2 <= width; x += 2, in += 3) {
    out[x] = static_cast<uint16_t>((in[0] << 4) | (in[2] & 0xf));
    out[x + 1] = static_cast<uint16_t>((in[1] << 4) | (in[2] >> 4));
  }
  if (x < width) out[x] = static_cast<uint16_t>((in[0] << 4) | (in[2] & 0xf));
}

}  // namespace

void unpack_row(SamplePacking packing, const uint8_t* in, uint32_t width, int significant_bits,
                uint16_t* out) {
  switch (packing) {
    case SamplePacking::k8:
      for (uint32_t x = 0; x < width; ++x) out[x] = in[x];
      return;
    case SamplePacking::k16Low:
      for (uint32_t x = 0; x < width; ++x) out[x] = little_endian_16(in + 2 * x);
      return;
    case SamplePacking::k16High: {
      const int shift = 16 - significant_bits;
      for (uint32_t x = 0; x < width; ++x)
        out[x] = static_cast<uint16_t>(little_endian_16(in + 2 * x) >> shift);
      return;
    }
    case SamplePacking::kMipi10:
      unpack_mipi10(in, width, out);
      return;
    case SamplePacking::kMipi12:
      unpack_mipi12(in, width, out);
      return;
    default:
      std::memset(out, 0, width * sizeof(uint16_t));  // not a raw packing: callers never ask
      return;
  }
}

void unpack_row_8bit(SamplePacking packing, const uint8_t* in, uint32_t width, uint8_t* out) {
  if (packing == SamplePacking::k8) {
    std::memcpy(out, in, width);
    return;
  }
  // k16High of an 8-bit sensor: the high byte.
  for (uint32_t x = 0; x < width; ++x) out[x] = in[2 * x + 1];
}

}  // namespace camlab::capture
