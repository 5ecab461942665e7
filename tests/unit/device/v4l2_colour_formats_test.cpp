// The colour virtual camera's frames through camlab's V4L2 backend, in process: every
// format's bytes decoded here from the format's documented layout (not with camlab's
// unpackers) and compared with the renderer's noise-free mosaic.
//
//   Bayer 8/10/12/16, 10P, 12P   the raw DN at the format's depth, rounded: exact
//   binned Bayer                 each pixel the mean of its colour's four nearest pixels
//   RGB3, BGR3, NV12, YUYV        on a uniform scene, each channel 255 (DN - black) /
//                                (4095 - black) and BT.601 limited range of it
//   MJPG                         bytesused is the JPEG's length, within sizeimage; it
//                                decodes to the RGB3 picture within the JPEG's error
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "device/v4l2/v4l2_camera.h"
#include "device/v4l2/v4l2_transfer.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab {
namespace {

using namespace std::chrono_literals;
using nlohmann::json;

constexpr int kWidth = 64, kHeight = 48, kBlack = 64, kMaxDn = 4095;

// 12 bits, black 64, noise-free, 10 ms frames; GBRG, so that an order mix-up shows.
json camera_json() {
  json camera = mock::testing::colour_camera_json(kWidth, kHeight, "GBRG");
  camera["sensor"]["read_noise_e"] = 0.0;
  camera["sensor"]["shot_noise"] = false;
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", 0}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 40}};
  return camera;
}

// An edge, so that every pixel's position matters; its light side a colour.
json edge_scene_json() {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", {0.3, 0.2, 0.1}},
          {"targets",
           {{{"type", "slanted_edge"},
             {"size_m", {0.05, 0.05}},
             {"angle_deg", 8.0},
             {"dark_reflectance", {0.05, 0.1, 0.15}},
             {"light_reflectance", {0.8, 0.6, 0.3}},
             {"pose", {{"position_m", {0.0, 0.0, 1.0}}}}}}}};
}

json uniform_colour_scene_json() {
  json scene = mock::testing::uniform_scene_json(1.0, 0.5);
  scene["targets"][0]["light_reflectance"] = {0.8, 0.6, 0.3};
  scene["background_reflectance"] = {0.8, 0.6, 0.3};
  return scene;
}

// GBRG written out: row 0 G B G B, row 1 R G R G.
int gbrg_colour(int x, int y) { return y % 2 == 0 ? (x % 2 == 0 ? 1 : 2) : (x % 2 == 0 ? 0 : 1); }

class ColourFormats : public ::testing::Test {
 protected:
  void open(const json& scene_json) {
    camera_.reset();
    auto camera = mock::parse_camera_spec(camera_json());
    auto scene = mock::parse_scene_spec(scene_json);
    ASSERT_TRUE(camera.ok() && scene.ok());
    mock::VirtualDeviceOptions options;
    options.realtime = false;
    auto device = mock::VirtualV4l2Device::create(std::move(*camera), std::move(*scene), options);
    ASSERT_TRUE(device.ok()) << device.error().message;
    device_ = std::move(*device);
    io_ = std::make_shared<mock::VirtualV4l2Io>(std::vector{device_});
    auto opened = device::V4l2Camera::open(io_, "/dev/video0");
    ASSERT_TRUE(opened.ok()) << opened.error().message;
    camera_ = std::move(*opened);
    mock::Renderer reference = mock::testing::make_renderer(camera_json(), scene_json);
    auto frame = reference.render(reference.default_settings(), 0, mock::RenderOptions{});
    ASSERT_TRUE(frame.ok());
    mosaic_ = frame->image;  // CV_16UC1, 12-bit DN
    truth_ = frame->truth;
  }

