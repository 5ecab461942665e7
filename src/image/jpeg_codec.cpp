#include "image/jpeg_codec.h"

#include <turbojpeg.h>

#include <memory>
#include <string>

namespace camlab::image {

namespace {

struct HandleCloser {
  void operator()(void* handle) const { tjDestroy(handle); }
};
using Handle = std::unique_ptr<void, HandleCloser>;

// One decompressor and one compressor per thread: creating them costs more than decoding
// a small frame's header.
tjhandle decompressor() {
  thread_local Handle handle(tjInitDecompress());
  return handle.get();
}
tjhandle compressor() {
  thread_local Handle handle(tjInitCompress());
  return handle.get();
}

Error turbojpeg_error(tjhandle handle, const char* what) {
  return make_error("bad_image", std::string(what) + ": " + tjGetErrorStr2(handle));
}

// The stream's size, checked so that every later call sees a sane picture.
Result<JpegHeader> header_of(tjhandle handle, std::span<const uint8_t> jpeg) {
  if (handle == nullptr) return make_error("io_error", "cannot start the JPEG decoder");
  if (jpeg.size() < 4 || jpeg[0] != 0xFF || jpeg[1] != 0xD8)
    return make_error("bad_image", "not a JPEG stream (" + std::to_string(jpeg.size()) +
                                       " bytes, no start-of-image marker)");
  int width = 0, height = 0, subsampling = 0, colourspace = 0;
  if (tjDecompressHeader3(handle, jpeg.data(), static_cast<unsigned long>(jpeg.size()), &width,
                          &height, &subsampling, &colourspace) != 0)
    return turbojpeg_error(handle, "JPEG header");
  if (width <= 0 || height <= 0 || width > 32768 || height > 32768)
    return make_error("bad_image", "JPEG of " + std::to_string(width) + "x" +
                                       std::to_string(height) + " pixels is not a camera frame");
  return JpegHeader{width, height, subsampling == TJSAMP_GRAY};
}

Result<cv::Mat> decode_scaled(std::span<const uint8_t> jpeg, int scale_denominator) {
  tjhandle handle = decompressor();
  auto header = header_of(handle, jpeg);
  if (!header) return header.error();
  const int width = (header->width + scale_denominator - 1) / scale_denominator;
  const int height = (header->height + scale_denominator - 1) / scale_denominator;
  cv::Mat image(height, width, header->greyscale ? CV_8UC1 : CV_8UC3);
  // Stop on warnings: a truncated stream "decodes" with its missing rows grey.
  if (tjDecompress2(handle, jpeg.data(), static_cast<unsigned long>(jpeg.size()), image.data, width,
                    static_cast<int>(image.step[0]), height,
                    header->greyscale ? TJPF_GRAY : TJPF_BGR, TJFLAG_STOPONWARNING) != 0)
    return turbojpeg_error(handle, "JPEG data");
  return image;
}

}  // namespace

Result<JpegHeader> read_jpeg_header(std::span<const uint8_t> jpeg) {
  return header_of(decompressor(), jpeg);
}

Result<cv::Mat> decode_jpeg(std::span<const uint8_t> jpeg) { return decode_scaled(jpeg, 1); }

Result<double> jpeg_mean_fast(std::span<const uint8_t> jpeg) {
  auto small = decode_scaled(jpeg, 8);
  if (!small) return small.error();
  const cv::Scalar per_channel = cv::mean(*small);
  double sum = 0;
  for (int c = 0; c < small->channels(); ++c) sum += per_channel[c];
  return sum / small->channels();
}

Result<std::vector<uint8_t>> encode_jpeg(const cv::Mat& image, int quality) {
  if (image.empty() || image.depth() != CV_8U || (image.channels() != 1 && image.channels() != 3))
    return make_error("invalid_argument", "JPEG encoding takes an 8-bit, 1- or 3-channel image");
  if (quality < 1 || quality > 100)
    return make_error("out_of_range",
                      "JPEG quality " + std::to_string(quality) + " is outside 1..100");
  tjhandle handle = compressor();
  if (handle == nullptr) return make_error("io_error", "cannot start the JPEG encoder");
  const bool grey = image.channels() == 1;
  unsigned char* out = nullptr;
  unsigned long out_size = 0;
  if (tjCompress2(handle, image.data, image.cols, static_cast<int>(image.step[0]), image.rows,
                  grey ? TJPF_GRAY : TJPF_BGR, &out, &out_size, grey ? TJSAMP_GRAY : TJSAMP_422,
                  quality, 0) != 0) {
    tjFree(out);
    return turbojpeg_error(handle, "JPEG encoding");
  }
  std::vector<uint8_t> bytes(out, out + out_size);
  tjFree(out);
  return bytes;
}

uint64_t jpeg_buffer_bound(int width, int height) {
  if (width <= 0 || height <= 0) return 0;
  return tjBufSize(width, height, TJSAMP_422);
}

}  // namespace camlab::image
