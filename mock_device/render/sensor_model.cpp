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

  auto expose_rows = [&](int first_row, int row_step) {
    noise::PoissonLaw law;  // kept while neighbouring pixels see the same mean
    for (int y = first_row; y < mean_reflectance.rows; y += row_step) {
      const float* in = mean_reflectance.ptr<float>(y);
      const uint64_t row_start = static_cast<uint64_t>(y) * mean_reflectance.cols;
      for (int x = 0; x < mean_reflectance.cols; ++x) {
        const uint64_t pixel = row_start + static_cast<uint64_t>(x);
        double electrons = std::max(0.0, static_cast<double>(in[x])) * electrons_per_reflectance;
        if (shot && electrons > 0) {
          if (electrons >= certain_full_e) {
            electrons = s.full_well_e;
          } else {
            if (electrons != law.mean()) law = noise::PoissonLaw(electrons);
            electrons = static_cast<double>(law.draw(shot_key, pixel));
          }
        }
        electrons = std::min(electrons, s.full_well_e);  // the well saturates before the ADC
        if (read) electrons += s.read_noise_e * noise::standard_normal(read_key, pixel);
        // Rounded half up and clipped to the ADC's range (a cast, not std::round: the
        // library call cost a sixth of the frame).
        const double level = s.black_level_dn + electrons * dn_per_e;
        const int dn = level <= 0 ? 0 : level >= max_dn ? max_dn : static_cast<int>(level + 0.5);
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

}  // namespace camlab::mock
