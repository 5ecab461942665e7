// A camera as a fleet host publishes it (service/store/fleet_store.h, FleetCamera), and
// back: its identity, formats, controls with their ranges and what its raw values mean
// (capture::CameraTraits), so that any host of the fleet can check a capture request
// against a camera on another host exactly as that host would (capture::plan_capture),
// and answer 400/422 at once rather than fail the job later.
//
// Reentrant.
#pragma once

#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "capture/capture_plan.h"
#include "device/camera.h"
#include "service/jobs/camera_worker.h"

namespace camlab::service {

// The published description: CameraSnapshot::description (identity, formats, controls,
// as device/camera_json.h writes them) with "traits" added.
nlohmann::json describe_for_fleet(const CameraSnapshot& snapshot);

// What plan_capture needs, read back from a published description.
struct PublishedCamera {
  std::vector<device::ControlInfo> controls;
  std::vector<device::PixelFormatInfo> formats;
  capture::CameraTraits traits;
};
// "invalid_argument" naming the part that does not read.
Result<PublishedCamera> read_published_camera(const nlohmann::json& description);

}  // namespace camlab::service
