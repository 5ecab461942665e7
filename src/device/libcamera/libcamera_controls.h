// Internal to the libcamera backend (includes libcamera): how libcamera's controls
// appear as camlab ControlInfo entries, how camlab values become ControlValues, and
// what a completed request's metadata says about a frame. See libcamera_camera.h for
// the naming and units.
//
// Reentrant.
#pragma once

#include <libcamera/controls.h>
#include <libcamera/pixel_format.h>

#include <cstdint>
#include <string>
#include <vector>

#include "base/result.h"
#include "device/camera.h"

namespace camlab::device::libcamera_backend {

// One camlab control backed by a libcamera control: value_camlab * scale is the
// libcamera value (floats: scale 1/1000; exposure_time_absolute: scale 100).
struct ControlBinding {
  ControlInfo info;
  const libcamera::ControlId* id = nullptr;
  double scale = 1.0;
};

// "ExposureTime" -> "exposure_time", "AeEnable" -> "ae_enable".
std::string snake_case(const std::string& camel);

// Every scalar control of the camera (arrays, strings, rectangles and sizes are left
// out: a ControlInfo range cannot carry them), plus the exposure_time_absolute alias,
// sorted by name.
std::vector<ControlBinding> bind_controls(const libcamera::ControlInfoMap& controls);

// The ControlValue for camlab `value` (checked against the binding's range): an
// "out_of_range" error naming the range otherwise.
Result<libcamera::ControlValue> to_control_value(const ControlBinding& binding, int64_t value);

// A libcamera value in camlab's integer units (inverse of to_control_value).
int64_t from_control_value(const ControlBinding& binding, const libcamera::ControlValue& value);

// The settings a completed request reports (exposure_us, analogue_gain,
// lens_position) and its FocusFoM, copied into `meta`; those the request lacks stay empty.
void fill_settings(const libcamera::ControlList& metadata, FrameMetadata* meta);

// camlab's fourcc strings (V4L2's, as the V4L2 backend reports them) for libcamera's
// pixel formats and back: "GREY" is R8, the rest keep their fourcc (libcamera 0.0.3
// has no 16-bit greyscale format).
std::string fourcc_of(const libcamera::PixelFormat& format);
libcamera::PixelFormat pixel_format_of(const std::string& fourcc);

}  // namespace camlab::device::libcamera_backend
