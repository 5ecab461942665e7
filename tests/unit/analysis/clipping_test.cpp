// A sensor whose full well is reached below the ADC's top code, on data drawn here with
// the physics written out (Poisson electrons, the full well capping them, read noise
// after the cap, conversion gain, black level, 12-bit ADC whose top code is never
// reached): edges that touch the full well are flagged `clipped` rather than read low,
// C x N comes from the unclipped frames, and the HDR merge leaves clipped pixels out.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <stdexcept>
#include <string>
#include <vector>

#include "analysis/analyze_folder.h"
#include "analysis/clip_level.h"
#include "analysis/defocus/defocus_report.h"
#include "analysis/exposure/exposure_report.h"
#include "analytic_edge.h"
#include "image/capture_folder.h"

namespace camlab::analysis {
namespace {

namespace fs = std::filesystem;

constexpr double kFullWellE = 10000, kReadNoiseE = 3, kGainDnPerE = 0.3;
constexpr int kBlack = 64;  // full well = 3064 DN, the ADC's top code 4095

struct Sensor {
  std::mt19937 rng{5};
  uint16_t dn(double mean_electrons) {
    std::poisson_distribution<long> photo(std::max(mean_electrons, 0.0));
    std::normal_distribution<double> read(0, kReadNoiseE);
    const double e = std::min<double>(static_cast<double>(photo(rng)), kFullWellE) + read(rng);
    return static_cast<uint16_t>(std::clamp(std::lround(kBlack + kGainDnPerE * e), 0L, 4095L));
  }
};

fs::path fresh(const std::string& name) {
  const fs::path dir =
      fs::temp_directory_path() / ("camlab_clip_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  return dir;
}

image::FrameSidecar sidecar(uint64_t sequence, nlohmann::json settings) {
  image::FrameSidecar side;
  side.sequence = sequence;
  side.pixel_format = "Y12";
  side.bit_depth = 12;
  side.black_level_dn = kBlack;  // white_level_dn: 4095, the format's (the sensor clips lower)
  side.settings = std::move(settings);
  return side;
}

// An aperture series of one slanted edge: f/2 puts the light side over the full well.
constexpr double kEdgeKPx = 40.0;  // C x N, px
const std::vector<double> kFNumbers = {2.0, 2.8, 4.0, 5.6, 8.0};

fs::path write_edge_series(const std::string& name, bool finish) {
  const int size = 160;
  const double k_px = kEdgeKPx;
  const double angle = 5.0 * std::numbers::pi / 180.0, nx = std::cos(angle), ny = -std::sin(angle);
  const double centre = (size - 1) / 2.0;
  const fs::path dir = fresh(name);
  auto writer =
      image::CaptureFolderWriter::create(dir, "aperture_series", {{"backend", "test"}}, {});
  if (!writer) throw std::runtime_error(writer.error().message);
  Sensor sensor;
  const double light_e_at_f2 = 16000, dark_e_at_f2 = 1000;  // f/2: light side 1.6 full wells
  for (size_t k = 0; k < kFNumbers.size(); ++k) {
    const double n = kFNumbers[k], scale = 4.0 / (n * n);
    cv::Mat frame(size, size, CV_16UC1);
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const double d = (x - centre) * nx + (y - centre) * ny;
        const double f = testing::pixel_light_fraction(d, k_px / n, nx, ny, 8);
        frame.at<uint16_t>(y, x) =
            sensor.dn(scale * (dark_e_at_f2 + (light_e_at_f2 - dark_e_at_f2) * f));
      }
    const double half = 60;
    auto point = [&](double along) {
      return nlohmann::json::array({centre - ny * along, centre + nx * along});
    };
    image::FrameSidecar side = sidecar(k, {{"f_number", n}, {"focus_position", 0}});
    side.truth = {{"targets",
                   {{{"name", "edge"},
                     {"edge_px",
                      {{"start", point(-half)},
                       {"end", point(half)},
                       {"middle", point(0)},
                       {"light_side_point", {centre + 5 * nx, centre + 5 * ny}}}}}}}};
    if (auto added = writer->add_frame(frame, side); !added)
      throw std::runtime_error(added.error().message);
  }
  if (finish) (void)writer->finish();
  return dir;
}

TEST(Clipping, EdgesAtTheFullWellAreFlaggedAndCtimesNComesFromTheOthers) {
  const fs::path dir = write_edge_series("edges", true);

  DefocusOptions options;
  options.baseline_sigma_px = 0;
  auto report = analyze_defocus(dir, options);
  ASSERT_TRUE(report.ok()) << report.error().message;
  if (std::getenv("CAMLAB_EDGE_REPORT")) std::cout << to_json(*report).dump(1) << "\n";
  ASSERT_TRUE(report->clip_level_dn) << "the full well shows in the f/2 frame's histogram";
  EXPECT_NEAR(*report->clip_level_dn, kBlack + kGainDnPerE * kFullWellE, 15);
  ASSERT_EQ(report->targets.size(), 1u);
  const TargetDefocus& t = report->targets[0];
  EXPECT_EQ(t.frames[0].edge.status, kEdgeClipped) << "f/2: the light side is at the full well";
  for (size_t k = 1; k < t.frames.size(); ++k)
    EXPECT_EQ(t.frames[k].edge.status, kEdgeOk) << "f/" << kFNumbers[k];
  ASSERT_TRUE(t.aperture) << t.aperture_error;
  EXPECT_NEAR(t.aperture->k_px / kEdgeKPx - 1, 0, 0.01) << t.aperture->k_px;
  // The report ties each edge to the scene and gives a rejected edge no diameter.
  const auto json = to_json(*report);
  const auto& f2 = json["targets"][0]["frames"][0];
  EXPECT_TRUE(f2["diameter_px"].is_null()) << f2.dump();
  EXPECT_TRUE(f2["ci95_px"].is_null());
  // f/4 (measured): the drawn edge runs along (sin 5 deg, cos 5 deg), 85 degrees from +x
  // as a line, through the centre.
  const auto& f4 = json["targets"][0]["frames"][2];
  EXPECT_NEAR(std::fmod(f4["edge_px"]["angle_deg"].get<double>() + 360.0, 180.0), 85.0, 0.2);
  const double angle = 5.0 * std::numbers::pi / 180.0, centre = 79.5;
  const double off_line = (f4["edge_px"]["x"].get<double>() - centre) * std::cos(angle) -
                          (f4["edge_px"]["y"].get<double>() - centre) * std::sin(angle);
  EXPECT_LT(std::fabs(off_line), 0.5) << "the reported point lies on the drawn edge";
  fs::remove_all(dir);
}

// An exposure bracket of a radiance ramp whose bright end fills the full well at the
// longer exposures: the merge must leave those pixels out, not average them in.
// A bracket of a horizontal ramp, two frames per exposure: column x receives
// rate(x) electrons per us (rows alike), drawn through `Sensor`. Returns the folder.
template <typename Rate>
fs::path write_ramp_bracket(const std::string& name, int width, int height, Rate rate,
                            const std::vector<double>& exposures_us) {
  const fs::path dir = fresh(name);
  auto writer = image::CaptureFolderWriter::create(dir, "bracket", {{"backend", "test"}}, {});
  if (!writer) throw std::runtime_error(writer.error().message);
  Sensor sensor;
  uint64_t sequence = 0;
  for (double t : exposures_us)
    for (int repeat = 0; repeat < 2; ++repeat) {
      cv::Mat frame(height, width, CV_16UC1);
      for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x) frame.at<uint16_t>(y, x) = sensor.dn(rate(x) * t);
      auto added =
          writer->add_frame(frame, sidecar(sequence++, {{"exposure_us", t}, {"gain", 1.0}}));
      if (!added) throw std::runtime_error(added.error().message);
    }
  if (auto done = writer->finish(); !done) throw std::runtime_error(done.error().message);
  return dir;
}

TEST(Clipping, HdrLeavesPixelsAtTheFullWellOutAndStaysWithinThreePercent) {
  const int width = 256, height = 32;
  // Electrons per us, log-spaced from 20 to 20000 across the frame.
  auto rate = [&](int x) { return 20.0 * std::pow(1000.0, x / (width - 1.0)); };
  const fs::path dir =
      write_ramp_bracket("hdr", width, height, rate, {0.4, 1.0, 2.5, 6.0, 15.0, 40.0});
  auto report = analyze_exposure(dir, {});
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_TRUE(report->hdr) << report->hdr_error;
  std::vector<double> errors;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      if (report->hdr->clipped.at<uint8_t>(y, x)) continue;
      const double truth = kGainDnPerE * rate(x);  // DN per us at unity gain
      errors.push_back(std::fabs(report->hdr->radiance.at<float>(y, x) / truth - 1));
    }
  ASSERT_GT(errors.size(), 0.9 * width * height)
      << "the brightest pixels fit the shortest exposure";
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  const double median = errors[errors.size() / 2];
  if (std::getenv("CAMLAB_EDGE_REPORT"))
    std::cout << "HDR median relative error " << median << "\n";
  EXPECT_LT(median, 0.03);
  fs::remove_all(dir);
}

