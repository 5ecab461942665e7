// The devices of one `camlab vcam run`: `count` virtual cameras from one camera spec and
// one scene (each device its own noise seed), as the broker serves them.
//
// Reentrant.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "base/result.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

// An empty path stands for the default camera or scene (mock_device/spec/default_specs.h).
// Device i is /dev/video<i>. `realtime` false: frames are made as fast as buffers are
// queued (no frame clock), for quick tests.
Result<std::vector<std::shared_ptr<VirtualV4l2Device>>> create_vcam_devices(
    const std::string& camera_path, const std::string& scene_path, int count, bool realtime = true);

}  // namespace camlab::mock
