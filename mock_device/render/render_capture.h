// Renders a whole capture (views x sweep values x repeats) into a capture folder: the
// engine behind `camlab render`. Frames carry the settings in effect and their truth.
//
// Thread-bound: one call at a time per Renderer.
#pragma once

#include <filesystem>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "mock_device/render/renderer.h"

namespace camlab::mock {

// A setting varied across frames. Parameters: exposure_us, gain (linear), f_number,
// focus_position (steps), focus_m (focus distance in metres; converted to the nearest
// focus position).
struct Sweep {
  std::string parameter;
  std::vector<double> values;
};

// "name=v1,v2,...", "name=start:stop:step" (added; stop included when on the grid), or
// "name=start:stop:stops" (multiplied by one stop: sqrt 2 for f_number, 2 for exposure_us
// and gain; also half-stops, third-stops, or xRATIO for any ratio), so that
// f_number=2:11.4:stops is f/2, 2.83, 4, 5.66, 8, 11.3.
Result<Sweep> parse_sweep(const std::string& text);

// Applies one `name=value` to settings (the same names as a sweep).
Status apply_setting(const Renderer& renderer, const std::string& name, double value,
                     RenderSettings* settings);

struct RenderCaptureRequest {
  std::filesystem::path out_dir;
  RenderSettings base;
  std::optional<Sweep> sweep;
  // A second setting varied inside the first (a grid: every value of `sweep` x every value
  // of this one, e.g. f-numbers x focus positions for a lens map); needs `sweep`, and
  // another setting than it.
  std::optional<Sweep> inner_sweep;
  // Keeps every f-number's exposure H = T x E at the base's: wherever a sweep sets the
  // f-number, the exposure time follows as (N / base N)^2, since the image-side irradiance
  // goes as 1 / N^2. A lens map at a fixed time leaves f/5.6 four stops under f/1.4 and
  // its edges' noise four times as large relative to their contrast.
  bool hold_exposure = false;
  int repeats = 1;         // frames per setting (noise statistics need pairs)
  std::vector<int> views;  // empty: every view of the scene
  RenderOptions options;   // seed etc.; frame_number is set per frame
  // Called after each frame with (frames done, frames total); may print progress.
  std::function<void(int, int, const RenderedFrame&)> progress;
};

struct RenderCaptureSummary {
  int frames = 0;
  double seconds = 0;
  std::filesystem::path out_dir;
};

Result<RenderCaptureSummary> render_capture(Renderer& renderer,
                                            const RenderCaptureRequest& request);

}  // namespace camlab::mock
