// The libcamera backend: cameras that libcamera's pipeline handlers expose (UVC webcams,
// embedded sensors, the virtual camera through `camlab vcam run`), behind the Camera
// interface. Built when CMake finds libcamera (CAMLAB_WITH_LIBCAMERA, compile
// definition CAMLAB_HAVE_LIBCAMERA); libcamera's ABI changes with every release, so no
// libcamera type leaves the backend's .cpp files.
//
// Controls are libcamera's, named in snake_case ("ExposureTime" is "exposure_time")
// with their libcamera units: exposure_time in us, booleans as 0/1. Float controls are
// carried as integers in thousandths ("analogue_gain" 2000 is AnalogueGain 2.0,
// "lens_position" 1500 is 1.5 dioptres) because ControlInfo's ranges are integers.
// "exposure_time_absolute" (100 us units) aliases ExposureTime so that capture plans
// written against V4L2 names run unchanged. Setting an exposure turns AeEnable off, as
// manual exposure needs.
//
// A control set with set_control() travels with the next request queued (at start, or
// with the next requeue()), as libcamera applies controls per request; a frame's
// FrameMetadata carries what its completed request reported (SensorTimestamp, and
// ExposureTime / AnalogueGain / LensPosition when the pipeline reports them: libcamera
// 0.0.3's UVC pipeline reports only the timestamp).
//
// Thread-bound, like every Camera. One libcamera CameraManager per process is shared by
// all libcamera cameras and listings (libcamera allows no second one). libcamera's own
// log is kept to errors by setting LIBCAMERA_LOG_LEVELS=*:ERROR in the environment
// when it is unset (the only way libcamera 0.0.3 takes levels before it logs).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "device/camera.h"

namespace camlab::device {

// Every camera libcamera enumerates: id "libcamera:<libcamera camera id>", backend
// "libcamera", path and bus_info the libcamera id, name its Model property. An error
// when the CameraManager cannot start.
Result<std::vector<CameraIdentity>> list_libcamera_cameras();

// Opens (and acquires, exclusively) a camera by its camlab id, its libcamera id, or its
// path. "busy" when another process or object holds it, "no_device" when it is unknown.
Result<std::unique_ptr<Camera>> open_libcamera_camera(const std::string& id);

}  // namespace camlab::device
