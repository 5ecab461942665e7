#include "image/png_encoder.h"

#include <libdeflate.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>

namespace camlab::image {

namespace {

constexpr uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
// PNG limits width and height to 2^31 - 1; camlab's frames are far smaller, and this
// bound keeps every size below in 32 bits.
constexpr int kMaxSide = 1 << 15;

void put_u32(std::vector<uint8_t>& out, uint32_t v) {
  const uint8_t bytes[4] = {static_cast<uint8_t>(v >> 24), static_cast<uint8_t>(v >> 16),
                            static_cast<uint8_t>(v >> 8), static_cast<uint8_t>(v)};
  out.insert(out.end(), bytes, bytes + 4);
}

// Appends a chunk: length, type, data, CRC-32 of type and data.
void put_chunk(std::vector<uint8_t>& out, const char type[4], const uint8_t* data, size_t size) {
  put_u32(out, static_cast<uint32_t>(size));
  const size_t type_at = out.size();
  out.insert(out.end(), type, type + 4);
  if (size) out.insert(out.end(), data, data + size);
  put_u32(out, libdeflate_crc32(0, out.data() + type_at, 4 + size));
}

// The Paeth predictor (PNG specification 9.4): whichever of left, up, up-left is closest
// to left + up - up-left, ties in that order.
inline uint8_t paeth(int a, int b, int c) {
  const int p = a + b - c;
  const int pa = std::abs(p - a), pb = std::abs(p - b), pc = std::abs(p - c);
  if (pa <= pb && pa <= pc) return static_cast<uint8_t>(a);
  if (pb <= pc) return static_cast<uint8_t>(b);
  return static_cast<uint8_t>(c);
}

// One image row as PNG stores it: R, G, B order, 16-bit samples big-endian.
void row_bytes(const cv::Mat& image, int y, uint8_t* out) {
  const int channels = image.channels();
  const int width = image.cols;
  if (image.depth() == CV_8U) {
    const uint8_t* in = image.ptr<uint8_t>(y);
    if (channels == 1) {
      std::memcpy(out, in, static_cast<size_t>(width));
      return;
    }
    for (int x = 0; x < width; ++x, in += 3, out += 3) {
      out[0] = in[2];
      out[1] = in[1];
      out[2] = in[0];
    }
    return;
  }
  const uint16_t* in = image.ptr<uint16_t>(y);
  if (channels == 1) {
    for (int x = 0; x < width; ++x, out += 2) {
      out[0] = static_cast<uint8_t>(in[x] >> 8);
      out[1] = static_cast<uint8_t>(in[x]);
    }
    return;
  }
  for (int x = 0; x < width; ++x, in += 3, out += 6) {
    for (int c = 0; c < 3; ++c) {
      out[2 * c] = static_cast<uint8_t>(in[2 - c] >> 8);
      out[2 * c + 1] = static_cast<uint8_t>(in[2 - c]);
    }
  }
}

// Filters one row (PNG specification 9.2); `prior` is all zeros for the first row. `bpp`
// is the bytes of one pixel: the distance to the corresponding byte on the left.
void filter_row(PngFilter filter, const uint8_t* raw, const uint8_t* prior, size_t size, size_t bpp,
                uint8_t* out) {
  switch (filter) {
    case PngFilter::kNone:
      std::memcpy(out, raw, size);
      return;
    case PngFilter::kSub:
      for (size_t i = 0; i < std::min(bpp, size); ++i) out[i] = raw[i];
      for (size_t i = bpp; i < size; ++i) out[i] = static_cast<uint8_t>(raw[i] - raw[i - bpp]);
      return;
    case PngFilter::kUp:
      for (size_t i = 0; i < size; ++i) out[i] = static_cast<uint8_t>(raw[i] - prior[i]);
      return;
    case PngFilter::kAverage:
      for (size_t i = 0; i < size; ++i) {
        const int left = i >= bpp ? raw[i - bpp] : 0;
        out[i] = static_cast<uint8_t>(raw[i] - ((left + prior[i]) >> 1));
      }
      return;
    case PngFilter::kPaeth:
      for (size_t i = 0; i < size; ++i) {
        const int left = i >= bpp ? raw[i - bpp] : 0;
        const int up_left = i >= bpp ? prior[i - bpp] : 0;
        out[i] = static_cast<uint8_t>(raw[i] - paeth(left, prior[i], up_left));
      }
      return;
  }
}

}  // namespace

void PngEncoder::FreeCompressor::operator()(libdeflate_compressor* c) const {
  libdeflate_free_compressor(c);
}

PngEncoder::PngEncoder(PngOptions options) : options_(options) {
  options_.level = std::clamp(options_.level, 0, 12);
  compressor_.reset(libdeflate_alloc_compressor(options_.level));
}

PngEncoder::~PngEncoder() = default;
PngEncoder::PngEncoder(PngEncoder&&) noexcept = default;
PngEncoder& PngEncoder::operator=(PngEncoder&&) noexcept = default;

Result<std::span<const uint8_t>> PngEncoder::encode(const cv::Mat& image) {
  const int depth = image.depth();
  const int channels = image.channels();
  if (image.empty() || (depth != CV_8U && depth != CV_16U) || (channels != 1 && channels != 3))
    return make_error("bad_frame",
                      "a PNG frame must be an 8- or 16-bit image with 1 or 3 channels, not " +
                          std::string(image.empty() ? "an empty image" : "this one"));
  if (image.cols > kMaxSide || image.rows > kMaxSide)
    return make_error("bad_frame", "a " + std::to_string(image.cols) + "x" +
                                       std::to_string(image.rows) +
                                       " frame is larger than camlab writes (32768 px a side)");
  if (!compressor_) return make_error("io_error", "libdeflate could not allocate a compressor");

  const size_t bytes_per_sample = depth == CV_16U ? 2 : 1;
  const size_t bpp = bytes_per_sample * static_cast<size_t>(channels);
  const size_t row_size = bpp * static_cast<size_t>(image.cols);
  const size_t rows = static_cast<size_t>(image.rows);
  filtered_.resize(rows * (1 + row_size));
  rows_[0].assign(row_size, 0);  // the row before the first is zeros (PNG specification 9.2)
  rows_[1].resize(row_size);
  for (size_t y = 0; y < rows; ++y) {
    std::vector<uint8_t>& prior = rows_[y % 2];
    std::vector<uint8_t>& raw = rows_[(y + 1) % 2];
    row_bytes(image, static_cast<int>(y), raw.data());
    uint8_t* out = filtered_.data() + y * (1 + row_size);
    out[0] = static_cast<uint8_t>(options_.filter);
    filter_row(options_.filter, raw.data(), prior.data(), row_size, bpp, out + 1);
  }

  const size_t bound = libdeflate_zlib_compress_bound(compressor_.get(), filtered_.size());
  png_.clear();
  png_.reserve(bound + 64);
  png_.insert(png_.end(), kSignature, kSignature + sizeof kSignature);
  uint8_t header[13];
  const uint32_t width = static_cast<uint32_t>(image.cols), height = static_cast<uint32_t>(rows);
  for (int i = 0; i < 4; ++i) {
    header[i] = static_cast<uint8_t>(width >> (24 - 8 * i));
    header[4 + i] = static_cast<uint8_t>(height >> (24 - 8 * i));
  }
  header[8] = static_cast<uint8_t>(8 * bytes_per_sample);  // bit depth
  header[9] = channels == 3 ? 2 : 0;                       // colour type: truecolour or grey
  header[10] = 0;                                          // compression: deflate
  header[11] = 0;                                          // filter method 0 (five filters)
  header[12] = 0;                                          // no interlace
  put_chunk(png_, "IHDR", header, sizeof header);

  // IDAT: length, then type and the zlib stream compressed in place.
  const size_t idat_at = png_.size();
  png_.resize(idat_at + 8 + bound);
  const size_t zlib_size = libdeflate_zlib_compress(
      compressor_.get(), filtered_.data(), filtered_.size(), png_.data() + idat_at + 8, bound);
  if (zlib_size == 0) return make_error("io_error", "libdeflate: PNG data did not compress");
  uint8_t* idat = png_.data() + idat_at;
  for (int i = 0; i < 4; ++i) idat[i] = static_cast<uint8_t>(zlib_size >> (24 - 8 * i));
  std::memcpy(idat + 4, "IDAT", 4);
  png_.resize(idat_at + 8 + zlib_size);  // shrinking keeps the compressed bytes
  put_u32(png_, libdeflate_crc32(0, png_.data() + idat_at + 4, 4 + zlib_size));
  put_chunk(png_, "IEND", nullptr, 0);
  return std::span<const uint8_t>(png_);
}

}  // namespace camlab::image
