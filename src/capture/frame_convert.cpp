#include "capture/frame_convert.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <span>

#include "capture/raw_unpack.h"
#include "capture/yuv_to_rgb.h"
#include "image/jpeg_codec.h"

namespace camlab::capture {

namespace {

using image::FrameLayout;
using image::PixelFormatInfo;
using image::SamplePacking;

size_t stride_of(const PixelFormatInfo& info, const device::StreamFormat& format) {
  return std::max<size_t>(format.bytes_per_line, image::packed_row_bytes(info, format.width));
}

// What the stored DN are called: V4L2's name for that depth, unpacked.
std::string stored_format_name(const PixelFormatInfo& info, int bit_depth) {
  if (info.layout == FrameLayout::kRgb)
    return info.packing == SamplePacking::kJpeg ? "MJPG" : "RGB3";
  if (info.layout == FrameLayout::kMosaic)
    return "S" + std::string(info.cfa) + std::to_string(bit_depth);
  return bit_depth <= 8 ? "GREY" : "Y" + std::to_string(bit_depth);
}

// A deeper sensor's black level in the DN of a format that keeps fewer bits (its top bits).
int black_level_in(int format_bits, int sensor_bit_depth, int black_level_dn) {
  if (sensor_bit_depth <= 0) return 0;
  if (sensor_bit_depth <= format_bits) return black_level_dn;
  return static_cast<int>(std::lround(std::ldexp(black_level_dn, format_bits - sensor_bit_depth)));
}

std::string fourcc_name(const std::string& fourcc) {
  std::string name = fourcc;
  while (!name.empty() && name.back() == ' ') name.pop_back();
  return name;
}

Error unsupported(const std::string& fourcc) {
  return make_error("unsupported", "pixel format '" + fourcc_name(fourcc) +
                                       "' cannot be captured (camlab captures " +
                                       image::capturable_fourcc_list() + ")");
}

// Raw samples (mono or mosaic) to DN.
ConvertedFrame unpack_raw(const device::Frame& frame, const device::StreamFormat& format,
                          const PixelFormatInfo& info, int sensor_bit_depth, int black_level_dn) {
  const int rows = static_cast<int>(format.height), cols = static_cast<int>(format.width);
  const size_t stride = stride_of(info, format);
  // Y16 and Bayer 16 carry the sensor's DN in their high bits: a known depth shifts them
  // back down so that the folder holds the raw DN.
  int depth = info.bits_per_sample;
  if (info.packing == SamplePacking::k16High)
    depth = sensor_bit_depth >= 1 && sensor_bit_depth <= 16 ? sensor_bit_depth : 16;
  ConvertedFrame out;
  out.layout = info.layout;
  out.cfa_pattern = std::string(info.cfa);
  out.bit_depth = depth;
  out.black_level_dn = black_level_in(depth, sensor_bit_depth, black_level_dn);
  out.white_level_dn = (1 << depth) - 1;
  out.image.create(rows, cols, depth <= 8 ? CV_8UC1 : CV_16UC1);
  for (int y = 0; y < rows; ++y) {
    const uint8_t* in = frame.data + static_cast<size_t>(y) * stride;
    if (depth <= 8)
      unpack_row_8bit(info.packing, in, format.width, out.image.ptr<uint8_t>(y));
    else
      unpack_row(info.packing, in, format.width, depth, out.image.ptr<uint16_t>(y));
  }
  return out;
}

ConvertedFrame luma_of_yuyv(const device::Frame& frame, const device::StreamFormat& format,
                            const PixelFormatInfo& info) {
  const int rows = static_cast<int>(format.height), cols = static_cast<int>(format.width);
  const size_t stride = stride_of(info, format);
  ConvertedFrame out;
  out.image.create(rows, cols, CV_8UC1);
  for (int y = 0; y < rows; ++y) {
    const uint8_t* in = frame.data + static_cast<size_t>(y) * stride;
    uint8_t* row = out.image.ptr<uint8_t>(y);
    for (int x = 0; x < cols; ++x) row[x] = in[2 * static_cast<size_t>(x)];  // Y0 U Y1 V
  }
  return out;
}

ConvertedFrame rgb_of(const device::Frame& frame, const device::StreamFormat& format,
                      const PixelFormatInfo& info) {
  ConvertedFrame out;
  out.layout = FrameLayout::kRgb;
  if (info.packing == SamplePacking::kNv12 || info.packing == SamplePacking::kYuv420) {
    out.image = yuv420_to_bgr(frame.data, format, info.packing);
    return out;
  }
  const int rows = static_cast<int>(format.height), cols = static_cast<int>(format.width);
  const size_t stride = stride_of(info, format);
  out.image.create(rows, cols, CV_8UC3);
  const bool swap = info.packing == SamplePacking::kRgb24;  // OpenCV keeps B, G, R
  for (int y = 0; y < rows; ++y) {
    const uint8_t* in = frame.data + static_cast<size_t>(y) * stride;
    uint8_t* row = out.image.ptr<uint8_t>(y);
    if (!swap) {
      std::memcpy(row, in, static_cast<size_t>(cols) * 3);
      continue;
    }
    for (int x = 0; x < cols; ++x) {
      row[3 * x] = in[3 * x + 2];
      row[3 * x + 1] = in[3 * x + 1];
      row[3 * x + 2] = in[3 * x];
    }
  }
  return out;
}

}  // namespace

bool can_convert(const std::string& fourcc) { return image::pixel_format_info(fourcc).has_value(); }

Status check_frame(const device::Frame& frame, const device::StreamFormat& format) {
  const auto info = image::pixel_format_info(format.fourcc);
  if (!info) return unsupported(format.fourcc);
  const std::string what = "frame " + std::to_string(frame.meta.sequence);
  if (frame.data == nullptr || format.width == 0 || format.height == 0)
    return make_error("bad_frame", what + " is empty");
  if (info->packing == SamplePacking::kJpeg) {
    auto header = image::read_jpeg_header({frame.data, frame.size});
    if (!header) return make_error("bad_frame", what + ": " + header.error().message);
    if (header->width != static_cast<int>(format.width) ||
        header->height != static_cast<int>(format.height))
      return make_error("bad_frame", what + " is a " + std::to_string(header->width) + "x" +
                                         std::to_string(header->height) + " JPEG in a " +
                                         std::to_string(format.width) + "x" +
                                         std::to_string(format.height) + " stream");
    return {};
  }
  const uint64_t needed = image::frame_bytes(*info, format.width, format.height,
                                             static_cast<uint32_t>(stride_of(*info, format)));
  if (frame.size < needed)
    return make_error("bad_frame",
                      what + " has " + std::to_string(frame.size) + " bytes; " +
                          fourcc_name(format.fourcc) + " " + std::to_string(format.width) + "x" +
                          std::to_string(format.height) + " needs " + std::to_string(needed));
  return {};
}

namespace {

// Whether the format delivers the sensor's own samples (mono or mosaic DN, as convert_frame
// unpacks them) rather than an image processor's output (YCbCr, RGB, JPEG).
bool carries_sensor_samples(const PixelFormatInfo& info) {
  switch (info.packing) {
    case SamplePacking::kJpeg:
    case SamplePacking::kYuyv:
    case SamplePacking::kRgb24:
    case SamplePacking::kBgr24:
    case SamplePacking::kNv12:
    case SamplePacking::kYuv420:
      return false;
    default:
      return true;
  }
}

}  // namespace

Result<ConvertedFrame> convert_frame(const device::Frame& frame, const device::StreamFormat& format,
                                     int sensor_bit_depth, int black_level_dn,
                                     bool isp_subtracts_black) {
  if (Status s = check_frame(frame, format); !s) return s.error();
  const PixelFormatInfo info = *image::pixel_format_info(format.fourcc);
  ConvertedFrame out;  // 8 bits, black 0, unless a branch says otherwise
  switch (info.packing) {
    case SamplePacking::kJpeg:
      out.layout = FrameLayout::kRgb;
      out.jpeg.assign(frame.data, frame.data + frame.size);
      break;
    case SamplePacking::kYuyv: {
      // Luma is stored as delivered (nothing rescaled); its range goes in the sidecar. A
      // YUV format is limited range (black 16, white 235) unless the driver says full.
      out = luma_of_yuyv(frame, format, info);
      const int black8 =
          isp_subtracts_black ? 0 : black_level_in(8, sensor_bit_depth, black_level_dn);
      if (format.quantization == device::YcbcrQuantization::kFull) {
        out.black_level_dn = black8;
      } else {
        out.black_level_dn = 16 + static_cast<int>(std::lround(black8 * 219.0 / 255.0));
        out.white_level_dn = 235;
      }
      break;
    }
    case SamplePacking::kRgb24:
    case SamplePacking::kBgr24:
    case SamplePacking::kNv12:
    case SamplePacking::kYuv420:
      out = rgb_of(frame, format, info);  // an ISP's output: black already subtracted
      break;
    default:
      out = unpack_raw(frame, format, info, sensor_bit_depth, black_level_dn);
      break;
  }
  // A webcam's YUYV declares sRGB or BT.709: its DN are not light until decoded. A camera
  // that declares no colour space leaves the curve unknown, but a raw format's samples are
  // the sensor's DN, linear whatever it declares; a processed format's stay unknown.
  out.transfer = format.transfer == TransferFunction::kUnknown && carries_sensor_samples(info)
                     ? TransferFunction::kLinear
                     : format.transfer;
  out.linear = info.linear && out.transfer == TransferFunction::kLinear;
  out.pixel_format = stored_format_name(info, out.bit_depth);
  out.delivered_format = fourcc_name(format.fourcc);
  return out;
}

Result<double> frame_mean(const device::Frame& frame, const device::StreamFormat& format) {
  if (Status s = check_frame(frame, format); !s) return s.error();
  const PixelFormatInfo info = *image::pixel_format_info(format.fourcc);
  const int rows = static_cast<int>(format.height), cols = static_cast<int>(format.width);
  auto* data = const_cast<uint8_t*>(frame.data);  // read only: cv::Mat has no const view
  const size_t stride = stride_of(info, format);
  // Y16 is little-endian; so is every host camlab builds for (x86-64, arm64).
  static_assert(std::endian::native == std::endian::little,
                "frame_mean reads 16 bits in host order");
  switch (info.packing) {
    case SamplePacking::k8:
      return cv::mean(cv::Mat(rows, cols, CV_8UC1, data, stride))[0];
    case SamplePacking::kYuyv:
      return cv::mean(cv::Mat(rows, cols, CV_8UC2, data, stride))[0];
    case SamplePacking::k16High:
    case SamplePacking::k16Low:
      return cv::mean(cv::Mat(rows, cols, CV_16UC1, data, stride))[0];
    case SamplePacking::kJpeg:
      return image::jpeg_mean_fast({frame.data, frame.size});
    default: {  // packed and colour formats: convert, then average every sample
      auto converted = convert_frame(frame, format, 0, 0);
      if (!converted) return converted.error();
      const cv::Scalar mean = cv::mean(converted->image);
      double sum = 0;
      for (int c = 0; c < converted->image.channels(); ++c) sum += mean[c];
      return sum / converted->image.channels();
    }
  }
}

}  // namespace camlab::capture