  // One frame of `fourcc` at the size asked; its bytes copied out.
  std::vector<uint8_t> grab(const char* fourcc, uint32_t width, uint32_t height,
                            device::StreamFormat* format) {
    auto configured = camera_->configure({fourcc, width, height});
    EXPECT_TRUE(configured.ok()) << fourcc << ": " << configured.error().message;
    if (!configured) return {};
    *format = *configured;
    EXPECT_TRUE(camera_->start(2).ok());
    auto frame = camera_->dequeue(5000ms);
    EXPECT_TRUE(frame.ok()) << fourcc;
    if (!frame) return {};
    std::vector<uint8_t> bytes(frame->data, frame->data + frame->size);
    EXPECT_TRUE(camera_->requeue(*frame).ok());
    EXPECT_TRUE(camera_->stop().ok());
    return bytes;
  }

  int dn(int x, int y) const { return mosaic_.at<uint16_t>(y, x); }

  std::shared_ptr<mock::VirtualV4l2Device> device_;
  std::shared_ptr<mock::VirtualV4l2Io> io_;
  std::unique_ptr<device::V4l2Camera> camera_;
  cv::Mat mosaic_;
  json truth_;
};

// Sample x of row `line` of a raw Bayer format, decoded from its documented layout.
int sample(const std::string& fourcc, const uint8_t* line, int x) {
  if (fourcc == "GBRG") return line[x];                          // 8 bits
  if (fourcc == "GB10" || fourcc == "GB12" || fourcc == "GB16")  // 16 LE
    return line[2 * x] | (line[2 * x + 1] << 8);
  if (fourcc == "pGAA") {  // 4 in 5 bytes: high 8 bits each, then 2-bit remainders
    const uint8_t* group = line + x / 4 * 5;
    return (group[x % 4] << 2) | ((group[4] >> (2 * (x % 4))) & 3);
  }
  const uint8_t* group = line + x / 2 * 3;  // pGCC: 2 in 3 bytes, 4-bit remainders
  return (group[x % 2] << 4) | ((group[2] >> (4 * (x % 2))) & 15);
}

TEST_F(ColourFormats, EveryRawFormatCarriesTheRenderersMosaicAtItsDepth) {
  open(edge_scene_json());
  const std::pair<const char*, int> formats[] = {{"GBRG", 8},  {"GB10", 10}, {"GB12", 12},
                                                 {"GB16", 16}, {"pGAA", 10}, {"pGCC", 12}};
  for (const auto& [fourcc, bits] : formats) {
    device::StreamFormat format;
    const std::vector<uint8_t> bytes = grab(fourcc, kWidth, kHeight, &format);
    ASSERT_EQ(bytes.size(), format.size_bytes) << fourcc << ": bytesused is the whole frame";
    int worst = 0;
    for (int y = 0; y < kHeight; ++y)
      for (int x = 0; x < kWidth; ++x) {
        // 12-bit DN at the format's depth: fewer bits are the top ones, rounded.
        const int want = std::min((1 << bits) - 1,
                                  static_cast<int>(std::lround(std::ldexp(dn(x, y), bits - 12))));
        worst = std::max(
            worst, std::abs(sample(fourcc, bytes.data() + y * format.bytes_per_line, x) - want));
      }
    EXPECT_EQ(worst, 0) << fourcc;
  }
}

TEST_F(ColourFormats, BinnedBayerAveragesEachColoursNearestFour) {
  open(edge_scene_json());
  device::StreamFormat format;
  const std::vector<uint8_t> bytes = grab("GB12", kWidth / 2, kHeight / 2, &format);
  ASSERT_EQ(format.width, 32u);
  int worst = 0;
  for (int y = 0; y < kHeight / 2; ++y)
    for (int x = 0; x < kWidth / 2; ++x) {
      // Binned pixel (x, y) keeps its colour; its sources are the same-colour pixels of
      // the 4x4 cell at (4 (x / 2), 4 (y / 2)): offsets (x % 2) + {0, 2}, (y % 2) + {0, 2}.
      const int sx = 4 * (x / 2) + x % 2, sy = 4 * (y / 2) + y % 2;
      ASSERT_EQ(gbrg_colour(sx, sy), gbrg_colour(x, y));
      const double mean = (dn(sx, sy) + dn(sx + 2, sy) + dn(sx, sy + 2) + dn(sx + 2, sy + 2)) / 4.0;
      const int got = sample("GB12", bytes.data() + y * format.bytes_per_line, x);
      worst = std::max(worst, std::abs(got - static_cast<int>(std::lround(mean))));
    }
  EXPECT_EQ(worst, 0);
}

