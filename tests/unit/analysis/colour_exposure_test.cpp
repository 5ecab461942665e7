// Exposure analysis of a Bayer capture, per channel, on flat fields drawn here with the
// photon-transfer model written out independently of camlab's renderer: each site
// collects Poisson electrons at its colour's rate, plus Gaussian read noise, times the
// conversion gain K, plus black, rounded and clipped to 12 bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <string>

#include "analysis/exposure/exposure_report.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {
// Named too: the test files of an executable share a unity build's translation unit.
namespace colour_exposure_test {

namespace fs = std::filesystem;

constexpr double kGainDnPerE = 0.25;
constexpr double kReadNoiseE = 3.0;
constexpr int kBlack = 64;
constexpr double kElectronsPerUs[3] = {20.0, 30.0, 12.0};  // R, G, B: QE x photon rate
const std::string kCfa = "BGGR";

int colour_at(int x, int y) {
  const char c = kCfa[static_cast<size_t>(2 * (y % 2) + x % 2)];
  return c == 'R' ? 0 : c == 'G' ? 1 : 2;
}

cv::Mat flat_field(double exposure_us, std::mt19937& rng) {
  cv::Mat out(256, 256, CV_16UC1);
  std::normal_distribution<double> read(0.0, kReadNoiseE);
  for (int y = 0; y < out.rows; ++y)
    for (int x = 0; x < out.cols; ++x) {
      std::poisson_distribution<int> photo(kElectronsPerUs[colour_at(x, y)] * exposure_us);
      const double dn = kBlack + kGainDnPerE * (photo(rng) + read(rng));
      out.at<uint16_t>(y, x) = static_cast<uint16_t>(std::clamp(std::lround(dn), 0L, 4095L));
    }
  return out;
}

TEST(ColourExposure, EachChannelGivesTheConversionGainAndItsOwnSlope) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_colour_exposure_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  auto writer = image::CaptureFolderWriter::create(dir, "bracket", {{"backend", "test"}}, {});
  ASSERT_TRUE(writer.ok());
  std::mt19937 rng(11);
  uint64_t sequence = 0;
  for (double t : {5.0, 10.0, 20.0, 40.0, 60.0, 80.0, 100.0, 120.0})
    for (int repeat = 0; repeat < 2; ++repeat) {
      image::FrameSidecar side;
      side.sequence = sequence++;
      side.pixel_format = "SBGGR12";
      side.layout = image::FrameLayout::kMosaic;
      side.cfa_pattern = kCfa;
      side.bit_depth = 12;
      side.black_level_dn = kBlack;
      side.settings = {{"exposure_us", t}, {"gain", 1.0}};
      ASSERT_TRUE(writer->add_frame(flat_field(t, rng), side).ok());
    }
  ASSERT_TRUE(writer->finish().ok());

  auto report = analyze_exposure(dir, {});
  ASSERT_TRUE(report.ok()) << report.error().message;
  if (std::getenv("CAMLAB_EDGE_REPORT")) std::cout << to_json(*report).dump(1) << "\n";
  ASSERT_EQ(report->channels.size(), 3u);
  for (int c = 0; c < 3; ++c) {
    const ExposureReport& one = report->channels[static_cast<size_t>(c)];
    EXPECT_EQ(one.channel, std::string(1, "RGB"[c]));
    ASSERT_TRUE(one.photon_transfer) << one.channel << ": " << one.photon_transfer_error;
    EXPECT_NEAR(one.photon_transfer->system_gain_dn_per_e / kGainDnPerE - 1, 0, 0.04)
        << one.channel;
    EXPECT_NEAR(one.photon_transfer->dark_noise_e / kReadNoiseE - 1, 0, 0.25) << one.channel;
    EXPECT_NEAR(one.linearity_slope_dn_per_us / (kGainDnPerE * kElectronsPerUs[c]) - 1, 0, 0.01)
        << one.channel;
  }
  const auto json = to_json(*report);
  EXPECT_TRUE(json["channels"].contains("G"));
  fs::remove_all(dir);
}

}  // namespace colour_exposure_test
}  // namespace
}  // namespace camlab::analysis
