// Raw and colour formats through convert_frame, against buffers packed here straight from
// the layouts V4L2 documents (MIPI RAW10/RAW12, 16-bit little-endian, NV12/YU12 from
// R, G, B by the BT.601/709 equations), not by the code under test.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "capture/frame_convert.h"
#include "frame_over.h"

namespace camlab::capture {
namespace {

std::vector<uint16_t> random_dn(size_t count, int bits, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> dn(0, (1 << bits) - 1);
  std::vector<uint16_t> out(count);
  for (auto& v : out) v = static_cast<uint16_t>(dn(rng));
  out[0] = static_cast<uint16_t>((1 << bits) - 1);  // the extremes, always
  out[1] = 0;
  return out;
}

// MIPI CSI-2 RAW10: per 4 samples, their bits 9..2 in 4 bytes, then one byte holding bits
// 1..0 of sample 0 in bits 1..0, of sample 1 in bits 3..2, and so on.
std::vector<uint8_t> pack_raw10(const std::vector<uint16_t>& dn, int width, int height,
                                int stride) {
  std::vector<uint8_t> out(static_cast<size_t>(stride * height), 0xaa);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const uint16_t v = dn[static_cast<size_t>(y * width + x)];
      uint8_t* group = &out[static_cast<size_t>(y * stride + (x / 4) * 5)];
      group[x % 4] = static_cast<uint8_t>(v >> 2);
      group[4] =
          static_cast<uint8_t>((group[4] & ~(3 << (2 * (x % 4)))) | ((v & 3) << (2 * (x % 4))));
    }
  return out;
}

// RAW12: per 2 samples, their bits 11..4, then bits 3..0 of sample 0 low, of sample 1 high.
std::vector<uint8_t> pack_raw12(const std::vector<uint16_t>& dn, int width, int height,
                                int stride) {
  std::vector<uint8_t> out(static_cast<size_t>(stride * height), 0x55);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const uint16_t v = dn[static_cast<size_t>(y * width + x)];
      uint8_t* group = &out[static_cast<size_t>(y * stride + (x / 2) * 3)];
      group[x % 2] = static_cast<uint8_t>(v >> 4);
      const int shift = 4 * (x % 2);
      group[2] = static_cast<uint8_t>((group[2] & ~(0xf << shift)) | ((v & 0xf) << shift));
    }
  return out;
}

void expect_dn(const cv::Mat& image, const std::vector<uint16_t>& dn, int width, int height) {
  ASSERT_EQ(image.type(), CV_16UC1);
  ASSERT_EQ(image.cols, width);
  ASSERT_EQ(image.rows, height);
  int wrong = 0;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x)
      wrong += image.at<uint16_t>(y, x) != dn[static_cast<size_t>(y * width + x)];
  EXPECT_EQ(wrong, 0);
}

TEST(RawFormats, Raw10PackedBayerBecomesItsMosaicOfDn) {
  const int width = 8, height = 4, stride = 12;  // 10 bytes of data, 2 of padding
  const auto dn = random_dn(width * height, 10, 1);
  auto bytes = pack_raw10(dn, width, height, stride);
  auto out = convert_frame(frame_over(bytes), {"pRAA", 8, 4, 12, 48, {}}, 10, 64);
  ASSERT_TRUE(out.ok()) << out.error().message;
  expect_dn(out->image, dn, width, height);
  EXPECT_EQ(out->layout, image::FrameLayout::kMosaic);
  EXPECT_EQ(out->cfa_pattern, "RGGB");
  EXPECT_EQ(out->bit_depth, 10);
  EXPECT_EQ(out->white_level_dn, 1023);
  EXPECT_EQ(out->black_level_dn, 64);
  EXPECT_EQ(out->pixel_format, "SRGGB10");
  EXPECT_EQ(out->delivered_format, "pRAA");
  EXPECT_TRUE(out->linear);
}

