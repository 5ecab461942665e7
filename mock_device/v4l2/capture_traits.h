// What a virtual camera's spec says its raw control and pixel values mean, in the form
// capture plans use (capture::CameraTraits): bit depth, black level, gain unity, the
// f-number of each iris position, focal length and focus extension per step.
//
// Reentrant.
#pragma once

#include "capture/capture_plan.h"
#include "mock_device/spec/camera_spec.h"

namespace camlab::mock {

capture::CameraTraits capture_traits_of(const CameraSpec& spec);

}  // namespace camlab::mock