// Issue 15's first case for HDR: part of the scene so bright that even the shortest
// exposure fills the full well (75% of the ADC's range, so no frame reaches the top code).
// Every pixel clipped in every frame is flagged, and the others merge within 3%.
TEST(Clipping, HdrFlagsEveryPixelAtTheFullWellInEveryFrame) {
  const int width = 256, height = 26;
  // Electrons per us, log-spaced from 20 to 80000 across the frame: at 0.4 us the
  // brightest 16% of the columns (over 25000 e-/us) still exceed the full well.
  auto rate = [&](int x) { return 20.0 * std::pow(4000.0, x / (width - 1.0)); };
  const std::vector<double> exposures_us = {0.4, 1.0, 2.5, 6.0, 15.0, 40.0};
  const fs::path dir = write_ramp_bracket("hdr_always", width, height, rate, exposures_us);
  auto report = analyze_exposure(dir, {});
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_TRUE(report->hdr) << report->hdr_error;
  int always = 0, flagged = 0;
  std::vector<double> errors;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const bool clipped = report->hdr->clipped.at<uint8_t>(y, x) != 0;
      // Saturated in every frame: 4 sigma of shot noise over the full well at the shortest
      // exposure. Pixels near the full well there may or may not be flagged.
      const double e_shortest = rate(x) * exposures_us.front();
      if (e_shortest > kFullWellE + 4 * std::sqrt(kFullWellE)) {
        ++always;
        flagged += clipped ? 1 : 0;
      }
      if (clipped || e_shortest > 0.9 * kFullWellE) continue;
      const double truth = kGainDnPerE * rate(x);
      errors.push_back(std::fabs(report->hdr->radiance.at<float>(y, x) / truth - 1));
    }
  ASSERT_GT(always, 0.1 * width * height);
  EXPECT_EQ(flagged, always) << "of the pixels at the full well in every frame";
  ASSERT_GT(errors.size(), 0.7 * width * height);
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.03);
  EXPECT_GE(report->hdr->clipped_everywhere, always);
  fs::remove_all(dir);
}

