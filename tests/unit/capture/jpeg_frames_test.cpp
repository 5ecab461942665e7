// MJPEG frames: kept byte for byte, checked before they are kept, and averaged for the
// settle rule. The JPEGs are made by OpenCV's encoder, not camlab's.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "capture/frame_convert.h"
#include "frame_over.h"
#include "image/jpeg_codec.h"

namespace camlab::capture {
namespace {

std::vector<uint8_t> opencv_jpeg(int width, int height, int quality) {
  cv::Mat bgr(height, width, CV_8UC3);
  cv::randu(bgr, cv::Scalar(30, 60, 90), cv::Scalar(120, 160, 220));
  cv::GaussianBlur(bgr, bgr, {7, 7}, 2);
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", bgr, jpeg, {cv::IMWRITE_JPEG_QUALITY, quality});
  return jpeg;
}

TEST(JpegFrames, AreKeptAsDeliveredAndFlaggedNotLinear) {
  auto jpeg = opencv_jpeg(64, 48, 90);
  const device::StreamFormat format{"MJPG", 64, 48, 0, 64 * 48 * 2, {}};
  auto out = convert_frame(frame_over(jpeg), format, 0, 0);
  ASSERT_TRUE(out.ok()) << out.error().message;
  EXPECT_EQ(out->jpeg, jpeg);
  EXPECT_TRUE(out->image.empty());
  EXPECT_FALSE(out->linear);
  EXPECT_EQ(out->layout, image::FrameLayout::kRgb);
  EXPECT_EQ(out->pixel_format, "MJPG");
}

TEST(JpegFrames, TruncatedWrongSizedAndNonJpegBuffersAreBadFrames) {
  auto jpeg = opencv_jpeg(64, 48, 90);
  const device::StreamFormat format{"MJPG", 64, 48, 0, 64 * 48 * 2, {}};
  std::vector<uint8_t> cut(jpeg.begin(), jpeg.begin() + static_cast<long>(jpeg.size() / 2));
  // A cut stream still has a header; decoding it is what fails.
  auto decoded = image::decode_jpeg(cut);
  ASSERT_FALSE(decoded.ok()) << "half a JPEG must not decode to a half-grey picture";
  EXPECT_EQ(decoded.error().code, ErrorCode::kBadImage);
  const device::StreamFormat wrong_size{"MJPG", 640, 480, 0, 640 * 480 * 2, {}};
  EXPECT_EQ(check_frame(frame_over(jpeg), wrong_size).error().code, ErrorCode::kBadFrame);
  std::vector<uint8_t> zeros(400, 0);
  EXPECT_EQ(check_frame(frame_over(zeros), format).error().code, ErrorCode::kBadFrame);
}

// UVC cameras send MJPEG without Huffman tables (DHT): the decoder must use JPEG's
// standard tables (Annex K), as libjpeg-turbo does.
TEST(JpegFrames, UvcStyleFramesWithoutHuffmanTablesAreAcceptedAndDecode) {
  auto jpeg = opencv_jpeg(64, 48, 90);
  std::vector<uint8_t> stripped(jpeg.begin(), jpeg.begin() + 2);
  for (size_t i = 2; i + 4 <= jpeg.size() && jpeg[i] == 0xFF;) {
    const int marker = jpeg[i + 1], length = (jpeg[i + 2] << 8) | jpeg[i + 3];
    if (marker == 0xDA) {  // start of scan: the rest is entropy-coded data
      stripped.insert(stripped.end(), jpeg.begin() + static_cast<long>(i), jpeg.end());
      break;
    }
    if (marker != 0xC4)  // DHT
      stripped.insert(stripped.end(), jpeg.begin() + static_cast<long>(i),
                      jpeg.begin() + static_cast<long>(i + 2 + length));
    i += 2 + static_cast<size_t>(length);
  }
  ASSERT_LT(stripped.size(), jpeg.size()) << "the tables were removed";
  const device::StreamFormat format{"MJPG", 64, 48, 0, 64 * 48 * 2, {}};
  EXPECT_TRUE(check_frame(frame_over(stripped), format).ok());
  auto with = image::decode_jpeg(jpeg), without = image::decode_jpeg(stripped);
  ASSERT_TRUE(with.ok() && without.ok());
  EXPECT_EQ(cv::norm(*with, *without, cv::NORM_INF), 0) << "OpenCV writes the standard tables";
}

TEST(JpegFrames, FastMeanIsTheFullDecodesMeanWithinAQuarterDn) {
  for (auto [w, h] : {std::pair{64, 48}, std::pair{320, 240}, std::pair{100, 75}}) {
    auto jpeg = opencv_jpeg(w, h, 85);
    cv::Mat full = cv::imdecode(jpeg, cv::IMREAD_UNCHANGED);
    const cv::Scalar m = cv::mean(full);
    const double full_mean = (m[0] + m[1] + m[2]) / 3;
    auto frame = frame_over(jpeg);
    auto fast =
        frame_mean(frame, {"MJPG", static_cast<uint32_t>(w), static_cast<uint32_t>(h), 0, 0, {}});
    ASSERT_TRUE(fast.ok()) << fast.error().message;
    EXPECT_NEAR(*fast, full_mean, 0.25) << w << "x" << h;
  }
}

TEST(JpegFrames, TurboDecodeMatchesOpenCvsAndTheEncoderHonoursQuality) {
  auto jpeg = opencv_jpeg(96, 64, 95);
  auto ours = image::decode_jpeg(jpeg);
  ASSERT_TRUE(ours.ok());
  cv::Mat theirs = cv::imdecode(jpeg, cv::IMREAD_UNCHANGED);
  EXPECT_LE(cv::norm(*ours, theirs, cv::NORM_INF), 1.0);
  auto high = image::encode_jpeg(theirs, 95), low = image::encode_jpeg(theirs, 30);
  ASSERT_TRUE(high.ok() && low.ok());
  EXPECT_LT(low->size(), high->size());
  cv::Mat back = cv::imdecode(*high, cv::IMREAD_UNCHANGED);
  EXPECT_LT(cv::norm(back, theirs, cv::NORM_L1) / theirs.total() / 3, 2.0) << "mean abs error";
  EXPECT_EQ(image::encode_jpeg(theirs, 0).error().code, ErrorCode::kOutOfRange);
}

}  // namespace
}  // namespace camlab::capture
