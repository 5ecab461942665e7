// A webcam's YUYV is gamma-encoded, and says so in the format's colour fields. The virtual
// camera with `isp.transfer` encodes and declares it the same way; captured through
// camlab's V4L2 backend (in process), the frame's sidecar says which curve, the SFR
// decodes it, and the light-linear measurements refuse it instead of reading codes as
// light.
//
//   levels decoded         within half an 8-bit code's light of the truth's (reflectance x
//                          electrons per unit reflectance / full well, independent of the
//                          encoder and decoder)
//   MTF50 decoded          within 1% of a linear YUYV capture of the same edge
//   MTF50 read as linear   more than 2% off (what the sidecar's curve saves)
//   blur disk decoded      within 0.1 px of the thin lens's 2.057 px (read as light: 2-10% high)
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>

#include "analysis/channel_signal.h"
#include "analysis/defocus/defocus_report.h"
#include "analysis/sfr/sfr_image.h"
#include "base/transfer_function.h"
#include "capture/capture_runner.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"
#include "virtual_camera.h"

namespace camlab::capture {
namespace {

using nlohmann::json;

constexpr int kEdgeWidth = 256, kEdgeHeight = 192;
constexpr int kEdgeExposureSteps = 70;
constexpr double kDark = 0.02, kLight = 0.8;  // 40:1, a printed chart's

// Mono, 12 bits, black 64, noise-free (the curve is under test); focused at infinity, so
// the edge 4 m away is blurred by a 2-px disk.
json edge_camera_json(const char* transfer, bool noise = false, bool declares_colour_space = true) {
  json camera = mock::testing::pinhole_camera_json(kEdgeWidth, kEdgeHeight);
  camera["sensor"]["read_noise_e"] = noise ? 5.0 : 0.0;
  camera["sensor"]["shot_noise"] = noise;
  camera["timing"] = {{"frame_interval_us", 10000}, {"control_latency_frames", 0}};
  camera["controls"]["exposure_time_absolute"] = {
      {"min", 1}, {"max", 100}, {"default", kEdgeExposureSteps}};
  camera["isp"] = {{"transfer", transfer}, {"declares_colour_space", declares_colour_space}};
  return camera;
}

json edge_scene_json() {
  return {{"illuminance_lux", 1000},
          {"background_reflectance", 0.3},
          {"targets",
           {{{"type", "slanted_edge"},
             {"size_m", {0.3, 0.3}},
             {"angle_deg", 5},
             {"dark_reflectance", kDark},
             {"light_reflectance", kLight},
             {"pose", {{"position_m", {0.0, 0.0, 4.0}}}}}}}};
}

// One frame of the edge into `dir`, YUYV unless `fourcc` says otherwise.
void capture_yuyv(const char* transfer, const std::filesystem::path& dir, bool noise = false,
                  bool declares_colour_space = true, const char* fourcc = "YUYV") {
  testing::VirtualCamera vcam = testing::open_virtual_camera(
      edge_camera_json(transfer, noise, declares_colour_space), edge_scene_json(), false);
  auto controls = vcam.camera->controls();
  auto formats = vcam.camera->formats();
  ASSERT_TRUE(controls.ok() && formats.ok());
  const json request = {
      {"kind", "single"},
      {"format", {{"fourcc", fourcc}, {"width", kEdgeWidth}, {"height", kEdgeHeight}}}};
  auto plan = plan_capture(request, *controls, *formats, vcam.traits);
  ASSERT_TRUE(plan.ok()) << plan.error().message;
  CaptureOptions options;
  options.source = {{"backend", "virtual"}};
  auto summary = run_capture(*vcam.camera, *plan, dir, options, nullptr);
  ASSERT_TRUE(summary.ok()) << summary.error().message;
}

// The light above black the renderer's truth gives a reflectance, as a fraction of full
// scale (a real camera's capture carries no truth, so it is rendered here).
double truth_light(double reflectance) {
  mock::Renderer renderer =
      mock::testing::make_renderer(edge_camera_json("linear"), edge_scene_json());
  auto frame = renderer.render(renderer.default_settings(), 0, mock::RenderOptions{});
  EXPECT_TRUE(frame.ok());
  const double electrons = frame->truth["electrons_per_unit_reflectance"].get<double>();
  return reflectance * electrons / 20000.0;  // full well, the spec's
}

// A copy of capture `from` whose sidecar claims linear values: what camlab read before it
// recorded the curve.
void copy_as_misread(const std::filesystem::path& from, const std::filesystem::path& to) {
  std::filesystem::copy(from, to, std::filesystem::copy_options::recursive);
  const auto sidecar_path = to / "frame_000000.json";
  json sidecar = json::parse(std::ifstream(sidecar_path));
  sidecar["transfer"] = "linear";
  sidecar["linear"] = true;
  std::ofstream(sidecar_path) << sidecar.dump();
}

std::vector<double> mtf50s(const analysis::SfrImageReport& report) {
  std::vector<double> out;
  for (const json& edge : report.report["frames"][0]["edges"])
    if (edge["status"] == "ok") out.push_back(edge["mtf50_cy_px"].get<double>());
  return out;
}

TEST(TransferCapture, AnSrgbYuyvFrameSaysSoAndDecodesToTheTruthsLight) {
  testing::ScratchDir dir("transfer");
  capture_yuyv("srgb", dir / "srgb");
  auto folder = image::CaptureFolder::open(dir / "srgb");
  ASSERT_TRUE(folder.ok()) << folder.error().message;
  auto side = folder->load_sidecar(0);
  auto stored = folder->load_stored_image(0);
  ASSERT_TRUE(side.ok() && stored.ok());
  EXPECT_EQ(side->transfer, TransferFunction::kSrgb) << "V4L2_XFER_FUNC_DEFAULT of SRGB";
  EXPECT_FALSE(side->linear);
  EXPECT_EQ(side->white_level_dn, 235);

  auto light = image::decode_to_light(*stored, *side);
  ASSERT_TRUE(light.ok()) << light.error().message;
  ASSERT_TRUE(light->decoded);
  EXPECT_EQ(light->stored.type(), CV_16UC1);
  EXPECT_TRUE(light->sidecar.linear) << "YUYV is not lossy once decoded";
  // Plateaus 20+ px from the edge (x 121-135), inside the square (x 53-203).
  const double black = side->black_level_dn, span = side->white_level_dn - black;
  for (const auto& [reflectance, columns] :
       {std::pair{kDark, cv::Range(70, 100)}, std::pair{kLight, cv::Range(160, 190)}}) {
    const double want = truth_light(reflectance);
    const double got = cv::mean(light->stored(cv::Range(60, 130), columns))[0] / 65535.0;
    // Half a code of the 8-bit encoding, in light, where `want` lies.
    const double code = black + span * encode_light(TransferFunction::kSrgb, want);
    const double half_code_light =
        (decode_to_light(TransferFunction::kSrgb, (code + 0.5 - black) / span) -
         decode_to_light(TransferFunction::kSrgb, (code - 0.5 - black) / span)) /
        2;
    EXPECT_NEAR(got, want, half_code_light + 1e-4) << "reflectance " << reflectance;
    // Read as light, the codes are far off (sRGB lifts the dark side 3-fold).
    const double raw = (cv::mean((*stored)(cv::Range(60, 130), columns))[0] - black) / span;
    EXPECT_GT(std::abs(raw - want), 10 * half_code_light) << "reflectance " << reflectance;
  }

  // Measurements of light levels and noise refuse it, naming the curve.
  auto channels = analysis::measurable_channels(*side);
  ASSERT_FALSE(channels.ok());
  EXPECT_EQ(channels.error().code, ErrorCode::kNotLinear);
  EXPECT_NE(channels.error().message.find("srgb curve"), std::string::npos)
      << channels.error().message;
}

// A driver that leaves the colour fields at DEFAULT declares no curve: the YUYV frame says
// "unknown", and neither the level measurements nor the decoding read it as light (its
// values are sRGB-encoded here, which nothing in the stream tells); the raw Y16 of the same
// camera is the sensor's DN, linear.
TEST(TransferCapture, AFormatWithoutAColourSpaceIsNotReadAsLightUnlessItIsRaw) {
  testing::ScratchDir dir("transfer_undeclared");
  capture_yuyv("srgb", dir / "yuyv", false, /*declares_colour_space=*/false);
  capture_yuyv("srgb", dir / "y16", false, /*declares_colour_space=*/false, "Y16 ");
  auto yuyv = image::CaptureFolder::open(dir / "yuyv");
  auto y16 = image::CaptureFolder::open(dir / "y16");
  ASSERT_TRUE(yuyv.ok() && y16.ok());
  auto side = yuyv->load_sidecar(0);
  auto stored = yuyv->load_stored_image(0);
  ASSERT_TRUE(side.ok() && stored.ok());
  EXPECT_EQ(side->transfer, TransferFunction::kUnknown);
  EXPECT_FALSE(side->linear);
  auto channels = analysis::measurable_channels(*side);
  auto light = image::decode_to_light(*stored, *side);
  ASSERT_FALSE(channels.ok());
  ASSERT_FALSE(light.ok());
  for (const auto& refused : {channels.error(), light.error()}) {
    EXPECT_EQ(refused.code, ErrorCode::kNotLinear);
    EXPECT_NE(refused.message.find("declares no colour space"), std::string::npos)
        << refused.message;
  }
  // The sidecar says so on disk, and reads back the same.
  const json on_disk = json::parse(std::ifstream(dir / "yuyv" / "frame_000000.json"));
  EXPECT_EQ(on_disk["transfer"], "unknown");
  auto raw = y16->load_sidecar(0);
  ASSERT_TRUE(raw.ok());
  EXPECT_EQ(raw->transfer, TransferFunction::kLinear);
  EXPECT_TRUE(raw->linear);
  EXPECT_TRUE(analysis::measurable_channels(*raw).ok());
}

TEST(TransferCapture, TheSfrOfAnSrgbCaptureIsTheLinearCapturesOnceDecoded) {
  testing::ScratchDir dir("transfer_sfr");
  capture_yuyv("linear", dir / "linear");
  capture_yuyv("srgb", dir / "srgb");
  auto linear_side = image::CaptureFolder::open(dir / "linear")->load_sidecar(0);
  ASSERT_TRUE(linear_side.ok());
  EXPECT_EQ(linear_side->transfer, TransferFunction::kLinear) << "declared V4L2_XFER_FUNC_NONE";
  EXPECT_TRUE(linear_side->linear);

  const analysis::SfrImageOptions options;
  auto linear = analysis::analyze_sfr_folder(dir / "linear", options);
  auto decoded = analysis::analyze_sfr_folder(dir / "srgb", options);
  ASSERT_TRUE(linear.ok()) << linear.error().message;
  ASSERT_TRUE(decoded.ok()) << decoded.error().message;
  EXPECT_EQ(decoded->report["transfer"]["encoding"], "srgb");
  EXPECT_EQ(linear->report["transfer"]["encoding"], "linear");

  copy_as_misread(dir / "srgb", dir / "misread");
  auto misread = analysis::analyze_sfr_folder(dir / "misread", options);
  ASSERT_TRUE(misread.ok()) << misread.error().message;

  const std::vector<double> want = mtf50s(*linear), got = mtf50s(*decoded),
                            wrong = mtf50s(*misread);
  ASSERT_FALSE(want.empty());
  ASSERT_EQ(got.size(), want.size());
  ASSERT_EQ(wrong.size(), want.size());
  for (size_t k = 0; k < want.size(); ++k) {
    std::printf("edge %zu: MTF50 linear capture %.4f, srgb decoded %.4f, read as linear %.4f\n", k,
                want[k], got[k], wrong[k]);
    EXPECT_NEAR(got[k] / want[k], 1.0, 0.01) << "edge " << k << ": " << got[k] << " vs " << want[k];
    EXPECT_GT(std::abs(wrong[k] / want[k] - 1.0), 0.02)
        << "edge " << k << ": read as linear " << wrong[k] << " vs " << want[k];
  }
}

// The circle of confusion from the same frames: decoded, the blur disk fitted to the sRGB
// capture's edges is the linear capture's (read as codes, the gamma bends the edge).
TEST(TransferCapture, TheBlurDiskOfAnSrgbCaptureIsTheLinearCapturesOnceDecoded) {
  testing::ScratchDir dir("transfer_coc");
  // With shot and read noise, as a camera's frames have (a noise-free decoded frame's
  // flat light side looks like a clip to the clip detector).
  capture_yuyv("linear", dir / "linear", true);
  capture_yuyv("srgb", dir / "srgb", true);
  copy_as_misread(dir / "srgb", dir / "misread");
  // Every edge of the chart is 4 m away: one blur disk, the thin lens's 2.057 px.
  auto disks = [](const std::filesystem::path& folder) {
    auto report = analysis::analyze_defocus(folder, analysis::DefocusOptions{});
    EXPECT_TRUE(report.ok()) << report.error().message;
    std::vector<double> out;
    if (report)
      for (const auto& target : report->targets)
        if (target.frames.at(0).edge.measured())
          out.push_back(target.frames.at(0).edge.diameter_px);
    return out;
  };
  const std::vector<double> linear = disks(dir / "linear"), decoded = disks(dir / "srgb"),
                            misread = disks(dir / "misread");
  auto text = [](const std::vector<double>& v) {
    std::string s;
    for (double d : v) s += " " + std::to_string(d).substr(0, 5);
    return s;
  };
  std::printf(
      "blur disks (thin lens 2.057 px): linear capture%s; srgb decoded%s; read as "
      "linear%s\n",
      text(linear).c_str(), text(decoded).c_str(), text(misread).c_str());
  EXPECT_GE(decoded.size(), 2u);
  for (double d : linear) EXPECT_NEAR(d, 2.057, 0.1) << "linear capture";
  for (double d : decoded) EXPECT_NEAR(d, 2.057, 0.1) << "srgb decoded";
  int misread_off = 0;
  for (double d : misread) misread_off += std::abs(d - 2.057) > 0.1;
  EXPECT_GT(misread_off, 0) << "the gamma read as light bends the edge";
}

}  // namespace
}  // namespace camlab::capture
