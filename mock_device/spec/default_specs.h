// The virtual camera camlab uses when none is given: camlabd without --camera-spec and
// --scene, `camlab vcam run` and `vcam serve` without --camera and --scene, and
// `camlab devices --virtual CAMERA` without --virtual-scene.
//
// The camera: 640x480, 10 bits, 4 um pixels, an 8 mm OPENCV4 lens with an iris from f/1.4
// to f/16 (8 positions) and a focus motor (1 um per step), gain 1x-16x, 30 frames/s with
// 3 frames of control latency, shot and read noise. The scene: three slanted edges (5
// degrees) at 0.7, 1 and 2 m, for blur and CoC measurement, under 1000 lux.
//
// Reentrant.
#pragma once

#include <nlohmann/json.hpp>

#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock {

// The specs as JSON (what a capture records as its source).
const nlohmann::json& default_camera_spec_json();
const nlohmann::json& default_scene_spec_json();

// The same, parsed (constant specs: parsing them cannot fail; a test checks it).
CameraSpec default_camera_spec();
SceneSpec default_scene_spec();

}  // namespace camlab::mock
