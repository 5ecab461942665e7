// The inner loop of the renderer: mean reflectance seen by each pixel, integrated over
// the pixel's area and (when the lens is sampled) over the aperture disk.
//
// Reentrant: reads only its arguments.
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core.hpp>

#include "mock_device/render/chief_ray_table.h"
#include "mock_device/render/target_surface.h"

namespace camlab::mock {

struct IntegratorSetup {
  const ChiefRayTable* rays = nullptr;
  const std::vector<TargetSurface>* surfaces = nullptr;
  double background_reflectance = 0;
  double aperture_radius_m = 0;  // A / 2
  double focus_distance_m = 0;   // plane of focus; infinity allowed
  int lens_grid = 0;             // k: k x k stratified lens samples; 0 = pinhole
  int pixel_grid = 4;            // m: m x m area samples when the lens is not sampled
  uint64_t seed = 0;
  int threads = 1;
};

// Returns a CV_32F image (height x width of the ray table) of mean reflectance. Pixels
// whose chief rays fall outside the lens model's domain are 0 (black), as a real lens
// with a mechanical vignette would show them.
cv::Mat integrate_reflectance(const IntegratorSetup& setup);

}  // namespace camlab::mock
