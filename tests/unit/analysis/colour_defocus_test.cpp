// Defocus of a colour (Bayer) capture, per channel, on mosaics made here from the thin
// lens and the disk-blurred edge written out independently of camlab's renderer and fits:
// each pixel is the fraction of the blur disks over its area (supersampled) that falls on
// the light side, for that pixel's colour's own blur diameter.
//
// The lens has longitudinal chromatic aberration: R, G and B have focal lengths
// 8.012, 8.000 and 7.985 mm, so at one lens-to-sensor distance each channel images the
// object at a different distance behind the lens.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <numbers>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <string>

#include "analysis/defocus/defocus_report.h"
#include "analysis/exposure/exposure_report.h"
#include "analysis/focus/focus_report.h"
#include "analytic_edge.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace colour_defocus_test {

namespace fs = std::filesystem;
using nlohmann::json;

constexpr double kPitchUm = 3.0;
constexpr double kNominalFocalMm = 8.0;
constexpr double kChannelFocalMm[3] = {8.012, 8.000, 7.985};  // R, G, B
constexpr double kFocusDistanceMm = 500.0;                    // the nominal lens's focus
constexpr double kObjectMm = 2000.0;                          // beyond it: images in front
constexpr int kSize = 200;
constexpr int kBlack = 256;
constexpr double kDark = 300, kLight = 2800;  // DN above black
const std::string kCfa = "GRBG";

double image_distance(double focal_mm, double object_mm) {
  return 1.0 / (1.0 / focal_mm - 1.0 / object_mm);
}
double lens_to_sensor_mm() { return image_distance(kNominalFocalMm, kFocusDistanceMm); }

// Blur disk diameter in px for channel c at f-number n: the cone from the aperture
// (diameter f / N of the nominal focal length) converging at z_i, cut by the sensor at z_s.
double coc_px(int c, double n) {
  const double zi = image_distance(kChannelFocalMm[c], kObjectMm), zs = lens_to_sensor_mm();
  return (kNominalFocalMm / n) * std::fabs(zs - zi) / zi / (kPitchUm * 1e-3);
}

int colour_at(int x, int y) {
  const char c = kCfa[static_cast<size_t>(2 * (y % 2) + x % 2)];
  return c == 'R' ? 0 : c == 'G' ? 1 : 2;
}

// The edge passes through the image centre, 6 degrees from vertical; light on +x.
constexpr double kAngleRad = 6.0 * std::numbers::pi / 180.0;
const double kNx = std::cos(kAngleRad), kNy = -std::sin(kAngleRad);  // unit normal
const double kCentre = (kSize - 1) / 2.0;

cv::Mat mosaic_at(double n, std::mt19937& rng) {
  std::normal_distribution<double> noise(0.0, 2.0);
  cv::Mat out(kSize, kSize, CV_16UC1);
  for (int y = 0; y < kSize; ++y)
    for (int x = 0; x < kSize; ++x) {
      const double d = (x - kCentre) * kNx + (y - kCentre) * kNy;
      const double fraction =
          testing::pixel_light_fraction(d, coc_px(colour_at(x, y), n), kNx, kNy);
      const double dn = kBlack + kDark + (kLight - kDark) * fraction + noise(rng);
      out.at<uint16_t>(y, x) = static_cast<uint16_t>(std::clamp(std::lround(dn), 0L, 4095L));
    }
  return out;
}

json truth_at(double n) {
  const double half = 70;
  auto point = [&](double along) {  // along the edge direction (-ny, nx) rotated: (kNy?...)
    return json::array({kCentre - kNy * along, kCentre + kNx * along});
  };
  json edge = {{"start", point(-half)},
               {"end", point(half)},
               {"middle", point(0)},
               {"light_side_point", json::array({kCentre + 5 * kNx, kCentre + 5 * kNy})}};
  json channels = json::object();
  const char* names[3] = {"R", "G", "B"};
  for (int c = 0; c < 3; ++c)
    channels[names[c]] = {
        {"focal_mm", kChannelFocalMm[c]},
        {"targets", {{{"name", "edge"}, {"coc_px", {{"at_origin", coc_px(c, n)}}}}}}};
  return {{"pixel_pitch_um", kPitchUm},
          {"focal_mm", kNominalFocalMm},
          {"cfa", kCfa},
          {"targets", {{{"name", "edge"}, {"distance_m", kObjectMm * 1e-3}, {"edge_px", edge}}}},
          {"channels", channels}};
}