// Doubling exposures of a flat field: the pair of largest variance (8000 e-) lies a step
// below the full well, so EMVA's saturation point alone reads the capacity 20% low and the
// linearity fit (5-95% of saturation) drops that last unclipped setting.
TEST(Clipping, DoublingExposuresGiveTheFullWellAndKeepTheLastUnclippedSetting) {
  const fs::path dir = fresh("doubling");
  auto writer = image::CaptureFolderWriter::create(dir, "bracket", {{"backend", "test"}}, {});
  ASSERT_TRUE(writer.ok());
  Sensor sensor;
  uint64_t sequence = 0;
  for (double t : {1.0, 2.0, 4.0, 8.0, 16.0, 32.0, 64.0})
    for (int repeat = 0; repeat < 2; ++repeat) {
      cv::Mat frame(128, 128, CV_16UC1);
      for (int y = 0; y < 128; ++y)
        for (int x = 0; x < 128; ++x) frame.at<uint16_t>(y, x) = sensor.dn(250.0 * t);
      ASSERT_TRUE(
          writer->add_frame(frame, sidecar(sequence++, {{"exposure_us", t}, {"gain", 1.0}})).ok());
    }
  ASSERT_TRUE(writer->finish().ok());
  auto report = analyze_exposure(dir, {});
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_TRUE(report->photon_transfer) << report->photon_transfer_error;
  EXPECT_NEAR(report->photon_transfer->saturation_capacity_e / kFullWellE - 1, 0, 0.03)
      << report->photon_transfer->saturation_capacity_e;
  EXPECT_NEAR(report->photon_transfer->system_gain_dn_per_e / kGainDnPerE - 1, 0, 0.03);
  bool last_unclipped_used = false;
  for (const auto& p : report->linearity)
    if (std::fabs(p.exposure_gain_us - 32.0) < 1e-9) last_unclipped_used = p.used;
  EXPECT_TRUE(last_unclipped_used) << "8000 e- is 80% of the full well";
  EXPECT_LT(report->max_linearity_error_pct, 1.0);
  fs::remove_all(dir);
}

// A doubling bracket of a scene with a dark and a bright half (100 and 800 e-/us), as the
// README's bracket of slanted edges: at 16 us the bright half fills the full well while
// the dark half does not. Before, that setting stayed in the fits and read K 56% low with a
// tight error bar. It must be left out and named, K within 2%, linearity within 0.5% on the
// settings kept; a bracket that stops at 4 us never reaches saturation and gives a bound.
fs::path write_half_bright_bracket(const std::string& name, const std::vector<double>& times_us) {
  const fs::path dir = fresh(name);
  auto writer = image::CaptureFolderWriter::create(dir, "bracket", {{"backend", "test"}}, {});
  if (!writer) throw std::runtime_error(writer.error().message);
  Sensor sensor;
  uint64_t sequence = 0;
  for (double t : times_us)
    for (int repeat = 0; repeat < 2; ++repeat) {
      // 512 x 256: the central ROI's 32,768 pixels put a pair's variance within 0.8% (1 sd).
      cv::Mat frame(256, 512, CV_16UC1);
      for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 512; ++x)
          frame.at<uint16_t>(y, x) = sensor.dn((x < 256 ? 100 : 800) * t);
      if (auto added =
              writer->add_frame(frame, sidecar(sequence++, {{"exposure_us", t}, {"gain", 1.0}}));
          !added)
        throw std::runtime_error(added.error().message);
    }
  if (auto done = writer->finish(); !done) throw std::runtime_error(done.error().message);
  return dir;
}

