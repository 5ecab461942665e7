// The cameras camlabd serves, kept up to date while it runs (hot-plug).
//
// Sources: V4L2 devices found through the device registry (every /dev/video* capture node,
// or only the --device paths), the cameras libcamera enumerates (when camlab is built with
// libcamera and it is not turned off), and in-process virtual cameras (mock_device's V4L2
// device core behind a VirtualV4l2Io, run through the same V4L2 backend as real hardware;
// by default one when no real camera is found at start). A camera reachable both as a V4L2
// node and through libcamera is served once, under the preferred backend
// (DeviceRegistry::merge_twins: the key is libcamera's UVC camera id computed from the
// node's sysfs, device/uvc_identity.h). Each camera gets its worker
// (service/jobs/camera_worker.h).
//
// Hot-plug: a watcher thread rescans the sources when /dev changes (inotify IN_CREATE,
// IN_DELETE and IN_ATTRIB on video* and media* nodes, debounced), when notify_hotplug() is
// called (the test fault API's replug), and every `rescan_interval` in any case: the
// preload's virtual /dev makes no inotify events, and some systems have no inotify. A
// camera no longer found has its worker retired (its jobs end device_lost with their
// frames kept, and it stays listed as gone); a camera found without a live worker gets a
// fresh one, under the same id (v4l2:<bus_info> survives renumbering of /dev/video*).
// libcamera is asked again only when the V4L2 nodes present changed (or on an event), so
// that a steady rescan does not start libcamera's camera manager every time.
//
// Ownership: the set owns the workers through shared_ptr; find() and workers() hand out
// copies, so a worker a handler holds stays valid when it is retired meanwhile (it then
// refuses new work with no_device). Retired workers' threads are joined by the watcher
// once they have finished, and by stop().
//
// Thread-safe: find(), workers(), virtual_device(), notify_hotplug() and rescan() from any
// thread (rescans are serialised); start() and stop() once each, from the daemon's thread.
#pragma once

#include <chrono>
#include <condition_variable>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "base/result.h"
#include "base/unique_fd.h"
#include "device/device_registry.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "service/jobs/camera_worker.h"

namespace camlab::service {

enum class VirtualCameras { kWhenNoneFound, kAlways, kNever };

struct CameraSetOptions {
  bool scan_devices = true;               // look at every /dev/video*
  std::vector<std::string> device_paths;  // only these (when non-empty)
  // Serve the cameras libcamera enumerates (when built with libcamera).
  bool libcamera = true;
  // A camera reachable both as a V4L2 node and through libcamera is served through
  // libcamera (per-request controls, per-frame metadata where the pipeline reports it);
  // otherwise through V4L2.
  bool prefer_libcamera = false;
  // The floor of hot-plug detection; 0 turns hot-plug off (the set is built once).
  std::chrono::milliseconds rescan_interval{1000};
  bool watch_dev = true;  // inotify on /dev (the rescan still runs without it)
  VirtualCameras virtual_cameras = VirtualCameras::kWhenNoneFound;
  std::filesystem::path camera_spec;  // empty: the built-in 640x480 camera
  std::filesystem::path scene_spec;   // empty: the built-in slanted-edge scene
  int virtual_count = 1;
  std::filesystem::path rig_spec;  // set: the virtual cameras are this rig's (rig_spec.h)
  // A camera spec describing the V4L2 (kernel) cameras' sensor and lens: bit depth, black
  // level, gain unity, iris f-numbers, focal length, focus steps (empty: unknown).
  std::filesystem::path device_spec;
  CameraWorkerOptions worker;
};

class CameraSet {
 public:
  static Result<std::unique_ptr<CameraSet>> create(const CameraSetOptions& options, JobStore& store,
                                                   Metrics& metrics);
  ~CameraSet();
  CameraSet(const CameraSet&) = delete;
  CameraSet& operator=(const CameraSet&) = delete;

  // Starts the workers found by create() and the watcher.
  void start();
  void stop();

  // The current worker of camera `id` (a retired one while the camera is gone), or null.
  std::shared_ptr<CameraWorker> find(const std::string& id) const;
  // Every camera's current worker, in the order the cameras were first found.
  std::vector<std::shared_ptr<CameraWorker>> workers() const;
  // The in-process virtual device behind camera `id`, for test fault injection; null for
  // any other camera. The devices live as long as the set.
  mock::VirtualV4l2Device* virtual_device(const std::string& id) const;

  // A camera may have come or gone (the test fault API's replug): rescan now.
  void notify_hotplug();
  // Scans every source and retires or adds workers to match; serialised.
  void rescan(bool force_libcamera = false);

 private:
  CameraSet(const CameraSetOptions& options, JobStore& store, Metrics& metrics);
  Status add_virtual_cameras(int first_index);
  // The rig of options_.rig_spec: its cameras on one frame clock, each with its pose.
  Status add_rig_cameras(int first_index);
  // Serves in-process devices (device i's provenance sources[i]) as /dev/video<index>,
  // under the ids the registry gives them.
  void serve_virtual_devices(const std::vector<std::shared_ptr<mock::VirtualV4l2Device>>& devices,
                             const std::vector<nlohmann::json>& sources, const std::string& origin);
  std::shared_ptr<device::DeviceRegistry> scan(bool force_libcamera);
  std::shared_ptr<CameraWorker> make_worker(const device::DeviceEntry& entry,
                                            std::shared_ptr<const device::DeviceRegistry> registry);
  void watch();
  void join_finished();

  const CameraSetOptions options_;
  JobStore& store_;
  Metrics& metrics_;
  capture::CameraTraits device_traits_;  // from --device-spec
  bool started_ = false;

  // Fixed after create().
  std::shared_ptr<mock::VirtualV4l2Io> virtual_io_;
  std::vector<std::string> virtual_paths_;
  std::map<std::string, std::shared_ptr<mock::VirtualV4l2Device>> virtual_devices_;  // by camera id
  std::map<std::string, nlohmann::json> virtual_sources_;                            // by camera id

  // One rescan at a time; guards the libcamera listing kept between rescans.
  std::mutex scan_mutex_;
  std::vector<device::CameraIdentity> libcamera_cameras_;
  std::string libcamera_listed_for_;  // the V4L2 nodes present when libcamera was last asked
  bool libcamera_listed_ = false;
  std::string libcamera_error_;  // logged once per distinct message

  mutable std::mutex mutex_;
  std::vector<std::shared_ptr<CameraWorker>> workers_;   // one per camera id ever found
  std::vector<std::shared_ptr<CameraWorker>> retiring_;  // retired or replaced, not joined

  std::thread watcher_;
  UniqueFd wake_fd_;  // eventfd: notify_hotplug() and stop() wake the watcher
  std::mutex watch_mutex_;
  bool watch_stop_ = false;
};

}  // namespace camlab::service
