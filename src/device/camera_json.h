// JSON descriptions of cameras, for `camlab devices --json` and camlabd's /v1/cameras.
//
// Reentrant.
#pragma once

#include <nlohmann/json.hpp>

#include "device/camera.h"

namespace camlab::device {

nlohmann::json to_json(const CameraIdentity& identity);
nlohmann::json to_json(const PixelFormatInfo& format);
nlohmann::json to_json(const ControlInfo& control);

// Identity, formats and controls of an open camera; a part that fails is reported in
// "errors" rather than hiding the rest.
nlohmann::json describe_camera(Camera& camera);

}  // namespace camlab::device
