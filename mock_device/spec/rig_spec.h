// A virtual camera rig: 2 to 8 cameras, each with its own spec and its pose in the rig's
// reference frame, looking at one scene on one frame clock (`camlab vcam run --rig`).
//
// The rig file (docs/virtual-camera.md, "Rigs"):
//   {"name": "...", "scene": "scene.json" or {...},
//    "cameras": [{"name": "left", "camera": "camera.json" or {...},
//                 "rt_cam_ref": [rx, ry, rz, tx, ty, tz], "trigger_offset_us": 0}, ...]}
// rt_cam_ref is mrcal's convention (rotation vector in rad, translation in m): it maps a
// point in the reference frame into the camera's frame; camera 0 usually at the
// reference (all zeros), as mrcal and camlab's rig calibration put it. The scene's target
// poses are in the reference frame (a scene written for camera 0 when camera 0 is at the
// reference); each camera sees them through its rt_cam_ref. Paths are relative to the
// rig file. trigger_offset_us (default 0, |offset| <= 100 ms) delays that camera's frames
// on the rig's clock: a rig whose cameras are not triggered together. "view_every_frames":
// N (default 0) moves the scene's targets through their poses on the rig's clock, N frames
// each, as a board a person moves in front of the rig.
//
// Reentrant: plain values, validated once.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/scene_spec.h"

namespace camlab::mock {

struct RigCameraSpec {
  std::string name;
  CameraSpec camera;
  RtCamTarget rt_cam_ref{};  // rad, m
  double trigger_offset_us = 0;
};

struct RigSpec {
  std::string name;
  std::vector<RigCameraSpec> cameras;
  SceneSpec scene;  // target poses in the reference frame
  // > 0: the scene's views (a board's poses) follow the rig's clock, this many frames each
  // (VirtualDeviceOptions::view_every_frames); 0: every camera shows view 0.
  int view_every_frames = 0;
};

// Errors: "invalid_argument" (a missing or malformed field, named by its path),
// "out_of_range", and those of the camera and scene specs it names.
Result<RigSpec> parse_rig_spec(const nlohmann::json& json, const std::filesystem::path& base_dir);
Result<RigSpec> load_rig_spec(const std::filesystem::path& path);

// The scene as camera `rt_cam_ref` sees it: every target pose composed with rt_cam_ref
// (rt_cam_target = rt_cam_ref o rt_ref_target), and its source JSON with the composed
// poses, as a capture's manifest records it.
SceneSpec scene_seen_from(const SceneSpec& scene_in_ref, const RtCamTarget& rt_cam_ref);

// rt_a_c = rt_a_b o rt_b_c (mrcal's compose_rt): x_a = R_ab (R_bc x_c + t_bc) + t_ab.
RtCamTarget compose_rt(const RtCamTarget& rt_a_b, const RtCamTarget& rt_b_c);

}  // namespace camlab::mock
