// The capture path's per-frame cost for each pixel format, with the error of what it
// keeps: MJPEG decoding (libjpeg-turbo against OpenCV's imdecode, and the 1/8-scale mean
// the settle rule reads), MIPI RAW10/RAW12 unpacking, NV12 to RGB, and plain copies.
//
//   format_bench [--repeats N]
//
// Frames are packed here from a known image (a blurred random texture with a bright
// square), so each conversion's output is compared with what went in. Times are the
// median of N repeats on one core of this machine (docs/BENCHMARKS.md).
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "capture/frame_convert.h"
#include "image/jpeg_codec.h"

namespace {

using namespace camlab;

double median_ms(int repeats, const std::function<void()>& work) {
  std::vector<double> ms;
  for (int i = 0; i < repeats; ++i) {
    const auto start = std::chrono::steady_clock::now();
    work();
    ms.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start)
                     .count());
  }
  std::sort(ms.begin(), ms.end());
  return ms[ms.size() / 2];
}

cv::Mat scene_bgr(int width, int height) {
  cv::Mat bgr(height, width, CV_8UC3);
  cv::RNG rng(1);
  rng.fill(bgr, cv::RNG::UNIFORM, cv::Scalar(20, 40, 60), cv::Scalar(200, 220, 240));
  cv::GaussianBlur(bgr, bgr, {0, 0}, 2.0);
  cv::rectangle(bgr, {width / 4, height / 4}, {width / 2, height / 2}, cv::Scalar(250, 240, 30),
                -1);
  return bgr;
}

device::Frame frame_over(const std::vector<uint8_t>& bytes) {
  device::Frame frame;
  frame.data = bytes.data();
  frame.size = bytes.size();
  return frame;
}

// 12-bit DN, packed as MIPI RAW12 or (top 10 bits) RAW10, as the CSI-2 specification lays
// them out.
std::vector<uint8_t> pack_mipi(const cv::Mat& dn12, int bits) {
  const int width = dn12.cols, height = dn12.rows;
  const int stride = bits == 10 ? width / 4 * 5 : width / 2 * 3;
  std::vector<uint8_t> out(static_cast<size_t>(stride) * height);
  for (int y = 0; y < height; ++y) {
    uint8_t* row = out.data() + static_cast<size_t>(y) * stride;
    const uint16_t* in = dn12.ptr<uint16_t>(y);
    if (bits == 10) {
      for (int x = 0; x < width; x += 4, row += 5) {
        row[4] = 0;
        for (int i = 0; i < 4; ++i) {
          const int v = in[x + i] >> 2;
          row[i] = static_cast<uint8_t>(v >> 2);
          row[4] |= static_cast<uint8_t>((v & 3) << (2 * i));
        }
      }
    } else {
      for (int x = 0; x < width; x += 2, row += 3) {
        row[0] = static_cast<uint8_t>(in[x] >> 4);
        row[1] = static_cast<uint8_t>(in[x + 1] >> 4);
        row[2] = static_cast<uint8_t>((in[x] & 0xf) | ((in[x + 1] & 0xf) << 4));
      }
    }
  }
  return out;
}

// NV12 from B, G, R by BT.601 limited range, one chroma sample per 2x2 block (its mean).
std::vector<uint8_t> pack_nv12(const cv::Mat& bgr) {
  const int w = bgr.cols, h = bgr.rows;
  std::vector<uint8_t> out(static_cast<size_t>(w) * h * 3 / 2);
  auto code = [](double v) { return static_cast<uint8_t>(std::clamp(std::lround(v), 0L, 255L)); };
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const cv::Vec3b p = bgr.at<cv::Vec3b>(y, x);
      out[static_cast<size_t>(y) * w + x] =
          code(16 + 219 * (0.299 * p[2] + 0.587 * p[1] + 0.114 * p[0]) / 255);
    }
  for (int y = 0; y < h; y += 2)
    for (int x = 0; x < w; x += 2) {
      double r = 0, g = 0, b = 0;
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) {
          const cv::Vec3b p = bgr.at<cv::Vec3b>(y + dy, x + dx);
          b += p[0] / 4.0, g += p[1] / 4.0, r += p[2] / 4.0;
        }
      const double yn = (0.299 * r + 0.587 * g + 0.114 * b) / 255;
      uint8_t* uv = out.data() + static_cast<size_t>(w) * h + static_cast<size_t>(y / 2) * w + x;
      uv[0] = code(128 + 224 * (b / 255 - yn) / 1.772);
      uv[1] = code(128 + 224 * (r / 255 - yn) / 1.402);
    }
  return out;
}

void row(const char* what, int width, int height, double ms, const std::string& error) {
  const double mpix = width * height / 1e6;
  std::printf("| %-34s | %4dx%-4d | %8.3f | %8.1f | %s |\n", what, width, height, ms,
              mpix / (ms / 1e3), error.c_str());
}

std::string printf_string(const char* format, double a, double b = 0) {
  char text[160];
  std::snprintf(text, sizeof text, format, a, b);
  return text;
}

}  // namespace

