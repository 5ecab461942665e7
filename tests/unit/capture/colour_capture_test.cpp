// Captures from the colour virtual camera through camlab's V4L2 backend (in process) into
// capture folders, one per format the device offers: the stored frames' per-channel
// means against the renderer's truth (each channel's expected DN of the scene's uniform
// colour, which mock_device_test checks against radiometry).
//
//   raw Bayer (8, 10, 12, 16, 10P, 12P, binned)   within 1 DN at the stored depth
//   RGB3, BGR3                                    within 1 DN of 255 (DN - black) / (white - black)
//   NV12 (BT.601 limited, converted back)         within 1.5 DN (Y, Cb, Cr are rounded codes)
//   YUYV (camlab keeps its Y)                     within 1 code of BT.601 limited luma
//   MJPG at quality 90                            within 1.5 DN (docs/virtual-camera.md)
#include <gtest/gtest.h>

#include <cmath>

#include "capture/capture_runner.h"
#include "image/capture_folder.h"
#include "virtual_camera.h"

namespace camlab::capture {
namespace {

using nlohmann::json;

constexpr int kWidth = 64, kHeight = 48;
const char* const kNames[3] = {"R", "G", "B"};

// 12 bits, black 64, noise-free (the formats are under test, not the noise), BGGR.
json camera_json() {
  json camera = mock::testing::colour_camera_json(kWidth, kHeight, "BGGR");
  camera["sensor"]["read_noise_e"] = 0.0;
  camera["sensor"]["shot_noise"] = false;
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", 0}};
  camera["controls"]["exposure_time_absolute"] = {{"min", 1}, {"max", 100}, {"default", 40}};
  return camera;
}

json scene_json() {
  json scene = mock::testing::uniform_scene_json(1.0, 0.5);
  scene["targets"][0]["light_reflectance"] = {0.7, 0.5, 0.25};
  scene["background_reflectance"] = {0.7, 0.5, 0.25};
  return scene;
}

// Each channel's expected DN (12 bits, black in) from the renderer's truth.
std::array<double, 3> expected_dn() {
  mock::Renderer renderer = mock::testing::make_renderer(camera_json(), scene_json());
  auto frame = renderer.render(renderer.default_settings(), 0, mock::RenderOptions{});
  EXPECT_TRUE(frame.ok());
  std::array<double, 3> dn{};
  for (int c = 0; c < 3; ++c)
    dn[c] = frame->truth["channels"][kNames[c]]["targets"][0]["expected_dn"]["light"].get<double>();
  return dn;
}

struct Stored {
  std::vector<cv::Mat> images;
  std::vector<image::FrameSidecar> sidecars;
};

Stored capture(const char* fourcc, uint32_t width, uint32_t height) {
  testing::VirtualCamera vcam = testing::open_virtual_camera(camera_json(), scene_json(), false);
  auto controls = vcam.camera->controls();
  auto formats = vcam.camera->formats();
  EXPECT_TRUE(controls.ok() && formats.ok());
  const json request = {{"kind", "single"},
                        {"repeats", 2},
                        {"format", {{"fourcc", fourcc}, {"width", width}, {"height", height}}}};
  auto plan = plan_capture(request, *controls, *formats, vcam.traits);
  EXPECT_TRUE(plan.ok()) << fourcc << ": " << plan.error().message;
  Stored out;
  if (!plan) return out;
  testing::ScratchDir dir("colour");
  CaptureOptions options;
  options.source = {{"backend", "virtual"}};
  auto summary = run_capture(*vcam.camera, *plan, dir / "capture", options, nullptr);
  EXPECT_TRUE(summary.ok()) << fourcc << ": " << summary.error().message;
  if (!summary) return out;
  auto folder = image::CaptureFolder::open(dir / "capture");
  EXPECT_TRUE(folder.ok());
  for (int i = 0; folder && i < static_cast<int>(folder->frames().size()); ++i) {
    auto image = folder->load_stored_image(i);
    auto sidecar = folder->load_sidecar(i);
    EXPECT_TRUE(image.ok() && sidecar.ok());
    out.images.push_back(*image);
    out.sidecars.push_back(*sidecar);
  }
  EXPECT_EQ(out.images.size(), 2u) << fourcc;
  return out;
}

// The colour of mosaic pixel (x, y) for a stored CFA pattern, by its 2x2 cell.
int colour_at(const std::string& cfa, int x, int y) {
  const char c = cfa.at(static_cast<size_t>(2 * (y % 2) + x % 2));
  return c == 'R' ? 0 : c == 'G' ? 1 : 2;
}

std::array<double, 3> mosaic_means(const cv::Mat& mosaic, const std::string& cfa) {
  std::array<double, 3> sum{}, n{};
  for (int y = 0; y < mosaic.rows; ++y)
    for (int x = 0; x < mosaic.cols; ++x) {
      const int c = colour_at(cfa, x, y);
      sum[c] += mosaic.depth() == CV_8U ? mosaic.at<uint8_t>(y, x) : mosaic.at<uint16_t>(y, x);
      n[c] += 1;
    }
  return {sum[0] / n[0], sum[1] / n[1], sum[2] / n[2]};
}

// R, G, B means of a stored B, G, R image.
std::array<double, 3> rgb_means(const cv::Mat& bgr) {
  const cv::Scalar m = cv::mean(bgr);
  return {m[2], m[1], m[0]};
}

TEST(ColourCapture, RawBayerFramesKeepEachChannelsDnWithinOneDn) {
  const std::array<double, 3> want = expected_dn();
  struct Case {
    const char* fourcc;
    uint32_t width, height;
    int stored_bits;
  };
  for (const Case& c : {Case{"BA81", 64, 48, 8}, Case{"BG10", 64, 48, 10}, Case{"BG12", 64, 48, 12},
                        Case{"BYR2", 64, 48, 12}, Case{"pBAA", 64, 48, 10},
                        Case{"pBCC", 64, 48, 12}, Case{"pBCC", 32, 24, 12}}) {
    const Stored s = capture(c.fourcc, c.width, c.height);
    for (size_t i = 0; i < s.images.size(); ++i) {
      const image::FrameSidecar& side = s.sidecars[i];
      EXPECT_EQ(side.layout, image::FrameLayout::kMosaic) << c.fourcc;
      EXPECT_EQ(side.cfa_pattern, "BGGR") << c.fourcc;
      EXPECT_EQ(side.bit_depth, c.stored_bits) << c.fourcc;
      EXPECT_EQ(s.images[i].cols, static_cast<int>(c.width));
      const std::array<double, 3> got = mosaic_means(s.images[i], side.cfa_pattern);
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(got[ch], std::ldexp(want[ch], c.stored_bits - 12), 1.0)
            << c.fourcc << " " << c.width << " " << kNames[ch];
      EXPECT_NEAR(side.black_level_dn, std::ldexp(64.0, c.stored_bits - 12), 0.5) << c.fourcc;
    }
  }
}

TEST(ColourCapture, IspFramesCarryEachChannelsLinearLevel) {
  const std::array<double, 3> dn = expected_dn();
  std::array<double, 3> level{};
  for (int c = 0; c < 3; ++c) level[c] = (dn[c] - 64) * 255.0 / (4095 - 64);
  const double luma = 0.299 * level[0] + 0.587 * level[1] + 0.114 * level[2];
  struct Case {
    const char* fourcc;
    double tolerance;
  };
  for (const Case& c :
       {Case{"RGB3", 1.0}, Case{"BGR3", 1.0}, Case{"NV12", 1.5}, Case{"MJPG", 1.5}}) {
    const Stored s = capture(c.fourcc, kWidth, kHeight);
    for (size_t i = 0; i < s.images.size(); ++i) {
      EXPECT_EQ(s.sidecars[i].layout, image::FrameLayout::kRgb) << c.fourcc;
      EXPECT_EQ(s.sidecars[i].linear, std::string(c.fourcc) != "MJPG") << c.fourcc;
      const std::array<double, 3> got = rgb_means(s.images[i]);
      for (int ch = 0; ch < 3; ++ch)
        EXPECT_NEAR(got[ch], level[ch], c.tolerance) << c.fourcc << " " << kNames[ch];
    }
  }
  // camlab keeps YUYV's Y samples: BT.601 luma at limited range.
  // Its black is YUYV's own 16: the ISP took the sensor's pedestal off (64 DN of 12 bits,
  // which the mono camera's YUYV keeps and records as 16 + 4 x 219 / 255 = 19).
  const Stored yuyv = capture("YUYV", kWidth, kHeight);
  for (size_t i = 0; i < yuyv.images.size(); ++i) {
    EXPECT_NEAR(cv::mean(yuyv.images[i])[0], 16 + 219 * luma / 255, 1.0);
    EXPECT_EQ(yuyv.sidecars[i].black_level_dn, 16);
    EXPECT_EQ(yuyv.sidecars[i].white_level_dn, 235);
  }
}

}  // namespace
}  // namespace camlab::capture
