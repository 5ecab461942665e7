// The colour virtual camera's cost against the monochrome one, and the error of each
// format its V4L2 device offers (docs/measuring.md: speed against error, never pass/fail).
//
//   colour_bench [--quick]
//
// Table 1: ms per 640x480 frame, monochrome (camera_640x480.json) against colour
//          (camera_colour_640x480.json), on the slanted edges: the scene integral
//          computed every frame (a new sampling seed each time), and reused (exposure
//          and noise only, as brackets and repeats render).
// Table 2: per device format, ms to make a frame from the raw mosaic and each channel's
//          mean over the frame against the truth: a uniform colour target filling the
//          frame, noise-free, so the error is the format's alone (raw: DN at the
//          format's depth; RGB, YUV, JPEG: 8-bit levels, 255 (DN - black) / (white - black)).
// Table 3: MJPG at several qualities on a textured colour target (noise on): JPEG bytes,
//          and each channel's mean against the RGB3 frame made from the same mosaic.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "image/jpeg_codec.h"
#include "mock_device/render/renderer.h"
#include "mock_device/v4l2/virtual_v4l2_formats.h"
#include "mock_device/v4l2/virtual_v4l2_frame_encoder.h"

namespace {

using namespace camlab;
using namespace camlab::mock;
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

const fs::path kExamples = fs::path(CAMLAB_SOURCE_DIR) / "mock_device/examples";

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

template <class T>
T or_exit(Result<T> r) {
  if (!r) {
    std::fprintf(stderr, "%s\n", r.error().message.c_str());
    std::exit(1);
  }
  return std::move(*r);
}

Renderer make(CameraSpec camera, SceneSpec scene) {
  return or_exit(Renderer::create(std::move(camera), std::move(scene)));
}

void speed_table(int repeats) {
  std::printf("Render cost at 640x480, scene_slanted_edges.json, noise on (median of %d)\n",
              repeats);
  std::printf(
      "| camera | samples/px | ms/frame, integral each frame | ms/frame, integral reused |\n"
      "|---|---|---|---|\n");
  struct Case {
    const char* camera;
    bool chromatic_aberration;
  };
  for (const Case c : {Case{"camera_640x480.json", false}, Case{"camera_colour_640x480.json", true},
                       Case{"camera_colour_640x480.json", false}}) {
    CameraSpec spec = or_exit(load_camera_spec(kExamples / c.camera));
    // Without its focus shifts the colour camera blurs as the monochrome one does, so the
    // two rows compare the cost of a pixel, not of a lens.
    if (!c.chromatic_aberration) spec.lens.chromatic_focus_shift_mm = {0, 0, 0};
    Renderer renderer =
        make(spec, or_exit(load_scene_spec(kExamples / "scene_slanted_edges.json")));
    std::vector<double> fresh, reused;
    int samples = 0;
    for (int i = 0; i < repeats; ++i) {
      RenderOptions options;
      options.seed = static_cast<uint64_t>(100 + i);  // a new scene integral
      options.frame_number = static_cast<uint64_t>(i);
      auto frame = or_exit(renderer.render(renderer.default_settings(), 0, options));
      fresh.push_back(frame.stats.seconds);
      samples = frame.stats.pixel_samples;
      options.frame_number += 1000;  // same integral, new noise
      auto again = or_exit(renderer.render(renderer.default_settings(), 0, options));
      reused.push_back(again.stats.seconds);
    }
    std::printf("| %s%s | %d | %.1f | %.1f |\n", c.camera,
                spec.sensor.is_colour() && !c.chromatic_aberration ? " (focus shifts 0)" : "",
                samples, median(fresh) * 1e3, median(reused) * 1e3);
  }
}

// Each channel's mean of a frame in `format`, decoded with its documented layout (raw:
// DN at the format's depth; others: 8-bit R, G, B).
std::array<double, 3> channel_means(const std::vector<uint8_t>& bytes, const OfferedFormat& f,
                                    const v4l2_pix_format& pix, const SensorSpec& sensor) {
  std::array<double, 3> sum{}, n{};
  const int w = static_cast<int>(pix.width), h = static_cast<int>(pix.height);
  if (f.is_bayer()) {
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) {
        const uint8_t* line = bytes.data() + static_cast<size_t>(y) * pix.bytesperline;
        double v = 0;
        switch (f.kind) {
          case FormatKind::kBayer8:
            v = line[x];
            break;
          case FormatKind::kBayer16Low:
          case FormatKind::kBayer16High:
            v = line[2 * x] | (line[2 * x + 1] << 8);
            break;
          case FormatKind::kBayerMipi10:
            v = (line[x / 4 * 5 + x % 4] << 2) | ((line[x / 4 * 5 + 4] >> (2 * (x % 4))) & 3);
            break;
          default:  // MIPI RAW12
            v = (line[x / 2 * 3 + x % 2] << 4) | ((line[x / 2 * 3 + 2] >> (4 * (x % 2))) & 15);
            break;
        }
        const int c = sensor.channel_at(x, y);
        sum[c] += v;
        n[c] += 1;
      }
    return {sum[0] / n[0], sum[1] / n[1], sum[2] / n[2]};
  }
  cv::Mat rgb;
  if (f.kind == FormatKind::kMjpeg) {
    cv::Mat bgr = or_exit(image::decode_jpeg(bytes));
    const cv::Scalar m = cv::mean(bgr);
    return {m[2], m[1], m[0]};
  }
  if (f.kind == FormatKind::kRgb24 || f.kind == FormatKind::kBgr24) {
    const cv::Scalar m = cv::mean(cv::Mat(h, w, CV_8UC3, const_cast<uint8_t*>(bytes.data())));
    return f.kind == FormatKind::kRgb24 ? std::array<double, 3>{m[0], m[1], m[2]}
                                        : std::array<double, 3>{m[2], m[1], m[0]};
  }
  // YUYV and NV12: back through BT.601 limited range, each chroma sample on its pixels.
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      double luma, cb, cr;
      if (f.kind == FormatKind::kYuyv) {
        const uint8_t* p = bytes.data() + static_cast<size_t>(y) * pix.bytesperline + 4 * (x / 2);
        luma = p[2 * (x % 2)];
        cb = p[1];
        cr = p[3];
      } else {
        luma = bytes[static_cast<size_t>(y) * pix.bytesperline + x];
        const uint8_t* c = bytes.data() + static_cast<size_t>(h) * pix.bytesperline +
                           static_cast<size_t>(y / 2) * pix.bytesperline + 2 * (x / 2);
        cb = c[0];
        cr = c[1];
      }
      const double yy = (luma - 16) * 255 / 219, pb = (cb - 128) * 255 / 224,
                   pr = (cr - 128) * 255 / 224;
      const double r = yy + 1.402 * pr, b = yy + 1.772 * pb;
      const double g = (yy - 0.299 * r - 0.114 * b) / 0.587;
      sum[0] += r;
      sum[1] += g;
      sum[2] += b;
      n[0] += 1;
    }
  return {sum[0] / n[0], sum[1] / n[0], sum[2] / n[0]};
}