fs::path write_aperture_series(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("camlab_colour_defocus_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto writer =
      image::CaptureFolderWriter::create(dir, "aperture_series", {{"backend", "test"}}, {});
  if (!writer) throw std::runtime_error(writer.error().message);
  std::mt19937 rng(7);
  int index = 0;
  for (double n : {2.0, 2.8, 4.0, 5.6, 8.0}) {
    image::FrameSidecar side;
    side.sequence = static_cast<uint64_t>(index++);
    side.pixel_format = "SGRBG12";
    side.layout = image::FrameLayout::kMosaic;
    side.cfa_pattern = kCfa;
    side.bit_depth = 12;
    side.black_level_dn = kBlack;
    side.settings = {{"f_number", n},
                     {"lens_to_sensor_mm", lens_to_sensor_mm()},
                     {"focus_distance_m", kFocusDistanceMm * 1e-3},
                     {"focus_position", 0}};
    side.truth = truth_at(n);
    if (auto added = writer->add_frame(mosaic_at(n, rng), side); !added)
      throw std::runtime_error(added.error().message);
  }
  if (auto done = writer->finish(); !done) throw std::runtime_error(done.error().message);
  return dir;
}

TEST(ColourDefocus, EachChannelsCtimesNMatchesItsThinLensAndTheFocusShiftIsTheLcas) {
  const fs::path dir = write_aperture_series("series");
  DefocusOptions options;
  options.baseline_sigma_px = 0;
  options.threads = 2;
  auto report = analyze_defocus(dir, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  if (std::getenv("CAMLAB_EDGE_REPORT")) std::cout << to_json(*report).dump(1) << "\n";
  ASSERT_EQ(report->channels.size(), 3u);
  EXPECT_EQ(report->sweep, "f_number");
  for (int c = 0; c < 3; ++c) {
    const DefocusReport& channel = report->channels[static_cast<size_t>(c)];
    ASSERT_EQ(channel.targets.size(), 1u) << channel.channel;
    const TargetDefocus& t = channel.targets[0];
    ASSERT_TRUE(t.aperture) << channel.channel << ": " << t.aperture_error;
    const double k_truth = coc_px(c, 1.0);
    EXPECT_NEAR(t.aperture->k_px / k_truth - 1, 0, 0.02)
        << channel.channel << " k " << t.aperture->k_px << " truth " << k_truth;
    ASSERT_TRUE(t.thin_lens_k_px);
    EXPECT_NEAR(*t.thin_lens_k_px / k_truth - 1, 0, 1e-9) << "the report's prediction";
  }
  ASSERT_EQ(report->chromatic.size(), 1u);
  const ChromaticFocusShift& lca = report->chromatic[0];
  EXPECT_EQ(lca.method, "aperture");
  EXPECT_FALSE(lca.side_assumed);
  const double zi_g = image_distance(kChannelFocalMm[1], kObjectMm);
  const double want_r = image_distance(kChannelFocalMm[0], kObjectMm) - zi_g;
  const double want_b = image_distance(kChannelFocalMm[2], kObjectMm) - zi_g;
  EXPECT_NEAR(lca.shift_r_mm / want_r - 1, 0, 0.05) << lca.shift_r_mm << " vs " << want_r;
  EXPECT_NEAR(lca.shift_b_mm / want_b - 1, 0, 0.05) << lca.shift_b_mm << " vs " << want_b;
  fs::remove_all(dir);
}

TEST(ColourDefocus, JpegCapturesAreRefusedAsNotLinear) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_colour_defocus_jpeg_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto writer = image::CaptureFolderWriter::create(dir, "single", {{"backend", "test"}}, {});
  ASSERT_TRUE(writer.ok());
  std::vector<uint8_t> jpeg;
  cv::imencode(".jpg", cv::Mat(64, 64, CV_8UC3, cv::Scalar(40, 90, 200)), jpeg);
  image::FrameSidecar side;
  side.pixel_format = side.delivered_format = "MJPG";
  side.layout = image::FrameLayout::kRgb;
  side.linear = false;
  ASSERT_TRUE(writer->add_jpeg_frame(jpeg, side).ok());
  ASSERT_TRUE(writer->finish().ok());
  for (auto code : {analyze_defocus(dir, {}).error().code, analyze_exposure(dir, {}).error().code,
                    analyze_focus(dir, {}).error().code})
    EXPECT_EQ(code, ErrorCode::kNotLinear);
  fs::remove_all(dir);
}

}  // namespace colour_defocus_test
}  // namespace
}  // namespace camlab::analysis