int main(int argc, char** argv) {
  int repeats = 21;
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc)
      repeats = std::max(1, std::atoi(argv[++i]));
  std::printf(
      "| conversion | size | ms/frame | Mpx/s | error against the source "
      "|\n|---|---|---|---|---|\n");
  for (auto [w, h] : {std::pair{1280, 720}, std::pair{1920, 1080}}) {
    const cv::Mat bgr = scene_bgr(w, h);
    const uint32_t uw = static_cast<uint32_t>(w), uh = static_cast<uint32_t>(h);

    // MJPEG at quality 90, 4:2:2 as UVC cameras send it.
    const auto jpeg = *image::encode_jpeg(bgr, 90);
    cv::Mat turbo, opencv;
    const double turbo_ms = median_ms(repeats, [&] { turbo = *image::decode_jpeg(jpeg); });
    const double opencv_ms =
        median_ms(repeats, [&] { opencv = cv::imdecode(jpeg, cv::IMREAD_COLOR); });
    double fast_mean = 0;
    const double mean_ms = median_ms(repeats, [&] { fast_mean = *image::jpeg_mean_fast(jpeg); });
    const device::StreamFormat mjpg{"MJPG", uw, uh, 0, static_cast<uint32_t>(jpeg.size()), {}};
    const double keep_ms =
        median_ms(repeats, [&] { (void)capture::convert_frame(frame_over(jpeg), mjpg, 0, 0); });
    const cv::Scalar full = cv::mean(turbo);
    const double full_mean = (full[0] + full[1] + full[2]) / 3;
    double jpeg_err = cv::norm(turbo, bgr, cv::NORM_L1) / (bgr.total() * 3.0);
    row("MJPEG q90 keep as delivered (copy)", w, h, keep_ms, "bit-exact");
    row("MJPEG decode, libjpeg-turbo", w, h, turbo_ms,
        printf_string("mean abs %.2f DN vs source (JPEG loss); max %.0f DN vs OpenCV", jpeg_err,
                      cv::norm(turbo, opencv, cv::NORM_INF)));
    row("MJPEG decode, OpenCV imdecode", w, h, opencv_ms, "reference decoder");
    row("MJPEG mean, 1/8-scale decode", w, h, mean_ms,
        printf_string("%.3f DN from the full decode's mean", std::fabs(fast_mean - full_mean)));

    // 12-bit DN, MIPI-packed, unpacked to the mosaic.
    cv::Mat dn12;
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    grey.convertTo(dn12, CV_16U, 16.0);
    for (int bits : {10, 12}) {
      const auto packed = pack_mipi(dn12, bits);
      const device::StreamFormat format{
          bits == 10 ? "pRAA" : "pRCC",         uw, uh, static_cast<uint32_t>(packed.size() / h),
          static_cast<uint32_t>(packed.size()), {}};
      capture::ConvertedFrame out;
      const double ms = median_ms(
          repeats, [&] { out = *capture::convert_frame(frame_over(packed), format, bits, 0); });
      cv::Mat want;
      dn12.convertTo(want, CV_16U, bits == 10 ? 0.25 : 1.0);
      if (bits == 10)  // the packer kept the top 10 of 12 bits by shifting: compare the same
        for (int y = 0; y < h; ++y)
          for (int x = 0; x < w; ++x) want.at<uint16_t>(y, x) = dn12.at<uint16_t>(y, x) >> 2;
      row(bits == 10 ? "SRGGB10P unpack" : "SRGGB12P unpack", w, h, ms,
          printf_string("%.0f samples differ", cv::countNonZero(out.image != want)));
    }

    // NV12 to R, G, B.
    const auto nv12 = pack_nv12(bgr);
    const device::StreamFormat nv{"NV12", uw, uh, uw, static_cast<uint32_t>(nv12.size()), {}};
    capture::ConvertedFrame rgb;
    const double nv_ms =
        median_ms(repeats, [&] { rgb = *capture::convert_frame(frame_over(nv12), nv, 0, 0); });
    const cv::Scalar src = cv::mean(bgr), got = cv::mean(rgb.image);
    double worst_mean = 0;
    for (int c = 0; c < 3; ++c) worst_mean = std::max(worst_mean, std::fabs(src[c] - got[c]));
    row("NV12 to RGB (BT.601 limited)", w, h, nv_ms,
        printf_string("channel means within %.2f DN of the source", worst_mean));

    // The formats that are a copy.
    std::vector<uint8_t> grey_bytes(grey.data, grey.data + grey.total());
    const device::StreamFormat grey_format{"GREY", uw, uh, uw, static_cast<uint32_t>(grey.total()),
                                           {}};
    const double grey_ms = median_ms(
        repeats, [&] { (void)capture::convert_frame(frame_over(grey_bytes), grey_format, 8, 0); });
    row("GREY copy", w, h, grey_ms, "bit-exact");
  }
  return 0;
}