TEST_F(ColourFormats, IspFormatsCarryEachChannelsLinearLevelAndItsBt601Code) {
  open(uniform_colour_scene_json());
  // Each channel's level: the truth's expected DN (checked against radiometry in
  // mock_device_test) as the noise-free sensor quantises it, black subtracted, scaled to
  // 8 bits.
  double level[3];
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c) {
    const double expected_dn =
        truth_["channels"][names[c]]["targets"][0]["expected_dn"]["light"].get<double>();
    level[c] = (std::round(expected_dn) - kBlack) * 255.0 / (kMaxDn - kBlack);
    ASSERT_GT(level[c], 20) << names[c];
    ASSERT_LT(level[c], 250) << names[c];
  }
  auto code = [](double v) { return static_cast<int>(std::floor(v + 0.5)); };
  const double luma = 0.299 * level[0] + 0.587 * level[1] + 0.114 * level[2];
  const int y_code = code(16 + 219 * luma / 255);
  const int cb_code = code(128 + 224 * (level[2] - luma) / 1.772 / 255);
  const int cr_code = code(128 + 224 * (level[0] - luma) / 1.402 / 255);

  device::StreamFormat format;
  std::vector<uint8_t> rgb = grab("RGB3", kWidth, kHeight, &format);
  ASSERT_EQ(rgb.size(), static_cast<size_t>(kWidth * kHeight * 3));
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(rgb[(10 * kWidth + 17) * 3 + c], code(level[c])) << names[c];
  std::vector<uint8_t> bgr = grab("BGR3", kWidth, kHeight, &format);
  for (int c = 0; c < 3; ++c)
    EXPECT_EQ(bgr[(33 * kWidth + 8) * 3 + 2 - c], code(level[c])) << names[c];

  std::vector<uint8_t> nv12 = grab("NV12", kWidth, kHeight, &format);
  ASSERT_EQ(nv12.size(), static_cast<size_t>(kWidth * kHeight * 3 / 2));
  EXPECT_EQ(nv12[5 * kWidth + 3], y_code);
  const uint8_t* chroma = nv12.data() + kWidth * kHeight;  // Cb Cr pairs, half height
  EXPECT_EQ(chroma[7 * kWidth + 2 * 5], cb_code);
  EXPECT_EQ(chroma[7 * kWidth + 2 * 5 + 1], cr_code);

  std::vector<uint8_t> yuyv = grab("YUYV", kWidth, kHeight, &format);
  const uint8_t* pair = yuyv.data() + 20 * format.bytes_per_line + 4 * 6;  // Y0 Cb Y1 Cr
  EXPECT_EQ(pair[0], y_code);
  EXPECT_EQ(pair[1], cb_code);
  EXPECT_EQ(pair[2], y_code);
  EXPECT_EQ(pair[3], cr_code);

  // MJPG: bytesused is the stream's own length, an upper bound is the buffer's.
  std::vector<uint8_t> jpeg = grab("MJPG", kWidth, kHeight, &format);
  ASSERT_GT(jpeg.size(), 100u);
  EXPECT_LT(jpeg.size(), format.size_bytes);
  EXPECT_EQ(jpeg[0], 0xFF);
  EXPECT_EQ(jpeg[1], 0xD8);
  EXPECT_EQ(jpeg[jpeg.size() - 2], 0xFF) << "the stream ends exactly at bytesused";
  EXPECT_EQ(jpeg[jpeg.size() - 1], 0xD9);
  const cv::Mat decoded = cv::imdecode(jpeg, cv::IMREAD_COLOR);  // B, G, R
  ASSERT_EQ(decoded.cols, kWidth);
  const cv::Scalar mean = cv::mean(decoded);
  for (int c = 0; c < 3; ++c) EXPECT_NEAR(mean[2 - c], level[c], 1.5) << names[c];
}

