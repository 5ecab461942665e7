// The devices of one `camlab vcam run`: `count` virtual cameras from one camera spec and
// one scene (each device its own noise seed), as the broker serves them.
//
// Reentrant.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "mock_device/spec/rig_spec.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

// An empty path stands for the default camera or scene (mock_device/spec/default_specs.h).
// Device i is /dev/video<i>. `realtime` false: frames are made as fast as buffers are
// queued (no frame clock), for quick tests.
Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_devices(
    const std::string& camera_path, const std::string& scene_path, int count, bool realtime = true);

// The cameras of a rig (mock_device/spec/rig_spec.h), device i its camera i, each seeing
// the scene through its pose, every one on one frame grid: frames that one trigger starts
// carry one timestamp (plus a camera's trigger offset).
Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_rig_devices(
    const std::string& rig_path, bool realtime = true);
// The same from a parsed rig, device i as /dev/video<first_index + i>.
Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_rig_devices(const RigSpec& rig,
                                                                                int first_index,
                                                                                bool realtime);

}  // namespace camlab::mock