void format_table(int repeats) {
  CameraSpec camera = or_exit(load_camera_spec(kExamples / "camera_colour_640x480.json"));
  camera.sensor.read_noise_e = 0;
  camera.sensor.shot_noise = false;
  const nlohmann::json scene_json = {{"illuminance_lux", 1000},
                                     {"background_reflectance", {0.7, 0.5, 0.25}},
                                     {"targets",
                                      {{{"type", "uniform"},
                                        {"size_m", {10, 10}},
                                        {"light_reflectance", {0.7, 0.5, 0.25}},
                                        {"pose", {{"position_m", {0, 0, 1.0}}}}}}}};
  Renderer renderer = make(camera, or_exit(parse_scene_spec(scene_json)));
  RenderOptions options;
  options.noise = false;
  auto frame = or_exit(renderer.render(renderer.default_settings(), 0, options));
  const SensorSpec& sensor = renderer.camera().sensor;
  const double white = (1 << sensor.bit_depth) - 1, black = sensor.black_level_dn;
  std::array<double, 3> dn{};
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c)
    dn[c] = frame.truth["channels"][names[c]]["targets"][0]["expected_dn"]["light"].get<double>();
  std::printf(
      "\nDevice formats of camera_colour_640x480.json (12 bits, black 64; a uniform target, "
      "noise off): each channel's mean against the truth (median of %d)\n",
      repeats);
  std::printf(
      "| format | size | ms/frame | truth R, G, B | error R | error G | error B |\n"
      "|---|---|---|---|---|---|---|\n");
  for (const OfferedFormat& f : offered_formats(sensor)) {
    for (uint32_t index = 0; index < 2; ++index) {
      if (index == 1 && !f.is_bayer()) continue;  // binning: the raw formats show it
      v4l2_pix_format pix{};
      fill_pix_format(f, *frame_size(f, sensor, index), &pix);
      std::vector<double> seconds;
      std::vector<uint8_t> bytes;
      for (int i = 0; i < repeats; ++i) {
        const auto start = Clock::now();
        bytes = or_exit(encode_frame(frame.image, sensor, renderer.camera().isp, f, pix));
        seconds.push_back(std::chrono::duration<double>(Clock::now() - start).count());
      }
      std::array<double, 3> truth{};
      for (int c = 0; c < 3; ++c)
        truth[c] = f.is_bayer() ? std::ldexp(dn[c], f.bits - sensor.bit_depth)
                                : (dn[c] - black) * 255 / (white - black);
      const auto got = channel_means(bytes, f, pix, sensor);
      std::printf("| %s%s | %ux%u | %.2f | %.2f, %.2f, %.2f | %+.3f | %+.3f | %+.3f |\n",
                  f.description.c_str(),
                  f.kind == FormatKind::kMjpeg
                      ? (" q" + std::to_string(renderer.camera().isp.jpeg_quality)).c_str()
                      : "",
                  pix.width, pix.height, median(seconds) * 1e3, truth[0], truth[1], truth[2],
                  got[0] - truth[0], got[1] - truth[1], got[2] - truth[2]);
    }
  }
}

