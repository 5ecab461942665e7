#include "mock_device/render/sensor_model.h"

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "mock_device/render/noise_sampler.h"
#include "mock_device/render/sampling.h"

namespace camlab::mock {

double electrons_per_unit_reflectance(const CameraSpec& camera, double illuminance_lux,
                                      double exposure_us, double f_number,
                                      double lens_to_sensor_mm) {
  const double magnification_loss = camera.lens.focal_mm / lens_to_sensor_mm;
  const double sensor_lux =
      illuminance_lux * magnification_loss * magnification_loss / (4.0 * f_number * f_number);
  const double pitch_m = camera.sensor.pixel_pitch_um * 1e-6;
  return camera.sensor.quantum_efficiency * sensor_lux * kPhotonsPerLuxSecondM2 * pitch_m *
         pitch_m * exposure_us * 1e-6;
}

cv::Mat expose(const cv::Mat& mean_reflectance, const CameraSpec& camera,
               double electrons_per_reflectance, double gain, bool noise, uint64_t seed,
               int threads) {
  const SensorSpec& s = camera.sensor;
  const int max_dn = (1 << s.bit_depth) - 1;
  const double dn_per_e = s.conversion_gain_dn_per_e * gain;
  const bool shot = noise && s.shot_noise;
  const bool read = noise && s.read_noise_e > 0;
  // Shot and read noise draw from their own keys; a pixel's counters are its index in
  // the frame (noise_sampler.h), so the frame does not depend on how rows are split.
  const uint64_t shot_key = mix_seed(seed, 1), read_key = mix_seed(seed, 2);
  // A mean this far above the full well fills it whatever the draw (the Poisson tail
  // below it is under 1e-20): no draw needed, and no overflow for absurd exposures.
  const double certain_full_e = s.full_well_e + 10 * std::sqrt(s.full_well_e) + 100;
  cv::Mat out(mean_reflectance.size(), s.bit_depth <= 8 ? CV_8UC1 : CV_16UC1);

  // A row at a time: electrons, then the row's shot and read deviates in one pass each
  // (noise::poisson_row), then DN; typed output so that no pixel tests the format.
  struct RowBuffers {
    std::vector<double> electrons, read_e;
    std::vector<int64_t> shot_e;
    std::vector<uint8_t> scratch;
  };
  auto expose_row = [&]<typename Pixel>(int y, Pixel* row, RowBuffers& b) {
    const int width = mean_reflectance.cols;
    const float* in = mean_reflectance.ptr<float>(y);
    const uint64_t row_start = static_cast<uint64_t>(y) * static_cast<uint64_t>(width);
    double* electrons = b.electrons.data();
    for (int x = 0; x < width; ++x)
      electrons[x] = std::max(0.0, static_cast<double>(in[x])) * electrons_per_reflectance;
    if (shot) {
      // Means at or above certain_full_e draw nothing: 0 in the row pass, then the full well.
      double* means = b.read_e.data();  // borrowed until the read noise needs it
      for (int x = 0; x < width; ++x) means[x] = electrons[x] < certain_full_e ? electrons[x] : 0;
      noise::poisson_row(means, b.shot_e.data(), width, shot_key, row_start, b.scratch);
      for (int x = 0; x < width; ++x)
        electrons[x] =
            electrons[x] < certain_full_e ? static_cast<double>(b.shot_e[x]) : s.full_well_e;
    }
    if (read) noise::standard_normal_row(b.read_e.data(), width, read_key, row_start, b.scratch);
    for (int x = 0; x < width; ++x) {
      // The well saturates before the ADC; read noise is added after it.
      double e = std::min(electrons[x], s.full_well_e);
      if (read) e += s.read_noise_e * b.read_e[x];
      // Rounded half up and clipped to the ADC's range (a cast, not std::round: the
      // library call cost a sixth of the frame).
      const double level = s.black_level_dn + e * dn_per_e;
      row[x] = static_cast<Pixel>(level <= 0        ? 0
                                  : level >= max_dn ? max_dn
                                                    : static_cast<int>(level + 0.5));
    }
  };
  auto expose_rows = [&](int first_row, int row_step) {
    RowBuffers buffers;
    const size_t width = static_cast<size_t>(mean_reflectance.cols);
    buffers.electrons.resize(width);
    buffers.read_e.resize(width);
    buffers.shot_e.resize(width);
    for (int y = first_row; y < mean_reflectance.rows; y += row_step) {
      if (out.depth() == CV_8U)
        expose_row(y, out.ptr<uint8_t>(y), buffers);
      else
        expose_row(y, out.ptr<uint16_t>(y), buffers);
    }
  };
  threads = std::max(1, threads);
  std::vector<std::thread> workers;
  for (int t = 1; t < threads; ++t) workers.emplace_back(expose_rows, t, threads);
  expose_rows(0, threads);
  for (auto& w : workers) w.join();
  return out;
}

}  // namespace camlab::mock
