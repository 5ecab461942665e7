// The lens-map capture the lens-map tests and lens_map_bench render: the example chart
// through one camera, the f-numbers x 15 focus positions 7 steps apart (15 to 113), 2 ms
// exposures at f/1.4 and as long again as N^2 at the others, one frame each.
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
  // 2 ms at f/1.4 (white at about 80% of full scale), the time growing as N^2 so that
  // every f-number is exposed alike, as a lens map is taken.
  req.base.f_number = 1.4;
  req.base.exposure_us = 2000;
  req.hold_exposure = true;
  req.sweep = mock::Sweep{"f_number", f_numbers};
  std::vector<double> positions;
  for (double p = 15; p <= 113; p += kLensMapSweepStep) positions.push_back(p);
  req.inner_sweep = mock::Sweep{"focus_position", positions};
  req.options.seed = seed;
  return req;
}

}  // namespace camlab::analysis::testing
