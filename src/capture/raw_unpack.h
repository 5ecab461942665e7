// Unpacking a driver's rows of raw samples into right-aligned DN, one row at a time:
// 8-bit, 16-bit (DN in the low or the high bits), and MIPI CSI-2's packed RAW10 and RAW12,
// which carry 4 samples in 5 bytes (the high 8 bits of each, then a byte of the four 2-bit
// remainders, first sample in the lowest bits) and 2 samples in 3 bytes (the high 8 bits
// of each, then a byte of the two 4-bit remainders).
//
// Reentrant: pure functions.
#pragma once

#include <cstdint>

#include "image/pixel_format.h"

namespace camlab::capture {

// `width` samples of `packing` (k8, k16Low, k16High, kMipi10, kMipi12) from `in` to `out`.
// k16High keeps the top `significant_bits` bits, right-aligned; the others keep every bit.
void unpack_row(image::SamplePacking packing, const uint8_t* in, uint32_t width,
                int significant_bits, uint16_t* out);

// The same into 8-bit samples, for formats of 8 significant bits (k8, or k16High of an
// 8-bit sensor).
void unpack_row_8bit(image::SamplePacking packing, const uint8_t* in, uint32_t width, uint8_t* out);

}  // namespace camlab::capture
