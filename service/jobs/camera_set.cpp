#include "service/jobs/camera_set.h"

#include <poll.h>
#include <sys/eventfd.h>
#include <sys/inotify.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>

#include "base/log.h"
#include "mock_device/broker/vcam_devices.h"
#include "mock_device/spec/camera_spec.h"
#include "mock_device/spec/default_specs.h"
#include "mock_device/spec/rig_spec.h"
#include "mock_device/spec/scene_spec.h"
#include "mock_device/v4l2/capture_traits.h"

namespace camlab::service {

namespace {

// Events on /dev come in bursts (the node, then its permissions; a media node with its
// video node): one rescan after the burst.
constexpr std::chrono::milliseconds kDebounce{100};

bool same_device(const device::DeviceEntry& a, const device::DeviceEntry& b) {
  return a.identity.path == b.identity.path && a.identity.backend == b.identity.backend &&
         a.transport == b.transport;
}

// Whether an inotify event on /dev is about a camera node (video* or media*).
bool is_camera_node_event(const inotify_event& event) {
  if (event.len == 0) return false;
  const std::string name = event.name;
  return name.rfind("video", 0) == 0 || name.rfind("media", 0) == 0;
}

}  // namespace

CameraSet::CameraSet(const CameraSetOptions& options, JobStore& store, Metrics& metrics)
    : options_(options), store_(store), metrics_(metrics) {}

Result<std::unique_ptr<CameraSet>> CameraSet::create(const CameraSetOptions& options,
                                                     JobStore& store, Metrics& metrics) {
  std::unique_ptr<CameraSet> set(new CameraSet(options, store, metrics));
  if (!options.device_spec.empty()) {
    auto spec = mock::load_camera_spec(options.device_spec);
    if (!spec) return spec.error();
    set->device_traits_ = mock::capture_traits_of(*spec);
  }
  std::shared_ptr<device::DeviceRegistry> found = set->scan(/*force_libcamera=*/true);
  for (const std::string& path : options.device_paths) {
    bool listed = false;
    for (const auto& e : found->devices())
      listed = listed || e.identity.path == path || e.v4l2_node == path;
    if (!listed)
      log_warning(log::Category::kCameras, "--device %s: not a V4L2 capture device (skipped)",
                  path.c_str());
  }
  const bool add_virtual =
      options.virtual_cameras == VirtualCameras::kAlways ||
      (options.virtual_cameras == VirtualCameras::kWhenNoneFound && found->devices().empty());
  if (add_virtual) {
    if (auto s = set->add_virtual_cameras(static_cast<int>(found->devices().size())); !s)
      return s.error();
    found = set->scan(/*force_libcamera=*/false);
  }
  std::shared_ptr<const device::DeviceRegistry> registry = found;
  for (const device::DeviceEntry& entry : found->devices())
    set->workers_.push_back(set->make_worker(entry, registry));
  return set;
}

Status CameraSet::add_virtual_cameras(int first_index) {
  if (!options_.rig_spec.empty()) return add_rig_cameras(first_index);
  nlohmann::json camera_json, scene_json;
  if (options_.camera_spec.empty()) {
    camera_json = mock::default_camera_spec_json();
  } else {
    auto spec = mock::load_camera_spec(options_.camera_spec);
    if (!spec) return spec.error();
    camera_json = spec->source;
  }
  if (options_.scene_spec.empty()) {
    scene_json = mock::default_scene_spec_json();
  } else {
    auto spec = mock::load_scene_spec(options_.scene_spec);
    if (!spec) return spec.error();
    scene_json = spec->source;
  }
  std::vector<std::shared_ptr<mock::VirtualV4l2Device>> devices;
  std::vector<nlohmann::json> sources;
  for (int i = 0; i < options_.virtual_count; ++i) {
    auto camera = mock::parse_camera_spec(camera_json);
    if (!camera) return camera.error();
    auto scene = mock::parse_scene_spec(scene_json);
    if (!scene) return scene.error();
    mock::VirtualDeviceOptions device_options;
    device_options.index = first_index + i;
    device_options.seed = static_cast<uint64_t>(1 + i);
    auto device =
        mock::VirtualV4l2Device::create(std::move(*camera), std::move(*scene), device_options);
    if (!device) return device.error();
    devices.push_back(std::move(*device));
    sources.push_back(
        {{"backend", "virtual"}, {"camera_spec", camera_json}, {"scene_spec", scene_json}});
  }
  serve_virtual_devices(devices, sources, "in-process virtual camera");
  return {};
}

void CameraSet::serve_virtual_devices(
    const std::vector<std::shared_ptr<mock::VirtualV4l2Device>>& devices,
    const std::vector<nlohmann::json>& sources, const std::string& origin) {
  for (const auto& device : devices)
    virtual_paths_.push_back("/dev/video" + std::to_string(device->index()));
  virtual_io_ = std::make_shared<mock::VirtualV4l2Io>(devices);
  // Their ids, as the registry gives them (v4l2:<bus_info>).
  device::DeviceRegistry registry;
  registry.add_v4l2(virtual_io_, origin, virtual_paths_);
  for (const device::DeviceEntry& entry : registry.devices())
    for (size_t i = 0; i < virtual_paths_.size(); ++i) {
      if (virtual_paths_[i] != entry.identity.path) continue;
      virtual_devices_[entry.identity.id] = devices[i];
      virtual_sources_[entry.identity.id] = sources[i];
    }
}

Status CameraSet::add_rig_cameras(int first_index) {
  mock::RigSpec rig;
  CAMLAB_ASSIGN(rig, mock::load_rig_spec(options_.rig_spec));
  std::vector<std::shared_ptr<mock::VirtualV4l2Device>> devices;
  CAMLAB_ASSIGN(devices, mock::create_vcam_rig_devices(rig, first_index, /*realtime=*/true));
  std::vector<nlohmann::json> sources;
  for (size_t i = 0; i < rig.cameras.size(); ++i) {
    const mock::RigCameraSpec& member = rig.cameras[i];
    sources.push_back({{"backend", "virtual"},
                       {"camera_spec", member.camera.source},
                       {"scene_spec", mock::scene_seen_from(rig.scene, member.rt_cam_ref).source},
                       {"rig",
                        {{"name", rig.name},
                         {"camera", member.name},
                         {"index", i},
                         {"rt_cam_ref", member.rt_cam_ref},
                         {"trigger_offset_us", member.trigger_offset_us}}}});
  }
  serve_virtual_devices(devices, sources, "in-process virtual rig camera");
  return {};
}

std::shared_ptr<device::DeviceRegistry> CameraSet::scan(bool force_libcamera) {
  auto registry = std::make_shared<device::DeviceRegistry>();
  const auto system_io = device::system_v4l2_io();
  if (!options_.device_paths.empty())
    registry->add_v4l2(system_io, "kernel", options_.device_paths);
  else if (options_.scan_devices)
    registry->add_v4l2(system_io, "kernel");

  if (options_.libcamera && device::DeviceRegistry::libcamera_supported()) {
    // Which nodes are present, by id: libcamera is asked again when this changes.
    std::string nodes;
    for (const auto& e : registry->devices()) nodes += e.identity.path + "=" + e.identity.id + ";";
    for (const auto& path : device::list_video_device_paths()) nodes += path + ";";
    if (force_libcamera || !libcamera_listed_ || nodes != libcamera_listed_for_) {
      auto listed = device::DeviceRegistry::list_libcamera();
      if (listed) {
        libcamera_cameras_ = std::move(*listed);
        libcamera_error_.clear();
      } else {
        libcamera_cameras_.clear();
        if (listed.error().message != libcamera_error_)
          log_warning(log::Category::kCameras, "libcamera: %s (its cameras are not served)",
                      listed.error().message.c_str());
        libcamera_error_ = listed.error().message;
      }
      libcamera_listed_for_ = nodes;
      libcamera_listed_ = true;
    }
    registry->add_libcamera(libcamera_cameras_);
    registry->merge_twins(options_.prefer_libcamera, system_io);
  }

  if (virtual_io_) registry->add_v4l2(virtual_io_, "in-process virtual camera", virtual_paths_);
  return registry;
}

std::shared_ptr<CameraWorker> CameraSet::make_worker(
    const device::DeviceEntry& entry, std::shared_ptr<const device::DeviceRegistry> registry) {
  CameraWorkerOptions worker_options = options_.worker;
  worker_options.traits = device_traits_;
  if (auto it = virtual_devices_.find(entry.identity.id); it != virtual_devices_.end()) {
    worker_options.spec_latency_frames = it->second->camera().timing.control_latency_frames;
    worker_options.source_extra = virtual_sources_.at(entry.identity.id);
    worker_options.traits = mock::capture_traits_of(it->second->camera());
  }
  const std::string id = entry.identity.id;
  // The registry of the scan that found the camera opens it: by path for V4L2 (the path
  // it had then), by id for libcamera.
  return std::make_shared<CameraWorker>(
      entry, [registry, id] { return registry->open(id); }, worker_options, store_, metrics_);
}

CameraSet::~CameraSet() { stop(); }

void CameraSet::start() {
  std::vector<std::shared_ptr<CameraWorker>> initial;
  {
    std::lock_guard lock(mutex_);
    if (started_) return;
    started_ = true;
    initial = workers_;
  }
  for (auto& worker : initial) worker->start();
  if (options_.rescan_interval.count() > 0) {
    wake_fd_.reset(::eventfd(0, EFD_CLOEXEC | EFD_NONBLOCK));
    watcher_ = std::thread([this] { watch(); });
  }
}

void CameraSet::stop() {
  {
    std::lock_guard lock(watch_mutex_);
    watch_stop_ = true;
  }
  if (wake_fd_) {
    const uint64_t one = 1;
    (void)!::write(wake_fd_.get(), &one, sizeof one);
  }
  if (watcher_.joinable()) watcher_.join();
  std::vector<std::shared_ptr<CameraWorker>> all;
  {
    std::lock_guard lock(mutex_);
    all = workers_;
    all.insert(all.end(), retiring_.begin(), retiring_.end());
  }
  // Ask every worker to stop first, so cameras wind down in parallel, then join.
  for (auto& worker : all) worker->request_stop();
  for (auto& worker : all) worker->stop();
  std::lock_guard lock(mutex_);
  retiring_.clear();
}

std::shared_ptr<CameraWorker> CameraSet::find(const std::string& id) const {
  std::lock_guard lock(mutex_);
  for (const auto& worker : workers_)
    if (worker->id() == id) return worker;
  return nullptr;
}

std::vector<std::shared_ptr<CameraWorker>> CameraSet::workers() const {
  std::lock_guard lock(mutex_);
  return workers_;
}

mock::VirtualV4l2Device* CameraSet::virtual_device(const std::string& id) const {
  auto it = virtual_devices_.find(id);
  return it == virtual_devices_.end() ? nullptr : it->second.get();
}

void CameraSet::notify_hotplug() {
  if (!wake_fd_) return;
  const uint64_t one = 1;
  (void)!::write(wake_fd_.get(), &one, sizeof one);
}

void CameraSet::rescan(bool force_libcamera) {
  std::lock_guard scan_lock(scan_mutex_);
  std::shared_ptr<const device::DeviceRegistry> found = scan(force_libcamera);
  std::vector<std::shared_ptr<CameraWorker>> to_start;
  {
    std::lock_guard lock(mutex_);
    for (auto& worker : workers_) {
      if (worker->retired()) continue;
      const auto& entries = found->devices();
      auto it = std::find_if(entries.begin(), entries.end(), [&](const device::DeviceEntry& e) {
        return e.identity.id == worker->id();
      });
      if (it != entries.end() && same_device(*it, worker->entry())) {
        worker->reopen_if_unavailable();  // e.g. a job lost it and it is back already
        continue;
      }
      const std::string reason =
          it == entries.end()
              ? "unplugged: " + worker->entry().identity.path + " is gone"
              : "moved from " + worker->entry().identity.path + " to " + it->identity.path;
      log_warning(log::Category::kCameras, "camera %s %s", worker->id().c_str(), reason.c_str());
      worker->retire(reason);
      retiring_.push_back(worker);
    }
    for (const device::DeviceEntry& entry : found->devices()) {
      auto it = std::find_if(workers_.begin(), workers_.end(),
                             [&](const auto& w) { return w->id() == entry.identity.id; });
      if (it != workers_.end() && !(*it)->retired()) continue;
      auto worker = make_worker(entry, found);
      log_info(log::Category::kCameras, "camera %s: %s at %s (%s)%s", entry.identity.id.c_str(),
               it == workers_.end() ? "found" : "back", entry.identity.path.c_str(),
               entry.transport.c_str(),
               entry.also_reachable_as.empty()
                   ? ""
                   : (", also reachable as " + entry.also_reachable_as).c_str());
      if (it != workers_.end())
        *it = worker;  // the retired one is in retiring_ until its thread is joined
      else
        workers_.push_back(worker);
      to_start.push_back(std::move(worker));
    }
  }
  // Opening takes milliseconds (bounded by CameraWorker::start), outside the lock so that
  // handlers never wait on a camera.
  for (auto& worker : to_start) worker->start();
}

void CameraSet::join_finished() {
  std::vector<std::shared_ptr<CameraWorker>> done;
  {
    std::lock_guard lock(mutex_);
    auto finished = std::stable_partition(retiring_.begin(), retiring_.end(),
                                          [](const auto& w) { return !w->finished(); });
    done.assign(finished, retiring_.end());
    retiring_.erase(finished, retiring_.end());
  }
  for (auto& worker : done) worker->join();  // returns at once: the thread has ended
}

void CameraSet::watch() {
  UniqueFd inotify;
  if (options_.watch_dev) {
    inotify.reset(::inotify_init1(IN_CLOEXEC | IN_NONBLOCK));
    if (!inotify ||
        ::inotify_add_watch(inotify.get(), "/dev", IN_CREATE | IN_DELETE | IN_ATTRIB) < 0) {
      log_info(log::Category::kCameras,
               "no inotify on /dev (%s): cameras plugged in or out are found by the rescan "
               "every %lld ms",
               std::strerror(errno), static_cast<long long>(options_.rescan_interval.count()));
      inotify.reset();
    }
  }
  alignas(inotify_event) char events[4096];
  for (;;) {
    pollfd fds[2] = {{wake_fd_.get(), POLLIN, 0}, {inotify ? inotify.get() : -1, POLLIN, 0}};
    const int ready = ::poll(fds, 2, static_cast<int>(options_.rescan_interval.count()));
    {
      std::lock_guard lock(watch_mutex_);
      if (watch_stop_) return;
    }
    bool event = false;
    if (ready > 0 && (fds[0].revents & POLLIN)) {
      uint64_t count = 0;
      (void)!::read(wake_fd_.get(), &count, sizeof count);
      event = true;
    }
    if (ready > 0 && (fds[1].revents & POLLIN)) {
      // Drain the burst, then wait out the debounce for its tail.
      for (int round = 0; round < 2; ++round) {
        ssize_t n;
        while ((n = ::read(inotify.get(), events, sizeof events)) > 0)
          for (ssize_t at = 0; at < n;) {
            const auto* e = reinterpret_cast<const inotify_event*>(events + at);
            event = event || is_camera_node_event(*e);
            at += static_cast<ssize_t>(sizeof(inotify_event) + e->len);
          }
        if (round == 0 && event) std::this_thread::sleep_for(kDebounce);
      }
    }
    rescan(/*force_libcamera=*/event);
    join_finished();
  }
}

}  // namespace camlab::service
