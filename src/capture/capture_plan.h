// Capture plans: what a capture request asks of a camera, validated against that camera
// before anything is touched. A plan is a list of steps (control values in the device's
// own units, plus the settings they stand for in physical units), each captured
// `repeats` times.
//
// Kinds (the JSON body of POST /v1/cameras/{id}/captures; docs/capture-api.md):
//   single           {"kind": "single", "repeats": 1}
//   bracket          {"kind": "bracket", "exposures_us": [1000, 2000, ...], "gain": 100}
//                    or {"kind": "bracket", "base_exposure_us": 4000, "ev_steps": [-2, 0, 2]}
//   focus_stack      {"kind": "focus_stack", "positions": [...]} or
//                    {"kind": "focus_stack", "start": 0, "stop": 100, "step": 10}
//   aperture_series  {"kind": "aperture_series", "f_numbers": [2, 2.8, 4]} or
//                    {"kind": "aperture_series", "iris_positions": [...]}; with
//                    "base_exposure_us" each stop exposed alike (as a lens map)
//   lens_map         an aperture series' stops x a focus stack's positions, the focus
//                    stepped inside each stop: {"kind": "lens_map", "f_numbers": [2, 4],
//                    "start": 15, "stop": 113, "step": 7, "base_exposure_us": 2000}
//                    (the first stop's time, each other's grown as N^2: every stop
//                    exposed alike)
// Common optional fields: "repeats" (>= 1, pairs for noise statistics), "format"
// ({"fourcc": "Y16 ", "width": 640, "height": 480, "frame_interval_us": 33333}),
// "exposure_us" and "gain" (fixed, for the kinds that do not step them), "controls"
// (extra fixed controls by V4L2 name in the control's unit, applied before the first
// step), "label" (free text for the manifest). Unknown fields are refused, so that a typo
// ("exposure_ms") never silently captures something else.
//
// Units: exposure in microseconds (converted to exposure_time_absolute's 100 us units:
// explicit values must be on the control's grid, EV-derived ones are rounded to it);
// "gain" is the V4L2 gain control's value; focus positions are focus_absolute steps;
// iris positions iris_absolute values.
//
// Kinds that step exposure or aperture switch auto exposure to manual; a focus stack
// switches continuous autofocus off (both restored after the run).
//
// Reentrant.
#pragma once

#include <cstdint>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "base/result.h"
#include "device/camera.h"

namespace camlab::capture {

// Bounds on what one request may ask (docs/architecture.md: everything from outside is bounded).
inline constexpr int kMaxStepsPerPlan = 1000;
inline constexpr int kMaxFramesPerPlan = 5000;
// A single capture of one setting may take as many frames as any plan (long series for
// temporal noise or flicker); frames per request bound it either way.
inline constexpr int kMaxRepeats = kMaxFramesPerPlan;
inline constexpr int kMaxFixedControls = 32;

// What a camera's raw values mean physically, when known: the virtual camera's come from
// its spec (sensor.bit_depth, sensor.black_level_dn, controls.gain_unity,
// lens.iris.f_numbers, lens.focal_mm, lens.focus.extension_mm_per_step); a real camera's
// from calibration or configuration. Every field may stay unknown (0 / empty): plans then
// refuse f-numbers, and sidecars carry device units only.
struct CameraTraits {
  int sensor_bit_depth = 0;  // significant bits of the DN; Y16 carries them MSB-aligned
  int black_level_dn = 0;    // in DN of sensor_bit_depth bits
  // The processed formats (YUYV, RGB, NV12) come from an ISP that took the black level off
  // (a colour sensor's demosaicing does; a mono sensor's YUYV may carry the pedestal): their
  // black is then the format's own (16 in limited-range YUYV), not the sensor's.
  bool isp_subtracts_black = false;
  int gain_unity = 0;  // gain control value for a linear gain of 1
  // f-number at iris_absolute = p is f_number_by_iris_position[p] (V4L2: larger = wider).
  std::vector<double> f_number_by_iris_position;
  double focal_mm = 0;
  // focus_absolute = p puts the lens focal_mm + p * this from the sensor (p = 0: infinity).
  double focus_extension_mm_per_step = 0;
};

struct CaptureStep {
  // Controls to set for this step, by V4L2 name, in the control's own unit
  // (exposure_time_absolute in 100 us, focus_absolute in steps, ...), checked against
  // the camera's ranges.
  std::map<std::string, int64_t> controls;
  // What the step stands for, with the unit in the key (exposure_us, focus_position,
  // focus_distance_m, lens_to_sensor_mm, iris_position, f_number): goes into the sidecar
  // (settings.requested) next to the values really applied.
  nlohmann::json requested = nlohmann::json::object();
  // Labels for the sidecar: {"step_index": 2}; the runner adds "repeat".
  nlohmann::json labels = nlohmann::json::object();
};

struct CapturePlan {
  std::string kind;  // "single", "bracket", "focus_stack", "aperture_series", "lens_map"
  // Resolved by plan_capture to a format the camera lists: a request without one gets the
  // camera's deepest greyscale format (Y16, else GREY, else the first) at its largest size.
  // interval.denominator == 0: the driver's default frame interval.
  device::StreamFormat format;
  int repeats = 1;                                // frames kept per step
  std::map<std::string, int64_t> fixed_controls;  // applied once before the first step
  std::vector<CaptureStep> steps;
  nlohmann::json request;  // the normalised request (stored in the manifest)
  CameraTraits traits;     // as given to plan_capture

  int total_frames() const { return static_cast<int>(steps.size()) * repeats; }
};

// Validates `request` against the camera's controls and formats. Errors:
//   "invalid_request": malformed (missing or mistyped fields, unknown kind or field, empty
//                      lists, limits above exceeded); the service answers 400.
//   "out_of_range":    a value outside the control's range or off its grid, or a
//                      format/size the camera lacks; the message names the allowed range
//                      (exposures in us); the service answers 422.
//   "unsupported":     the camera has no control for this kind (e.g. no iris), or no
//                      f-number table for f_numbers; 422.
Result<CapturePlan> plan_capture(const nlohmann::json& request,
                                 const std::vector<device::ControlInfo>& controls,
                                 const std::vector<device::PixelFormatInfo>& formats,
                                 const CameraTraits& traits = {});

}  // namespace camlab::capture