TEST(RawFormats, Raw12PackedMonoAndEveryCfaOrder) {
  const int width = 6, height = 3, stride = 9;
  const auto dn = random_dn(width * height, 12, 2);
  auto bytes = pack_raw12(dn, width, height, stride);
  auto mono = convert_frame(frame_over(bytes), {"Y12P", 6, 3, 9, 27, {}}, 12, 256);
  ASSERT_TRUE(mono.ok()) << mono.error().message;
  expect_dn(mono->image, dn, width, height);
  EXPECT_EQ(mono->layout, image::FrameLayout::kMono);
  EXPECT_EQ(mono->pixel_format, "Y12");
  const std::pair<const char*, const char*> orders[] = {
      {"pBCC", "BGGR"}, {"pGCC", "GBRG"}, {"pgCC", "GRBG"}, {"pRCC", "RGGB"}};
  for (auto [fourcc, cfa] : orders) {
    auto out = convert_frame(frame_over(bytes), {fourcc, 6, 3, 9, 27, {}}, 12, 256);
    ASSERT_TRUE(out.ok()) << fourcc;
    EXPECT_EQ(out->cfa_pattern, cfa) << fourcc;
    expect_dn(out->image, dn, width, height);
  }
}

TEST(RawFormats, UnpackedBayerKeepsLowAlignedDnAndBayer16ShiftsAKnownDepth) {
  const int width = 4, height = 2;
  const auto dn = random_dn(width * height, 12, 3);
  std::vector<uint8_t> low(width * height * 2), high(width * height * 2);
  for (size_t i = 0; i < dn.size(); ++i) {
    low[2 * i] = dn[i] & 0xff;
    low[2 * i + 1] = static_cast<uint8_t>(dn[i] >> 8);
    const uint16_t msb = static_cast<uint16_t>(dn[i] << 4);
    high[2 * i] = msb & 0xff;
    high[2 * i + 1] = static_cast<uint8_t>(msb >> 8);
  }
  auto b12 = convert_frame(frame_over(low), {"BA12", 4, 2, 8, 16, {}}, 0, 0);
  ASSERT_TRUE(b12.ok());
  expect_dn(b12->image, dn, width, height);
  EXPECT_EQ(b12->cfa_pattern, "GRBG");
  EXPECT_EQ(b12->bit_depth, 12);
  auto b16 = convert_frame(frame_over(high), {"RG16", 4, 2, 8, 16, {}}, 12, 0);
  ASSERT_TRUE(b16.ok());
  expect_dn(b16->image, dn, width, height);
  EXPECT_EQ(b16->pixel_format, "SRGGB12");
}

TEST(RawFormats, EightBitBayerStaysEightBitWithScaledBlack) {
  std::vector<uint8_t> bytes = {10, 20, 30, 40, 50, 60, 70, 80};
  auto out = convert_frame(frame_over(bytes), {"BA81", 4, 2, 4, 8, {}}, 12, 256);
  ASSERT_TRUE(out.ok());
  EXPECT_EQ(out->image.type(), CV_8UC1);
  EXPECT_EQ(out->image.at<uint8_t>(1, 3), 80);
  EXPECT_EQ(out->cfa_pattern, "BGGR");
  EXPECT_EQ(out->black_level_dn, 16) << "256 DN of 12 bits is 16 in the top 8";
  EXPECT_EQ(out->white_level_dn, 255);
}

TEST(RawFormats, RgbAndBgrBecomeTheSameImage) {
  std::vector<uint8_t> rgb = {255, 0, 0, 0, 255, 0, 0, 0, 255, 10, 20, 30};  // 2x2
  std::vector<uint8_t> bgr = {0, 0, 255, 0, 255, 0, 255, 0, 0, 30, 20, 10};
  auto a = convert_frame(frame_over(rgb), {"RGB3", 2, 2, 6, 12, {}}, 0, 0);
  auto b = convert_frame(frame_over(bgr), {"BGR3", 2, 2, 6, 12, {}}, 0, 0);
  ASSERT_TRUE(a.ok() && b.ok());
  EXPECT_EQ(a->layout, image::FrameLayout::kRgb);
  EXPECT_EQ(cv::norm(a->image, b->image, cv::NORM_INF), 0);
  EXPECT_EQ(a->image.at<cv::Vec3b>(0, 0), cv::Vec3b(0, 0, 255)) << "OpenCV keeps B, G, R";
  EXPECT_EQ(a->image.at<cv::Vec3b>(1, 1), cv::Vec3b(30, 20, 10));
}

struct Ycbcr {
  uint8_t y, cb, cr;
};

