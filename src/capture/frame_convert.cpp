#include "capture/frame_convert.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

namespace camlab::capture {

namespace {

int bytes_per_pixel(const std::string& fourcc) { return fourcc == "GREY" ? 1 : 2; }

size_t stride_of(const device::StreamFormat& format) {
  return std::max<size_t>(
      format.bytes_per_line,
      static_cast<size_t>(format.width) * static_cast<size_t>(bytes_per_pixel(format.fourcc)));
}

const char* pixel_format_for(int bit_depth) {
  switch (bit_depth) {
    case 8:
      return "GREY";
    case 10:
      return "Y10";
    case 12:
      return "Y12";
    case 14:
      return "Y14";
    default:
      return "Y16";
  }
}

// A deeper sensor's black level in 8-bit samples (its top 8 bits).
int black_level_8bit(int sensor_bit_depth, int black_level_dn) {
  if (sensor_bit_depth <= 8) return black_level_dn;
  return static_cast<int>(std::lround(std::ldexp(black_level_dn, 8 - sensor_bit_depth)));
}

}  // namespace

bool can_convert(const std::string& fourcc) {
  return fourcc == "GREY" || fourcc == "Y16 " || fourcc == "YUYV";
}

Status check_frame(const device::Frame& frame, const device::StreamFormat& format) {
  if (!can_convert(format.fourcc))
    return make_error("unsupported", "pixel format '" + format.fourcc +
                                         "' cannot be captured (GREY, Y16, YUYV can)");
  const size_t row_bytes =
      static_cast<size_t>(format.width) * static_cast<size_t>(bytes_per_pixel(format.fourcc));
  const size_t stride = stride_of(format);
  const size_t needed = format.height == 0 ? 0 : stride * (format.height - 1) + row_bytes;
  if (frame.data == nullptr || format.width == 0 || format.height == 0 || frame.size < needed)
    return make_error("bad_frame", "frame " + std::to_string(frame.meta.sequence) + " has " +
                                       std::to_string(frame.size) + " bytes; " + format.fourcc +
                                       " " + std::to_string(format.width) + "x" +
                                       std::to_string(format.height) + " needs " +
                                       std::to_string(needed));
  return {};
}

Result<ConvertedFrame> convert_frame(const device::Frame& frame, const device::StreamFormat& format,
                                     int sensor_bit_depth, int black_level_dn) {
  if (Status s = check_frame(frame, format); !s) return s.error();
  const int rows = static_cast<int>(format.height), cols = static_cast<int>(format.width);
  const size_t stride = stride_of(format);
  ConvertedFrame out;
  if (format.fourcc == "GREY" || format.fourcc == "YUYV") {
    out.image.create(rows, cols, CV_8UC1);
    const size_t pitch = format.fourcc == "GREY" ? 1 : 2;  // YUYV: Y0 U Y1 V
    for (int y = 0; y < rows; ++y) {
      const uint8_t* in = frame.data + static_cast<size_t>(y) * stride;
      uint8_t* row = out.image.ptr<uint8_t>(y);
      if (pitch == 1) {
        std::memcpy(row, in, static_cast<size_t>(cols));
      } else {
        for (int x = 0; x < cols; ++x) row[x] = in[2 * static_cast<size_t>(x)];
      }
    }
    out.bit_depth = 8;
    out.black_level_dn =
        sensor_bit_depth > 0 ? black_level_8bit(sensor_bit_depth, black_level_dn) : 0;
    out.pixel_format = "GREY";
    return out;
  }
  // Y16: little-endian, the DN in the top bits. A known depth shifts them back down so
  // that the folder holds the raw DN; an 8-bit sensor's land in an 8-bit image.
  const int depth = sensor_bit_depth >= 1 && sensor_bit_depth <= 16 ? sensor_bit_depth : 16;
  const int shift = 16 - depth;
  out.bit_depth = depth;
  out.black_level_dn = sensor_bit_depth > 0 ? black_level_dn : 0;
  out.pixel_format = pixel_format_for(depth);
  out.image.create(rows, cols, depth <= 8 ? CV_8UC1 : CV_16UC1);
  for (int y = 0; y < rows; ++y) {
    const uint8_t* in = frame.data + static_cast<size_t>(y) * stride;
    if (depth <= 8) {
      uint8_t* row = out.image.ptr<uint8_t>(y);
      for (int x = 0; x < cols; ++x)
        row[x] = static_cast<uint8_t>((in[2 * x] | (in[2 * x + 1] << 8)) >> shift);
    } else {
      uint16_t* row = out.image.ptr<uint16_t>(y);
      for (int x = 0; x < cols; ++x)
        row[x] = static_cast<uint16_t>((in[2 * x] | (in[2 * x + 1] << 8)) >> shift);
    }
  }
  return out;
}

Result<double> frame_mean(const device::Frame& frame, const device::StreamFormat& format) {
  if (Status s = check_frame(frame, format); !s) return s.error();
  const int rows = static_cast<int>(format.height), cols = static_cast<int>(format.width);
  auto* data = const_cast<uint8_t*>(frame.data);  // read only: cv::Mat has no const view
  const size_t stride = stride_of(format);
  if (format.fourcc == "GREY") return cv::mean(cv::Mat(rows, cols, CV_8UC1, data, stride))[0];
  if (format.fourcc == "YUYV") return cv::mean(cv::Mat(rows, cols, CV_8UC2, data, stride))[0];
  // Y16 is little-endian; so is every host camlab builds for (x86-64, arm64).
  static_assert(std::endian::native == std::endian::little, "frame_mean reads Y16 in host order");
  return cv::mean(cv::Mat(rows, cols, CV_16UC1, data, stride))[0];
}

}  // namespace camlab::capture
