// Driver buffers to raw-DN images: every format, strides, and short buffers.
#include "capture/frame_convert.h"
#include "frame_over.h"

#include <gtest/gtest.h>

#include <vector>

namespace camlab::capture {
namespace {

TEST(FrameConvert, Y16OfA12BitSensorBecomesRightAlignedDn) {
  device::StreamFormat format{"Y16 ", 3, 2, 8, 16, {}};  // 2 bytes of row padding
  std::vector<uint8_t> bytes(16, 0xee);
  const uint16_t dn[6] = {0, 64, 4095, 1000, 2048, 7};
  for (int i = 0; i < 6; ++i) {
    const uint16_t v = static_cast<uint16_t>(dn[i] << 4);  // MSB-aligned, little-endian
    const size_t at = static_cast<size_t>((i / 3) * 8 + (i % 3) * 2);
    bytes[at] = v & 0xff;
    bytes[at + 1] = v >> 8;
  }
  auto out = convert_frame(frame_over(bytes), format, 12, 64);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->image.type(), CV_16UC1);
  EXPECT_EQ(out->bit_depth, 12);
  EXPECT_EQ(out->black_level_dn, 64);
  EXPECT_EQ(out->pixel_format, "Y12");
  for (int i = 0; i < 6; ++i) EXPECT_EQ(out->image.at<uint16_t>(i / 3, i % 3), dn[i]) << i;
  // Unknown depth: the 16-bit values as they came.
  auto raw = convert_frame(frame_over(bytes), format, 0, 0);
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->bit_depth, 16);
  EXPECT_EQ(raw->image.at<uint16_t>(0, 2), 4095 << 4);
}

TEST(FrameConvert, GreyAndYuyvGiveEightBitImagesWithScaledBlack) {
  std::vector<uint8_t> grey = {1, 2, 3, 9, 4, 5, 6, 9};  // 3x2 with one byte of padding
  auto g = convert_frame(frame_over(grey), {"GREY", 3, 2, 4, 8, {}}, 12, 64);
  ASSERT_TRUE(g.ok()) << g.error().message;
  EXPECT_EQ(g->image.type(), CV_8UC1);
  EXPECT_EQ(g->image.at<uint8_t>(1, 2), 6);
  EXPECT_EQ(g->black_level_dn, 4) << "64 DN of 12 bits is 4 in the top 8";
  EXPECT_NE(g->image.data, grey.data()) << "the image owns its pixels";

  std::vector<uint8_t> yuyv = {10, 128, 20, 128, 30, 128, 40, 128};  // 2x2
  auto y = convert_frame(frame_over(yuyv), {"YUYV", 2, 2, 4, 8, {}}, 0, 0);
  ASSERT_TRUE(y.ok());
  EXPECT_EQ(y->image.at<uint8_t>(1, 1), 40);
  EXPECT_EQ(y->pixel_format, "GREY");
  auto mean = frame_mean(frame_over(yuyv), {"YUYV", 2, 2, 4, 8, {}});
  ASSERT_TRUE(mean.ok());
  EXPECT_DOUBLE_EQ(*mean, 25.0);
}

TEST(FrameConvert, YuyvLumaKeepsItsCodesAndStatesTheRangeItWasSentIn) {
  std::vector<uint8_t> yuyv = {16, 128, 235, 128, 126, 128, 200, 128};  // 2x2
  device::StreamFormat limited{"YUYV", 2, 2, 4, 8, {}};
  limited.quantization = device::YcbcrQuantization::kLimited;
  // A 12-bit sensor with black at 256 DN: 16 DN in the top 8 bits, 16 + 16 x 219/255 in
  // limited-range luma.
  auto y = convert_frame(frame_over(yuyv), limited, 12, 256);
  ASSERT_TRUE(y.ok()) << y.error().message;
  EXPECT_EQ(y->image.at<uint8_t>(0, 1), 235) << "codes are stored as delivered";
  EXPECT_EQ(y->black_level_dn, 16 + 14);
  EXPECT_EQ(y->white_level_dn, 235);

  device::StreamFormat unspecified{"YUYV", 2, 2, 4, 8, {}};  // V4L2's default: limited
  auto d = convert_frame(frame_over(yuyv), unspecified, 12, 256);
  ASSERT_TRUE(d.ok());
  EXPECT_EQ(d->white_level_dn, 235);

  device::StreamFormat full = limited;
  full.quantization = device::YcbcrQuantization::kFull;
  auto f = convert_frame(frame_over(yuyv), full, 12, 256);
  ASSERT_TRUE(f.ok());
  EXPECT_EQ(f->black_level_dn, 16);
  EXPECT_EQ(f->white_level_dn, 255);
}

TEST(FrameConvert, ShortBuffersAndUnknownFormatsAreRefused) {
  std::vector<uint8_t> bytes(5);
  EXPECT_EQ(convert_frame(frame_over(bytes), {"GREY", 3, 2, 3, 6, {}}, 8, 0).error().code,
            "bad_frame");
  EXPECT_EQ(convert_frame(frame_over(bytes), {"H264", 1, 1, 1, 1, {}}, 8, 0).error().code,
            "unsupported");
}

}  // namespace
}  // namespace camlab::capture