void jpeg_table() {
  CameraSpec camera = or_exit(load_camera_spec(kExamples / "camera_colour_640x480.json"));
  const nlohmann::json scene_json = {{"illuminance_lux", 1000},
                                     {"background_reflectance", {0.3, 0.25, 0.2}},
                                     {"targets",
                                      {{{"type", "texture"},
                                        {"size_m", {0.6, 0.6}},
                                        {"feature_m", 0.004},
                                        {"seed", 3},
                                        {"dark_reflectance", {0.1, 0.08, 0.05}},
                                        {"light_reflectance", {0.8, 0.6, 0.3}},
                                        {"pose", {{"position_m", {0, 0, 1.0}}}}}}}};
  Renderer renderer = make(camera, or_exit(parse_scene_spec(scene_json)));
  RenderSettings settings = renderer.default_settings();
  settings.focus_position = 65;
  auto frame = or_exit(renderer.render(settings, 0, RenderOptions{}));
  const SensorSpec& sensor = renderer.camera().sensor;
  OfferedFormat rgb, jpeg;
  for (const OfferedFormat& f : offered_formats(sensor)) {
    if (f.kind == FormatKind::kRgb24) rgb = f;
    if (f.kind == FormatKind::kMjpeg) jpeg = f;
  }
  v4l2_pix_format rgb_pix{}, jpeg_pix{};
  fill_pix_format(rgb, *frame_size(rgb, sensor, 0), &rgb_pix);
  fill_pix_format(jpeg, *frame_size(jpeg, sensor, 0), &jpeg_pix);
  const auto reference = channel_means(
      or_exit(encode_frame(frame.image, sensor, IspSpec{.jpeg_quality = 90}, rgb, rgb_pix)), rgb,
      rgb_pix, sensor);
  std::printf(
      "\nMJPG of a textured colour target (noise on) against RGB3 of the same mosaic; "
      "sizeimage %u bytes\n",
      jpeg_pix.sizeimage);
  std::printf(
      "| quality | JPEG bytes | ms/frame | mean error R | mean error G | mean error B |\n"
      "|---|---|---|---|---|---|\n");
  for (int quality : {50, 75, 90, 95}) {
    const auto start = Clock::now();
    const std::vector<uint8_t> bytes = or_exit(
        encode_frame(frame.image, sensor, IspSpec{.jpeg_quality = quality}, jpeg, jpeg_pix));
    const double ms = std::chrono::duration<double>(Clock::now() - start).count() * 1e3;
    const auto got = channel_means(bytes, jpeg, jpeg_pix, sensor);
    std::printf("| %d | %zu | %.2f | %+.3f | %+.3f | %+.3f |\n", quality, bytes.size(), ms,
                got[0] - reference[0], got[1] - reference[1], got[2] - reference[2]);
  }
}

}  // namespace

int main(int argc, char** argv) {
  const bool quick = argc > 1 && std::strcmp(argv[1], "--quick") == 0;
  speed_table(quick ? 1 : 5);
  format_table(quick ? 1 : 5);
  jpeg_table();
  return 0;
}
