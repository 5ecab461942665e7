// What the live view shows (service/live/display_frame.h), on frames whose every sample is
// known: the DN-to-screen mapping at the black level, the white level and in between; the
// scale; the clipping overlay exactly where samples clip; focus peaking on a sharp step and
// none on the same step blurred (an analytic erf edge, not the renderer's); a mosaic shown
// in its colour.
#include "service/live/display_frame.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "image/jpeg_codec.h"

namespace camlab::service {
namespace {

capture::ConvertedFrame mono10(const cv::Mat& dn) {
  capture::ConvertedFrame frame;
  frame.image = dn;
  frame.layout = image::FrameLayout::kMono;
  frame.bit_depth = 10;
  frame.black_level_dn = 32;
  frame.white_level_dn = 1023;
  return frame;
}

// A vertical edge between `low` and `high` DN at x = cols / 2, blurred by a Gaussian of
// `sigma_px` (0: a step), sampled at pixel centres: the erf profile in closed form.
cv::Mat edge(int cols, int rows, double low, double high, double sigma_px) {
  cv::Mat image(rows, cols, CV_16UC1);
  const double x0 = cols / 2.0;
  for (int x = 0; x < cols; ++x) {
    const double t = x + 0.5 - x0;
    const double f =
        sigma_px > 0 ? 0.5 * (1 + std::erf(t / (sigma_px * std::sqrt(2.0)))) : (t > 0 ? 1.0 : 0.0);
    const auto dn = static_cast<uint16_t>(std::lround(low + (high - low) * f));
    for (int y = 0; y < rows; ++y) image.at<uint16_t>(y, x) = dn;
  }
  return image;
}

int count_colour(const cv::Mat& bgr, cv::Vec3b colour) {
  int n = 0;
  for (int y = 0; y < bgr.rows; ++y)
    for (int x = 0; x < bgr.cols; ++x) n += bgr.at<cv::Vec3b>(y, x) == colour;
  return n;
}

TEST(DisplayFrame, DnMapFromBlackToWhiteWithTheDisplayPower) {
  cv::Mat dn(2, 3, CV_16UC1);
  // Below black, black, the middle of the span, white, above white (clipped by the format),
  // a quarter.
  const uint16_t values[] = {10, 32, 32 + (1023 - 32) / 2, 1023, 1023, 32 + (1023 - 32) / 4};
  for (int i = 0; i < 6; ++i) dn.at<uint16_t>(i / 3, i % 3) = values[i];
  auto shown = display_image(mono10(dn), {});
  ASSERT_TRUE(shown.ok()) << shown.error().message;
  ASSERT_EQ(shown->type(), CV_8UC1);
  auto expected = [](double v) {
    return static_cast<int>(std::lround(255 * std::pow(std::clamp(v, 0.0, 1.0), 1 / 2.2)));
  };
  EXPECT_EQ(shown->at<uint8_t>(0, 0), 0);
  EXPECT_EQ(shown->at<uint8_t>(0, 1), 0);
  EXPECT_EQ(shown->at<uint8_t>(0, 2), expected(495.0 / 991.0));
  EXPECT_EQ(shown->at<uint8_t>(1, 0), 255);
  EXPECT_EQ(shown->at<uint8_t>(1, 2), expected(247.0 / 991.0));

  // Frames that are not linear (stored JPEG) are shown as they are.
  capture::ConvertedFrame gamma;
  gamma.image = cv::Mat(1, 3, CV_8UC1);
  gamma.image.at<uint8_t>(0, 0) = 0;
  gamma.image.at<uint8_t>(0, 1) = 100;
  gamma.image.at<uint8_t>(0, 2) = 255;
  gamma.linear = false;
  auto plain = display_image(gamma, {});
  ASSERT_TRUE(plain.ok());
  EXPECT_EQ(plain->at<uint8_t>(0, 1), 100);
}

TEST(DisplayFrame, ScaledDownToTheWidthAskedNeverUp) {
  DisplayOptions options;
  options.max_width_px = 320;
  auto half = display_image(mono10(cv::Mat(400, 640, CV_16UC1, cv::Scalar(500))), options);
  ASSERT_TRUE(half.ok());
  EXPECT_EQ(half->cols, 320);
  EXPECT_EQ(half->rows, 200);
  options.max_width_px = 1000;
  auto same = display_image(mono10(cv::Mat(48, 64, CV_16UC1, cv::Scalar(500))), options);
  ASSERT_TRUE(same.ok());
  EXPECT_EQ(same->cols, 64);
}

TEST(DisplayFrame, ClippingIsMarkedExactlyWhereSamplesClip) {
  cv::Mat dn(120, 160, CV_16UC1, cv::Scalar(500));
  dn(cv::Rect(20, 30, 40, 20)).setTo(1023);  // at the white level
  dn(cv::Rect(100, 60, 30, 30)).setTo(20);   // below the black level
  DisplayOptions options;
  options.clipping = true;
  auto shown = display_image(mono10(dn), options);
  ASSERT_TRUE(shown.ok());
  ASSERT_EQ(shown->type(), CV_8UC3);
  EXPECT_EQ(count_colour(*shown, {0, 0, 255}), 40 * 20);
  EXPECT_EQ(count_colour(*shown, {255, 64, 0}), 30 * 30);
  EXPECT_EQ(shown->at<cv::Vec3b>(40, 30), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(shown->at<cv::Vec3b>(75, 115), cv::Vec3b(255, 64, 0));

  // Scaled down 4x: one clipped sample marks the display pixel it falls in, and only it.
  cv::Mat one(120, 160, CV_16UC1, cv::Scalar(500));
  one.at<uint16_t>(61, 81) = 1023;
  options.max_width_px = 40;
  auto small = display_image(mono10(one), options);
  ASSERT_TRUE(small.ok());
  EXPECT_EQ(count_colour(*small, {0, 0, 255}), 1);
  EXPECT_EQ(small->at<cv::Vec3b>(15, 20), cv::Vec3b(0, 0, 255));
}

TEST(DisplayFrame, FocusPeakingMarksASharpEdgeAndNotTheSameEdgeBlurred) {
  DisplayOptions options;
  options.focus_peaking = true;
  // Contrast 0.2 -> 0.8 of the span: about 110 display levels after the display power.
  const double low = 32 + 0.2 * 991, high = 32 + 0.8 * 991;
  auto sharp = display_image(mono10(edge(200, 50, low, high, 0)), options);
  ASSERT_TRUE(sharp.ok());
  const int marked_sharp = count_colour(*sharp, {0, 255, 0});
  EXPECT_GE(marked_sharp, 2 * 50);  // both columns beside the step, every row
  // Nothing far from the edge.
  for (int y = 0; y < 50; ++y)
    for (int x : {10, 50, 150, 190}) EXPECT_NE(sharp->at<cv::Vec3b>(y, x), cv::Vec3b(0, 255, 0));
  auto blurred = display_image(mono10(edge(200, 50, low, high, 4.0)), options);
  ASSERT_TRUE(blurred.ok());
  EXPECT_EQ(count_colour(*blurred, {0, 255, 0}), 0);
  // A lower threshold finds the blurred edge too: the level is what decides.
  options.peaking_threshold = 30;
  auto sensitive = display_image(mono10(edge(200, 50, low, high, 4.0)), options);
  ASSERT_TRUE(sensitive.ok());
  EXPECT_GT(count_colour(*sensitive, {0, 255, 0}), 0);
}

TEST(DisplayFrame, AMosaicIsShownInItsColour) {
  // RGGB with red light: R sites bright, the others dark.
  cv::Mat mosaic(64, 64, CV_16UC1);
  for (int y = 0; y < 64; ++y)
    for (int x = 0; x < 64; ++x) mosaic.at<uint16_t>(y, x) = (y % 2 == 0 && x % 2 == 0) ? 900 : 60;
  capture::ConvertedFrame frame = mono10(mosaic);
  frame.layout = image::FrameLayout::kMosaic;
  frame.cfa_pattern = "RGGB";
  auto shown = display_image(frame, {});
  ASSERT_TRUE(shown.ok()) << shown.error().message;
  ASSERT_EQ(shown->type(), CV_8UC3);
  const cv::Vec3b centre = shown->at<cv::Vec3b>(32, 32);
  EXPECT_GT(centre[2], 200);  // R
  EXPECT_LT(centre[1], 100);  // G
  EXPECT_LT(centre[0], 100);  // B
}

TEST(DisplayFrame, TheJpegDecodesToTheImageShown) {
  auto jpeg = display_jpeg(mono10(edge(160, 120, 100, 900, 1.0)), {});
  ASSERT_TRUE(jpeg.ok());
  auto decoded = image::decode_jpeg(*jpeg);
  ASSERT_TRUE(decoded.ok());
  EXPECT_EQ(decoded->cols, 160);
  EXPECT_EQ(decoded->rows, 120);
}

TEST(DisplayFrame, AnEmptyOrUnreadableFrameIsAnError) {
  EXPECT_EQ(display_image(capture::ConvertedFrame{}, {}).error().code, ErrorCode::kBadFrame);
  capture::ConvertedFrame floats = mono10(cv::Mat(4, 4, CV_32FC1));
  EXPECT_EQ(display_image(floats, {}).error().code, ErrorCode::kBadFrame);
  capture::ConvertedFrame broken;
  broken.jpeg = {0xff, 0xd8, 0x00, 0x01};
  broken.linear = false;
  EXPECT_EQ(display_image(broken, {}).error().code, ErrorCode::kBadImage);
}

}  // namespace
}  // namespace camlab::service
