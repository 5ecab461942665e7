// The lens-map capture the lens-map tests and lens_map_bench render: the example chart
// through one camera, the f-numbers x 15 focus positions 7 steps apart (15 to 113), 1 ms
// exposures, one frame each.
#pragma once

#include <cstdint>
#include <filesystem>
#include <vector>

#include "mock_device/render/render_capture.h"
#include "mock_device/render/renderer.h"

namespace camlab::analysis::testing {

inline constexpr double kLensMapSweepStep = 7;  // focus units between the sweep's positions

inline mock::RenderCaptureRequest lens_map_sweep(const mock::Renderer& renderer,
                                                 const std::filesystem::path& dir,
                                                 const std::vector<double>& f_numbers,
                                                 uint64_t seed) {
  mock::RenderCaptureRequest req;
  req.out_dir = dir;
  req.base = renderer.default_settings();
  req.base.exposure_us = 1000;
  req.sweep = mock::Sweep{"f_number", f_numbers};
  std::vector<double> positions;
  for (double p = 15; p <= 113; p += kLensMapSweepStep) positions.push_back(p);
  req.inner_sweep = mock::Sweep{"focus_position", positions};
  req.options.seed = seed;
  return req;
}

}  // namespace camlab::analysis::testing
