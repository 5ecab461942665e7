// Photon transfer, linearity and HDR merge: on synthetic frames with a known noise model
// (exact K, read noise, clipping) and on virtual-camera exposure sweeps against the spec.
#include "analysis/exposure/exposure.h"
#include "analysis/exposure/exposure_report.h"

#include <cmath>
#include <filesystem>
#include <random>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "capture_fixture.h"
#include "mock_device/render/render_capture.h"

namespace camlab::analysis {
namespace {

// A frame of `electrons` mean per pixel: Poisson shot noise, full-well clip, Gaussian read
// noise, x K, + black, rounded and clipped to 12 bits. Values are DN including black.
cv::Mat sensor_frame(int size, double electrons, double k, double read_e, double full_well,
                     std::mt19937& rng) {
  cv::Mat m(size, size, CV_16U);
  std::poisson_distribution<int> shot(electrons);
  std::normal_distribution<double> read(0.0, read_e);
  for (int r = 0; r < size; ++r)
    for (int c = 0; c < size; ++c) {
      const double e = std::min<double>(shot(rng), full_well) + read(rng);
      m.at<uint16_t>(r, c) =
          static_cast<uint16_t>(std::clamp(std::round(e * k + 64.0), 0.0, 4095.0));
    }
  return m;
}

TEST(PhotonTransfer, RecoversGainDarkNoiseAndSaturationOnSyntheticPairs) {
  const double k = 0.25, read_e = 3.0, full_well = 12000;
  std::mt19937 rng(5);
  std::vector<PairStats> pairs;
  for (double e : {0.0, 50.0, 200.0, 800.0, 2000.0, 4000.0, 6000.0, 8000.0, 10000.0, 11800.0,
                   13000.0, 20000.0}) {
    const cv::Mat a = sensor_frame(128, e, k, read_e, full_well, rng);
    const cv::Mat b = sensor_frame(128, e, k, read_e, full_well, rng);
    auto ps = pair_stats(a, b, 64.0);
    ASSERT_TRUE(ps.ok());
    pairs.push_back(*ps);
  }
  auto pt = fit_photon_transfer(pairs);
  ASSERT_TRUE(pt.ok()) << pt.error().message;
  EXPECT_NEAR(pt->system_gain_dn_per_e / k, 1.0, 0.01);
  EXPECT_NEAR(pt->dark_noise_e, read_e, 0.3);  // the dark pair measures it
  // Saturation where the variance collapses: the well, within the sweep's resolution.
  EXPECT_GT(pt->saturation_capacity_e, 0.9 * full_well);
  EXPECT_LT(pt->saturation_capacity_e, 1.05 * full_well);
  EXPECT_NEAR(pt->snr_max, std::sqrt(pt->saturation_capacity_e), 0.02 * std::sqrt(full_well));
  EXPECT_NEAR(pt->dynamic_range, pt->saturation_capacity_e / pt->dark_noise_e, 1e-9);
  for (const PairStats& p : pt->points) {
    if (p.used) {
      EXPECT_LE(p.mean_dn, 0.7 * pt->saturation_mean_dn);
    }
  }
}

TEST(PhotonTransfer, TooFewPairsOrDarkOnlyAreErrors) {
  std::vector<PairStats> two = {{1, 1, 100, 25, 1000, false}, {2, 1, 200, 50, 1000, false}};
  EXPECT_EQ(fit_photon_transfer(two).error().code, "too_few_samples");
  std::vector<PairStats> dark = {
      {1, 1, 0, 1, 1000, false}, {2, 1, -0.1, 1, 1000, false}, {3, 1, 0, 1, 1000, false}};
  EXPECT_EQ(fit_photon_transfer(dark).error().code, "no_signal");
  const cv::Mat a(8, 8, CV_16U, cv::Scalar(5)), b(9, 8, CV_16U, cv::Scalar(5));
  EXPECT_FALSE(pair_stats(a, b, 0).ok());
}

TEST(Linearity, ExactLineReadsZeroAndADeviantPointItsError) {
  std::vector<LinearityPoint> pts;
  for (double h : {20.0, 40.0, 80.0, 120.0}) pts.push_back({h, 3.0 * h, 0, false});
  pts.push_back({160.0, 3.0 * 160.0 * 1.02, 0, false});
  pts.push_back({1000.0, 900.0, 0, false});  // saturated: above 95% of 900, not used
  auto lin = fit_linearity(pts, 900.0);
  ASSERT_TRUE(lin.ok());
  EXPECT_EQ(lin->used_count, 5);
  EXPECT_NEAR(lin->points[4].error_pct, 2.0, 0.5);
  EXPECT_LT(std::fabs(lin->points[0].error_pct), 0.5);
  EXPECT_FALSE(lin->points[5].used);
}

TEST(HdrMerge, InverseVarianceMergeIsUnbiasedAndClippedEverywhereIsFlagged) {
  // Three exposures of a ramp of radiances 0.01..100 DN/us; clip at 4000 DN.
  const int n = 200;
  const double k = 0.2, read_var = 1.0;
  std::mt19937 rng(9);
  cv::Mat truth(1, n, CV_32F);
  for (int i = 0; i < n; ++i)
    truth.at<float>(0, i) = static_cast<float>(0.01 * std::pow(1e4, i / (n - 1.0)));
  truth.at<float>(0, n - 1) = 1e5f;  // clipped in every frame
  std::vector<HdrFrame> frames;
  for (double t : {10.0, 100.0, 1000.0}) {
    HdrFrame f;
    f.exposure_us = t;
    f.clip_dn = 4000;
    f.signal_dn.create(64, n, CV_32F);
    for (int r = 0; r < 64; ++r)
      for (int i = 0; i < n; ++i) {
        const double mean = truth.at<float>(0, i) * t;
        std::normal_distribution<double> noise(0.0, std::sqrt(k * mean + read_var));
        f.signal_dn.at<float>(r, i) =
            static_cast<float>(std::min(4000.0, std::round(mean + noise(rng))));
      }
    frames.push_back(f);
  }
  auto hdr = merge_hdr(frames, {k, read_var});
  ASSERT_TRUE(hdr.ok());
  EXPECT_EQ(hdr->clipped_everywhere, 64);
  std::vector<double> errors;
  for (int r = 0; r < 64; ++r) {
    for (int i = 0; i < n; ++i) {
      const float v = hdr->radiance.at<float>(r, i);
      ASSERT_TRUE(std::isfinite(v));
      if (i == n - 1) {
        EXPECT_EQ(hdr->clipped.at<uint8_t>(r, i), 255);
        EXPECT_NEAR(v, 4000.0 / 10.0, 1e-3);  // the bound from the shortest frame
        continue;
      }
      EXPECT_EQ(hdr->clipped.at<uint8_t>(r, i), 0);
      if (truth.at<float>(0, i) > 0.5) errors.push_back(v / truth.at<float>(0, i) - 1.0);
    }
  }
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(std::fabs(errors[errors.size() / 2]), 0.003);  // median: unbiased
  EXPECT_FALSE(merge_hdr({}, {k, read_var}).ok());
}

// The virtual camera: f = 8 mm, 4 um, 12 bits, black 64, full well 20000 e-, read 2 e-.
nlohmann::json camera_json(int size) {
  return {
      {"name", "exposure test"},
      {"sensor",
       {{"width_px", size},
        {"height_px", size},
        {"pixel_pitch_um", 4.0},
        {"bit_depth", 12},
        {"black_level_dn", 64},
        {"full_well_e", 20000},
        {"read_noise_e", 2.0},
        {"quantum_efficiency", 0.6}}},
      {"lens", {{"focal_mm", 8.0}, {"model", "LENSMODEL_PINHOLE"}}},
      {"timing", {{"frame_interval_us", 100000}}},
      {"controls", {{"exposure_time_absolute", {{"min", 1}, {"max", 1000}, {"default", 100}}}}}};
}

TEST(ExposureCapture, PhotonTransferMatchesTheSpecAndSignalIsLinear) {
  auto renderer =
      testing::make_renderer(camera_json(160), {{"illuminance_lux", 1000},
                                                {"background_reflectance", 0.5},
                                                {"targets",
                                                 {{{"type", "uniform"},
                                                   {"size_m", {10.0, 10.0}},
                                                   {"light_reflectance", 0.5},
                                                   {"pose", {{"position_m", {0.0, 0.0, 1.0}}}}}}}});
  const auto dir = testing::fresh_dir("ptc");
  mock::RenderCaptureRequest req;
  req.out_dir = dir;
  req.base = renderer.default_settings();
  req.base.f_number = 4.0;
  req.sweep = mock::Sweep{"exposure_us",
                          {100, 300, 1000, 3000, 6000, 10000, 15000, 20000, 30000, 40000, 50000,
                           60000, 70000, 80000, 100000}};
  req.repeats = 2;
  req.options.seed = 21;
  ASSERT_TRUE(mock::render_capture(renderer, req).ok());
  ExposureOptions o;
  o.roi_fraction = 1.0;
  auto report = analyze_exposure(dir, o);
  ASSERT_TRUE(report.ok()) << report.error().message;
  ASSERT_TRUE(report->photon_transfer.has_value()) << report->photon_transfer_error;
  const PhotonTransfer& pt = *report->photon_transfer;
  const double k_spec = (4095.0 - 64.0) / 20000.0;
  EXPECT_NEAR(pt.expected_gain_dn_per_e, k_spec, 1e-12);
  EXPECT_NEAR(pt.system_gain_dn_per_e / k_spec, 1.0, 0.01);
  EXPECT_NEAR(pt.dark_noise_e, 2.0, 0.6);
  EXPECT_NEAR(pt.saturation_capacity_e / 20000.0, 1.0, 0.1);
  EXPECT_GE(report->linearity_used, 5);
  EXPECT_LT(report->max_linearity_error_pct, 0.5);  // the virtual sensor is linear
  ASSERT_TRUE(report->hdr.has_value()) << report->hdr_error;
  EXPECT_EQ(report->hdr->clipped_everywhere, 0);
  // The merged radiance against the truth: reflectance 0.5 x electrons per unit
  // reflectance per us x K.
  image::CaptureFolder folder = *image::CaptureFolder::open(dir);
  auto side = folder.load_sidecar(0);
  ASSERT_TRUE(side.ok());
  const double truth_dn_per_us = 0.5 * side->truth["electrons_per_unit_reflectance"].get<double>() /
                                 side->settings["exposure_us"].get<double>() * k_spec;
  cv::Mat rel = report->hdr->radiance / truth_dn_per_us - 1.0;
  std::vector<float> v(rel.begin<float>(), rel.end<float>());
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  EXPECT_LT(std::fabs(v[v.size() / 2]), 0.03);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace camlab::analysis