TEST(MonochromeYuyv, CarriesLimitedRangeLumaOfTheGreyLevel) {
  json camera = mock::testing::pinhole_camera_json(32, 24);
  camera["sensor"]["read_noise_e"] = 0.0;
  camera["sensor"]["shot_noise"] = false;
  camera["timing"] = {{"frame_interval_us", 10000}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 20}};
  const json scene = mock::testing::uniform_scene_json(1.0, 0.5);
  auto spec = mock::parse_camera_spec(camera);
  auto scene_spec = mock::parse_scene_spec(scene);
  ASSERT_TRUE(spec.ok() && scene_spec.ok());
  mock::VirtualDeviceOptions options;
  options.realtime = false;
  auto device = mock::VirtualV4l2Device::create(*spec, *scene_spec, options);
  ASSERT_TRUE(device.ok());
  auto io = std::make_shared<mock::VirtualV4l2Io>(
      std::vector<std::shared_ptr<mock::VirtualV4l2Device>>{std::move(*device)});
  auto opened = device::V4l2Camera::open(io, "/dev/video0");
  ASSERT_TRUE(opened.ok());
  auto& cam = *opened;
  mock::Renderer reference = mock::testing::make_renderer(camera, scene);
  auto expected = reference.render(reference.default_settings(), 0, mock::RenderOptions{});
  ASSERT_TRUE(expected.ok());
  const double grey = expected->image.at<uint16_t>(5, 5) / 16.0;  // 12 -> 8 bits, unrounded
  ASSERT_GT(grey, 30);
  ASSERT_TRUE(cam->configure({"YUYV", 32, 24}).ok());
  ASSERT_TRUE(cam->start(2).ok());
  auto frame = cam->dequeue(5000ms);
  ASSERT_TRUE(frame.ok());
  EXPECT_EQ(frame->data[2 * (5 * 32 + 5)],
            static_cast<int>(std::floor(16 + 219 * grey / 255 + 0.5)));
  EXPECT_EQ(frame->data[2 * (5 * 32 + 5) + 1], 128);
  ASSERT_TRUE(cam->requeue(*frame).ok());
  ASSERT_TRUE(cam->stop().ok());
}

// The curve a format declares, resolved as the kernel's V4L2_MAP_XFER_FUNC_DEFAULT: only
// an explicit NONE or a raw colour space is linear; a webcam's SRGB or REC709 is not.
TEST(TransferOfV4l2Format, DefaultMapsByColourSpaceAndExplicitValuesAreKept) {
  using device::transfer_function_of;
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_RAW, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kLinear);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kSrgb);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_JPEG, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kSrgb);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_REC709, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kBt709);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_SMPTE170M, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kBt709);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_OPRGB, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kOther);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_NONE),
            TransferFunction::kLinear);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_709),
            TransferFunction::kBt709);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_SRGB, V4L2_XFER_FUNC_SMPTE2084),
            TransferFunction::kOther);
  // Both left at DEFAULT: nothing declared, not the kernel macro's BT.709 guess; an explicit
  // curve still says what it is.
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_DEFAULT, V4L2_XFER_FUNC_DEFAULT),
            TransferFunction::kUnknown);
  EXPECT_EQ(transfer_function_of(V4L2_COLORSPACE_DEFAULT, V4L2_XFER_FUNC_SRGB),
            TransferFunction::kSrgb);
  // The kernel's own macro agrees wherever camlab decodes.
  for (uint32_t cs : {V4L2_COLORSPACE_SRGB, V4L2_COLORSPACE_JPEG, V4L2_COLORSPACE_REC709,
                      V4L2_COLORSPACE_BT2020, V4L2_COLORSPACE_RAW}) {
    const uint32_t mapped = V4L2_MAP_XFER_FUNC_DEFAULT(cs);
    EXPECT_EQ(transfer_function_of(cs, V4L2_XFER_FUNC_DEFAULT), transfer_function_of(cs, mapped))
        << "colorspace " << cs;
  }
}

}  // namespace
}  // namespace camlab
