// What a camera reports with each frame (FrameMetadata: libcamera's ExposureTime,
// AnalogueGain and LensPosition, when the pipeline reports them) against what a capture
// step asked for. When a camera reports every control a plan varies, each frame's own
// report says whether the step's settings are in effect for it, and the capture runner
// keeps frames by that instead of by the control latency (capture/capture_runner.h).
//
// Reentrant.
#pragma once

#include <cstdint>
#include <map>
#include <set>
#include <string>

#include <nlohmann/json.hpp>

#include "device/camera.h"

namespace camlab::capture {

// Whether a frame's metadata can report control `name`: exposure_time_absolute (100 us)
// and exposure_time (us) as exposure_us, analogue_gain (thousandths) as analogue_gain,
// lens_position (thousandths of a dioptre) as lens_position.
bool is_reported_control(const std::string& name);

// What a frame taken with `controls` should report, for the controls in `names` that can
// be reported: keys "exposure_us", "analogue_gain", "lens_position".
std::map<std::string, double> expected_report(const std::map<std::string, int64_t>& controls,
                                              const std::set<std::string>& names);

// Whether `meta` reports every quantity in `expected`.
bool reports_all(const device::FrameMetadata& meta, const std::map<std::string, double>& expected);

// Whether every reported quantity equals the expected one, within what sensors quantise
// (exposure to line times, gain to register steps): exposure to within 5% or 30 us, gain
// to within 5%, lens position to within 0.05 dioptre. Steps closer than that are not told
// apart by their reports.
bool report_matches(const device::FrameMetadata& meta,
                    const std::map<std::string, double>& expected);

// The frame's report for its sidecar: {"exposure_us", "analogue_gain", "lens_position",
// "focus_fom"}, each only when reported; an empty object when nothing is.
nlohmann::json report_json(const device::FrameMetadata& meta);

}  // namespace camlab::capture