// R, G, B (0..255) to Y'CbCr codes by the textbook equations.
Ycbcr encode_ycbcr(double r, double g, double b, bool full, bool bt709) {
  const double kr = bt709 ? 0.2126 : 0.299, kb = bt709 ? 0.0722 : 0.114;
  const double yn = (kr * r + (1 - kr - kb) * g + kb * b) / 255;
  const double pb = (b / 255 - yn) / (2 * (1 - kb)), pr = (r / 255 - yn) / (2 * (1 - kr));
  auto code = [](double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); };
  if (full) return {code(255 * yn), code(128 + 255 * pb), code(128 + 255 * pr)};
  return {code(16 + 219 * yn), code(128 + 224 * pb), code(128 + 224 * pr)};
}

// A 4x4 frame of four flat 2x2 colour blocks, as NV12 or YU12.
std::vector<uint8_t> yuv420_blocks(const std::vector<cv::Vec3b>& rgb_blocks, bool nv12, bool full,
                                   bool bt709) {
  const int w = 4, h = 4;
  std::vector<uint8_t> out(w * h + w * h / 2);
  for (int by = 0; by < 2; ++by)
    for (int bx = 0; bx < 2; ++bx) {
      const cv::Vec3b c = rgb_blocks[static_cast<size_t>(by * 2 + bx)];
      const Ycbcr e = encode_ycbcr(c[0], c[1], c[2], full, bt709);
      for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 2; ++x) out[static_cast<size_t>((2 * by + y) * w + 2 * bx + x)] = e.y;
      if (nv12) {
        out[static_cast<size_t>(w * h + by * w + 2 * bx)] = e.cb;
        out[static_cast<size_t>(w * h + by * w + 2 * bx + 1)] = e.cr;
      } else {
        out[static_cast<size_t>(w * h + by * 2 + bx)] = e.cb;
        out[static_cast<size_t>(w * h + 4 + by * 2 + bx)] = e.cr;
      }
    }
  return out;
}

TEST(RawFormats, Nv12AndYu12GiveBackTheirColoursInEachQuantization) {
  const std::vector<cv::Vec3b> blocks = {
      {200, 40, 30}, {20, 180, 60}, {35, 70, 220}, {128, 128, 128}};
  for (bool nv12 : {true, false})
    for (bool full : {false, true})
      for (bool bt709 : {false, true}) {
        auto bytes = yuv420_blocks(blocks, nv12, full, bt709);
        device::StreamFormat format{nv12 ? "NV12" : "YU12", 4, 4, 4, 24, {}};
        format.quantization =
            full ? device::YcbcrQuantization::kFull : device::YcbcrQuantization::kDefault;
        format.ycbcr_encoding =
            bt709 ? device::YcbcrEncoding::kBt709 : device::YcbcrEncoding::kDefault;
        auto out = convert_frame(frame_over(bytes), format, 0, 0);
        ASSERT_TRUE(out.ok()) << out.error().message;
        for (int b = 0; b < 4; ++b) {
          const cv::Vec3b want = blocks[static_cast<size_t>(b)];
          for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 2; ++x) {
              const cv::Vec3b got = out->image.at<cv::Vec3b>(2 * (b / 2) + y, 2 * (b % 2) + x);
              for (int c = 0; c < 3; ++c)  // got is B, G, R
                EXPECT_NEAR(got[2 - c], want[c], 2)
                    << (nv12 ? "NV12" : "YU12") << (full ? " full" : " limited")
                    << (bt709 ? " 709" : " 601") << " block " << b << " channel " << c;
            }
        }
      }
}

TEST(RawFormats, ShortPackedBuffersAreRefusedWithTheSizeNeeded) {
  std::vector<uint8_t> bytes(45);
  auto out = convert_frame(frame_over(bytes), {"pRAA", 8, 4, 12, 48, {}}, 10, 0);
  ASSERT_FALSE(out.ok());
  EXPECT_EQ(out.error().code, ErrorCode::kBadFrame);
  EXPECT_NE(out.error().message.find("needs 46"), std::string::npos) << out.error().message;
  std::vector<uint8_t> nv12(4 * 4 + 7);
  EXPECT_EQ(convert_frame(frame_over(nv12), {"NV12", 4, 4, 4, 24, {}}, 0, 0).error().code,
            ErrorCode::kBadFrame);
}

}  // namespace
}  // namespace camlab::capture
