#include "mock_device/v4l2/capture_traits.h"

namespace camlab::mock {

capture::CameraTraits capture_traits_of(const CameraSpec& spec) {
  capture::CameraTraits traits;
  traits.sensor_bit_depth = spec.sensor.bit_depth;
  traits.black_level_dn = spec.sensor.black_level_dn;
  // The virtual colour camera's ISP subtracts black before its RGB, NV12 and YUYV; the mono
  // camera's YUYV keeps the pedestal (virtual_v4l2_frame_encoder.cpp).
  traits.isp_subtracts_black = spec.sensor.is_colour();
  traits.gain_unity = spec.controls.gain_unity;
  traits.f_number_by_iris_position = spec.lens.iris.f_numbers;
  traits.focal_mm = spec.lens.focal_mm;
  traits.focus_extension_mm_per_step = spec.lens.focus.extension_mm_per_step;
  return traits;
}

}  // namespace camlab::mock
