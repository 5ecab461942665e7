// The sensor model's noise as it was before the counter-based samplers
// (mock_device/render/sensor_model.cpp, 2026-11-24): one SplitMix64 stream per row, and a
// std::poisson_distribution (or std::normal_distribution above 1e4 e-) constructed for
// every pixel. Kept only so render_bench can time the current samplers against it in the
// same run (docs/measuring.md: compare two methods as a ratio measured in the same run).
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <random>
#include <thread>
#include <vector>

#include <opencv2/core.hpp>

#include "mock_device/render/sampling.h"
#include "mock_device/spec/camera_spec.h"

namespace camlab::bench::previous {

inline cv::Mat expose(const cv::Mat& mean_reflectance, const mock::CameraSpec& camera,
                      double electrons_per_reflectance, double gain, bool noise, uint64_t seed,
                      int threads) {
  const mock::SensorSpec& s = camera.sensor;
  const int max_dn = (1 << s.bit_depth) - 1;
  const double dn_per_e = s.conversion_gain_dn_per_e * gain;
  const bool shot = noise && s.shot_noise;
  const bool read = noise && s.read_noise_e > 0;
  cv::Mat out(mean_reflectance.size(), s.bit_depth <= 8 ? CV_8UC1 : CV_16UC1);
  auto expose_rows = [&](int first_row, int row_step) {
    for (int y = first_row; y < mean_reflectance.rows; y += row_step) {
      mock::SplitMix64 rng(mock::mix_seed(seed, static_cast<uint64_t>(y) + 1));
      std::normal_distribution<double> read_noise(0.0, s.read_noise_e);
      const float* in = mean_reflectance.ptr<float>(y);
      for (int x = 0; x < mean_reflectance.cols; ++x) {
        double electrons = std::max(0.0, static_cast<double>(in[x])) * electrons_per_reflectance;
        if (shot && electrons > 0) {
          if (electrons < 1e4) {
            std::poisson_distribution<long> poisson(electrons);
            electrons = static_cast<double>(poisson(rng));
          } else {
            std::normal_distribution<double> gauss(electrons, std::sqrt(electrons));
            electrons = std::max(0.0, gauss(rng));
          }
        }
        electrons = std::min(electrons, s.full_well_e);
        if (read) electrons += read_noise(rng);
        const double dn = std::clamp(std::round(s.black_level_dn + electrons * dn_per_e), 0.0,
                                     static_cast<double>(max_dn));
        if (out.depth() == CV_8U)
          out.ptr<uint8_t>(y)[x] = static_cast<uint8_t>(dn);
        else
          out.ptr<uint16_t>(y)[x] = static_cast<uint16_t>(dn);
      }
    }
  };
  threads = std::max(1, threads);
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t) workers.emplace_back(expose_rows, t, threads);
  expose_rows(0, threads);
  for (auto& w : workers) w.join();
  return out;
}

}  // namespace camlab::bench::previous
