#include "mock_device/v4l2/virtual_v4l2_frame_encoder.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>

#include <opencv2/imgproc.hpp>

#include "image/jpeg_codec.h"
#include "mock_device/v4l2/virtual_isp.h"

namespace camlab::mock {

namespace {

// A DN of `from_bits` as a sample of `to_bits`, rounded and clipped.
inline uint16_t rescaled(float dn, int from_bits, int to_bits) {
  const long max = (1L << to_bits) - 1;
  return static_cast<uint16_t>(
      std::clamp(std::lround(std::ldexp(dn, to_bits - from_bits)), 0L, max));
}

void put16(uint8_t* p, uint16_t v) {
  p[0] = static_cast<uint8_t>(v & 0xff);
  p[1] = static_cast<uint8_t>(v >> 8);
}

// A monochrome sensor's frame: GREY, Y16 (raw), YUYV (grey, the ISP's curve).
void write_mono(const cv::Mat& dn, const SensorSpec& sensor, FormatKind kind,
                TransferFunction transfer, const v4l2_pix_format& pix, uint8_t* out) {
  const int bit_depth = sensor.bit_depth;
  // YUYV keeps the sensor's black pedestal (camlab's capture states it as the black
  // level); a curve applies to the light above it.
  const double black8 = std::ldexp(static_cast<double>(sensor.black_level_dn), 8 - bit_depth);
  for (uint32_t y = 0; y < pix.height; ++y) {
    const float* row = dn.ptr<float>(static_cast<int>(y));
    uint8_t* line = out + static_cast<size_t>(y) * pix.bytesperline;
    for (uint32_t x = 0; x < pix.width; ++x) {
      const float v = row[x];
      if (kind == FormatKind::kY16) {
        // Y16 carries the DN scaled to the full 16 bits (MSB-aligned), little endian.
        const auto value = static_cast<uint16_t>(std::lround(std::ldexp(v, 16 - bit_depth)));
        line[2 * x] = static_cast<uint8_t>(value & 0xff);
        line[2 * x + 1] = static_cast<uint8_t>(value >> 8);
      } else if (kind == FormatKind::kGrey) {
        line[x] =
            static_cast<uint8_t>(std::clamp(std::lround(std::ldexp(v, 8 - bit_depth)), 0L, 255L));
      } else {  // YUYV, limited range as declared: grey, so U = V = 128
        const double grey =
            std::clamp(std::ldexp(static_cast<double>(v), 8 - bit_depth), 0.0, 255.0);
        const double encoded =
            transfer == TransferFunction::kLinear
                ? grey  // noise below black kept, as it always was
                : black8 +
                      (255.0 - black8) * encode_light(transfer, (grey - black8) / (255.0 - black8));
        line[2 * x] = to_byte(16 + 219.0 * encoded / 255.0);
        line[2 * x + 1] = 128;
      }
    }
  }
}

// A mosaic of raw DN in one of the Bayer formats.
void write_bayer(const cv::Mat& dn, int bit_depth, const OfferedFormat& format,
                 const v4l2_pix_format& pix, uint8_t* out) {
  std::vector<uint16_t> samples(pix.width + 4, 0);  // one row, padded to a whole MIPI group
  for (uint32_t y = 0; y < pix.height; ++y) {
    const float* row = dn.ptr<float>(static_cast<int>(y));
    uint8_t* line = out + static_cast<size_t>(y) * pix.bytesperline;
    for (uint32_t x = 0; x < pix.width; ++x) samples[x] = rescaled(row[x], bit_depth, format.bits);
    switch (format.kind) {
      case FormatKind::kBayer8:
        for (uint32_t x = 0; x < pix.width; ++x) line[x] = static_cast<uint8_t>(samples[x]);
        break;
      case FormatKind::kBayer16Low:
      case FormatKind::kBayer16High:
        for (uint32_t x = 0; x < pix.width; ++x) put16(line + 2 * x, samples[x]);
        break;
      case FormatKind::kBayerMipi10:
        // 4 samples in 5 bytes: their top 8 bits, then the four 2-bit remainders, the
        // first sample's in the lowest bits.
        for (uint32_t x = 0; x < pix.width; x += 4) {
          uint8_t* group = line + x / 4 * 5;
          uint8_t low = 0;
          for (uint32_t i = 0; i < 4; ++i) {
            const uint16_t s = x + i < pix.width ? samples[x + i] : 0;
            group[i] = static_cast<uint8_t>(s >> 2);
            low |= static_cast<uint8_t>((s & 3u) << (2 * i));
          }
          group[4] = low;
        }
        break;
      case FormatKind::kBayerMipi12:
        // 2 samples in 3 bytes: their top 8 bits, then the two 4-bit remainders.
        for (uint32_t x = 0; x < pix.width; x += 2) {
          uint8_t* group = line + x / 2 * 3;
          const uint16_t s0 = samples[x], s1 = x + 1 < pix.width ? samples[x + 1] : 0;
          group[0] = static_cast<uint8_t>(s0 >> 4);
          group[1] = static_cast<uint8_t>(s1 >> 4);
          group[2] = static_cast<uint8_t>((s0 & 0xfu) | ((s1 & 0xfu) << 4));
        }
        break;
      default:
        break;
    }
  }
}

// The ISP's R, G, B (CV_32FC3, 0..255) in RGB3, BGR3, NV12 or YUYV.
void write_isp(const cv::Mat& rgb, FormatKind kind, const v4l2_pix_format& pix, uint8_t* out) {
  auto at = [&](uint32_t x, uint32_t y) {
    return rgb.at<cv::Vec3f>(static_cast<int>(y), static_cast<int>(x));
  };
  switch (kind) {
    case FormatKind::kRgb24:
    case FormatKind::kBgr24: {
      const bool bgr = kind == FormatKind::kBgr24;
      for (uint32_t y = 0; y < pix.height; ++y) {
        uint8_t* line = out + static_cast<size_t>(y) * pix.bytesperline;
        for (uint32_t x = 0; x < pix.width; ++x) {
          const cv::Vec3f p = at(x, y);
          line[3 * x + 0] = to_byte(p[bgr ? 2 : 0]);
          line[3 * x + 1] = to_byte(p[1]);
          line[3 * x + 2] = to_byte(p[bgr ? 0 : 2]);
        }
      }
      break;
    }
    case FormatKind::kYuyv:
      for (uint32_t y = 0; y < pix.height; ++y) {
        uint8_t* line = out + static_cast<size_t>(y) * pix.bytesperline;
        for (uint32_t x = 0; x + 1 < pix.width; x += 2) {  // an even width
          const cv::Vec3f a = at(x, y), b = at(x + 1, y);
          const Ycbcr c =
              ycbcr_601_limited((a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, (a[2] + b[2]) / 2.0);
          line[2 * x + 0] = to_byte(ycbcr_601_limited(a[0], a[1], a[2]).y);
          line[2 * x + 1] = to_byte(c.cb);
          line[2 * x + 2] = to_byte(ycbcr_601_limited(b[0], b[1], b[2]).y);
          line[2 * x + 3] = to_byte(c.cr);
        }
      }
      break;
    case FormatKind::kNv12: {
      uint8_t* chroma = out + static_cast<size_t>(pix.bytesperline) * pix.height;
      for (uint32_t y = 0; y < pix.height; ++y) {
        uint8_t* line = out + static_cast<size_t>(y) * pix.bytesperline;
        for (uint32_t x = 0; x < pix.width; ++x) {
          const cv::Vec3f p = at(x, y);
          line[x] = to_byte(ycbcr_601_limited(p[0], p[1], p[2]).y);
        }
      }
      for (uint32_t y = 0; y < pix.height; y += 2) {
        uint8_t* line = chroma + static_cast<size_t>(y / 2) * pix.bytesperline;
        for (uint32_t x = 0; x < pix.width; x += 2) {
          const cv::Vec3f s = at(x, y) + at(x + 1, y) + at(x, y + 1) + at(x + 1, y + 1);
          const Ycbcr c = ycbcr_601_limited(s[0] / 4.0, s[1] / 4.0, s[2] / 4.0);
          line[x] = to_byte(c.cb);
          line[x + 1] = to_byte(c.cr);
        }
      }
      break;
    }
    default:
      break;
  }
}

Result<std::vector<uint8_t>> jpeg_of(const cv::Mat& rgb, int quality, uint32_t sizeimage) {
  cv::Mat bgr(rgb.size(), CV_8UC3);
  for (int y = 0; y < rgb.rows; ++y) {
    const auto* in = rgb.ptr<cv::Vec3f>(y);
    auto* row = bgr.ptr<cv::Vec3b>(y);
    for (int x = 0; x < rgb.cols; ++x)
      row[x] = {to_byte(in[x][2]), to_byte(in[x][1]), to_byte(in[x][0])};
  }
  auto jpeg = image::encode_jpeg(bgr, quality);
  if (!jpeg) return jpeg.error();
  if (jpeg->size() > sizeimage)
    return make_error("internal", "a " + std::to_string(jpeg->size()) +
                                      "-byte JPEG exceeds the frame's sizeimage of " +
                                      std::to_string(sizeimage) + " bytes");
  return jpeg;
}

}  // namespace

Result<std::vector<uint8_t>> encode_frame(const cv::Mat& raw_dn, const SensorSpec& sensor,
                                          const IspSpec& isp, const OfferedFormat& format,
                                          const v4l2_pix_format& pix) {
  cv::Mat dn;
  raw_dn.convertTo(dn, CV_32F);
  const bool binned = pix.width <= static_cast<uint32_t>(sensor.width_px) / 2 &&
                      pix.height <= static_cast<uint32_t>(sensor.height_px) / 2;
  if (!sensor.is_colour()) {
    if (dn.cols != static_cast<int>(pix.width) || dn.rows != static_cast<int>(pix.height))
      cv::resize(dn, dn, cv::Size(static_cast<int>(pix.width), static_cast<int>(pix.height)), 0, 0,
                 cv::INTER_AREA);  // 2x2 binning
    std::vector<uint8_t> bytes(pix.sizeimage, 0);
    write_mono(dn, sensor, format.kind, isp.transfer, pix, bytes.data());
    return bytes;
  }
  if (binned) dn = bin_bayer(dn);
  // A format with an even width or height drops the last column or row of an odd one.
  dn = dn(cv::Rect(0, 0, static_cast<int>(pix.width), static_cast<int>(pix.height)));
  if (format.is_bayer()) {
    std::vector<uint8_t> bytes(pix.sizeimage, 0);
    write_bayer(dn, sensor.bit_depth, format, pix, bytes.data());
    return bytes;
  }
  cv::Mat rgb = demosaic_to_rgb(dn, sensor);
  if (isp.transfer != TransferFunction::kLinear)
    rgb.reshape(1).forEach<float>(
        [&](float& v, const int*) { v = 255.0f * encode_light(isp.transfer, v / 255.0f); });
  if (format.kind == FormatKind::kMjpeg) return jpeg_of(rgb, isp.jpeg_quality, pix.sizeimage);
  std::vector<uint8_t> bytes(pix.sizeimage, 0);
  write_isp(rgb, format.kind, pix, bytes.data());
  return bytes;
}

}  // namespace camlab::mock
