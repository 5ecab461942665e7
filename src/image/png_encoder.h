// PNG encoding for capture frames, with libdeflate: the same lossless PNG any reader
// takes (libpng, OpenCV, browsers), at a fraction of zlib's time. A capture writes one
// frame per sensor frame, so the encoder sets the disk's pace (docs/BENCHMARKS.md, "Frame
// writes", has the table of level and filter against time and size that chose the
// defaults).
//
// Layout written (PNG specification, ISO/IEC 15948): the signature, IHDR (grey or RGB,
// 8 or 16 bits, no interlace), one IDAT holding the zlib stream of the filtered rows,
// IEND. Samples are big-endian, as PNG requires; a 3-channel image is taken in OpenCV's
// B, G, R order and stored as R, G, B.
//
// Thread-compatible: one encoder per thread (it keeps its buffers between frames).
#pragma once

#include <cstdint>
#include <memory>
#include <span>
#include <vector>

#include <opencv2/core.hpp>

#include "base/result.h"

struct libdeflate_compressor;

namespace camlab::image {

// PNG's row filters (the filter type byte of each row).
enum class PngFilter : uint8_t { kNone = 0, kSub = 1, kUp = 2, kAverage = 3, kPaeth = 4 };

struct PngOptions {
  int level = 1;                       // libdeflate 0 (stored) .. 12 (smallest)
  PngFilter filter = PngFilter::kSub;  // the same filter on every row
};

class PngEncoder {
 public:
  explicit PngEncoder(PngOptions options = {});
  ~PngEncoder();
  PngEncoder(PngEncoder&&) noexcept;
  PngEncoder& operator=(PngEncoder&&) noexcept;

  // Encodes CV_8UC1, CV_16UC1 (grey) or CV_8UC3, CV_16UC3 (B, G, R). The bytes stay
  // valid until the next call.
  Result<std::span<const uint8_t>> encode(const cv::Mat& image);

  const PngOptions& options() const { return options_; }

 private:
  struct FreeCompressor {
    void operator()(libdeflate_compressor* c) const;
  };
  PngOptions options_;
  std::unique_ptr<libdeflate_compressor, FreeCompressor> compressor_;
  std::vector<uint8_t> filtered_;  // rows x (1 + row bytes): filter byte, then the row
  std::vector<uint8_t> rows_[2];   // the current and previous row, unfiltered, big-endian
  std::vector<uint8_t> png_;
};

}  // namespace camlab::image