TEST(Clipping, ASettingClippedInPartOfTheFrameIsLeftOutAndNamed) {
  const fs::path dir = write_half_bright_bracket("half_bright", {1, 2, 4, 8, 16});
  auto report = analyze_exposure(dir, {});
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_TRUE(report->photon_transfer) << report->photon_transfer_error;
  const PhotonTransfer& pt = *report->photon_transfer;
  EXPECT_NEAR(pt.system_gain_dn_per_e / kGainDnPerE - 1, 0, 0.02) << pt.system_gain_dn_per_e;
  EXPECT_TRUE(pt.saturation_reached);
  EXPECT_NEAR(pt.saturation_capacity_e / kFullWellE - 1, 0, 0.03) << pt.saturation_capacity_e;
  for (const PairStats& p : pt.points) {
    EXPECT_EQ(p.saturated, p.exposure_us == 16) << p.exposure_us << " us";
    if (p.saturated) {
      EXPECT_FALSE(p.used);
    }
  }
  for (const LinearityPoint& p : report->linearity) {
    if (p.used) {
      EXPECT_LT(std::fabs(p.error_pct), 0.5) << p.exposure_gain_us << " us";
    }
  }
  EXPECT_LT(report->max_linearity_error_pct, 0.5);
  bool named = false;
  for (const std::string& why : report->left_out)
    named |= why.rfind("16 us", 0) == 0 && why.find("saturated") != std::string::npos;
  EXPECT_TRUE(named) << to_json(*report)["left_out"].dump();
  fs::remove_all(dir);
}

TEST(Clipping, ABracketThatNeverSaturatesGivesOnlyABoundOnTheCapacity) {
  const fs::path dir = write_half_bright_bracket("unsaturated", {1, 2, 4});
  auto report = analyze_exposure(dir, {});
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_TRUE(report->photon_transfer) << report->photon_transfer_error;
  EXPECT_FALSE(report->photon_transfer->saturation_reached);
  EXPECT_NEAR(report->photon_transfer->system_gain_dn_per_e / kGainDnPerE - 1, 0, 0.02);
  EXPECT_EQ(report->photon_transfer->used_count, 3) << "no saturation: no pair above 70% of it";
  const nlohmann::json json = to_json(*report);
  EXPECT_TRUE(json["photon_transfer"]["saturation_capacity_e"].is_null()) << json.dump();
  const double bound = json["photon_transfer"]["saturation_capacity_lower_bound_e"];
  EXPECT_LT(bound, kFullWellE) << "a bound below the full well it never reached";
  EXPECT_EQ(report->linearity_used, 3);
  fs::remove_all(dir);
}

TEST(Clipping, AnIncompleteCaptureIsReadWithAWarning) {
  const fs::path dir = write_edge_series("incomplete", false);
  AnalyzeOptions options;
  options.defocus.baseline_sigma_px = 0;
  auto run = analyze("defocus", dir, options);
  ASSERT_TRUE(run.ok()) << run.error().message;
  ASSERT_TRUE(run->report.contains("warnings"));
  EXPECT_NE(run->report["warnings"][0].get<std::string>().find("incomplete"), std::string::npos);
  EXPECT_EQ(run->text.rfind("warning: ", 0), 0u) << run->text.substr(0, 80);
  fs::remove_all(dir);
}

TEST(ClipLevel, AFlatBrightAreaWithShotNoiseIsNotAClip) {
  Sensor sensor;
  cv::Mat frame(100, 100, CV_16UC1);
  for (int y = 0; y < 100; ++y)
    for (int x = 0; x < 100; ++x) frame.at<uint16_t>(y, x) = sensor.dn(x < 50 ? 600 : 9000);
  EXPECT_FALSE(detect_clip_plateau(frame, kBlack)) << "9000 e-, below the full well";
  for (int y = 0; y < 100; ++y)
    for (int x = 50; x < 100; ++x) frame.at<uint16_t>(y, x) = sensor.dn(20000);
  auto plateau = detect_clip_plateau(frame, kBlack);
  ASSERT_TRUE(plateau);
  EXPECT_NEAR(plateau->fraction, 0.5, 0.05);
}

}  // namespace
}  // namespace camlab::analysis
