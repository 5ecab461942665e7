// From mean reflectance seen by each pixel to raw sensor DN: radiometry, photon shot
// noise, full-well clipping, read noise, gain, black level, quantisation, saturation.
//
// Reentrant.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

// Photons per second per square metre in 1 lux of 555 nm light: 1 lux = 1/683 W/m^2,
// and a 555 nm photon carries h c / lambda = 3.579e-19 J.
inline constexpr double kPhotonsPerLuxSecondM2 = 4.0906e15;

// Mean electrons a pixel collects per unit reflectance under `illuminance_lux`:
// QE x photon flux x pixel area x time, with sensor irradiance
// E = reflectance x illuminance x (f / z_s)^2 / (4 N^2).
double electrons_per_unit_reflectance(const CameraSpec& camera, double illuminance_lux,
                                      double exposure_us, double f_number,
                                      double lens_to_sensor_mm);

// Converts a CV_32F image of mean reflectance to DN (CV_8U for 8-bit sensors, else
// CV_16U). `gain` is linear. With noise off the expected signal is rounded. The result
// does not depend on `threads`: each pixel's draws are a hash of the seed and its index
// (noise_sampler.h).
cv::Mat expose(const cv::Mat& mean_reflectance, const CameraSpec& camera,
               double electrons_per_reflectance, double gain, bool noise, uint64_t seed,
               int threads);

}  // namespace camlab::mock
