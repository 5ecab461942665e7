// LibcameraCamera: a libcamera::Camera behind camlab's Camera interface, and the one
// CameraManager per process they share.
#include "device/libcamera/libcamera_camera.h"
#include "base/mapped_buffer.h"

#include <libcamera/camera.h>
#include <libcamera/camera_manager.h>
#include <libcamera/color_space.h>
#include <libcamera/control_ids.h>
#include <libcamera/framebuffer.h>
#include <libcamera/framebuffer_allocator.h>
#include <libcamera/property_ids.h>
#include <libcamera/request.h>
#include <libcamera/stream.h>
#include <sys/mman.h>
#include <time.h>

#include <algorithm>
#include <condition_variable>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <map>
#include <mutex>
#include <optional>

#include "device/device_registry.h"
#include "device/libcamera/libcamera_controls.h"
#include "device/uvc_identity.h"
#include "device/v4l2/v4l2_camera.h"

namespace camlab::device {

namespace {

using libcamera_backend::ControlBinding;

constexpr const char* kIdPrefix = "libcamera:";

// libcamera aborts on a second CameraManager in one process, so every listing and camera
// shares one, started on first use and stopped when the last user lets go.
Result<std::shared_ptr<libcamera::CameraManager>> shared_manager() {
  static std::mutex mutex;
  static std::weak_ptr<libcamera::CameraManager> current;
  std::lock_guard lock(mutex);
  if (auto manager = current.lock()) return manager;
  // libcamera logs its version, missing IPA modules and unsupported formats on stderr;
  // keep to errors unless the user chose levels. Its categories come into being on
  // first use and read LIBCAMERA_LOG_LEVELS then, so the variable is the only handle.
  setenv("LIBCAMERA_LOG_LEVELS", "*:ERROR", /*overwrite=*/0);
  std::shared_ptr<libcamera::CameraManager> manager(new libcamera::CameraManager,
                                                    [](libcamera::CameraManager* m) {
                                                      m->stop();
                                                      delete m;
                                                    });
  if (int error = manager->start(); error < 0)
    return make_error("io_error", std::string("libcamera's camera manager did not start: ") +
                                      std::strerror(-error));
  current = manager;
  return manager;
}

CameraIdentity identity_of(const libcamera::Camera& camera) {
  CameraIdentity identity;
  identity.id = kIdPrefix + camera.id();
  identity.backend = "libcamera";
  identity.path = camera.id();
  identity.bus_info = camera.id();
  identity.driver = "libcamera";
  identity.name = camera.properties().get(libcamera::properties::Model).value_or(camera.id());
  return identity;
}

// What an abandoned camera leaves (LibcameraCamera::abandon): never destroyed, since
// destroying it would touch the pipeline of a device that is gone.
struct Abandoned {
  std::shared_ptr<libcamera::Camera> camera;
  std::unique_ptr<libcamera::CameraConfiguration> config;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator;
  std::vector<std::unique_ptr<libcamera::Request>> requests;
};
void keep_abandoned(std::shared_ptr<Abandoned> abandoned) {
  static std::mutex mutex;
  static auto* kept = new std::vector<std::shared_ptr<Abandoned>>();  // leaked on purpose
  std::lock_guard lock(mutex);
  kept->push_back(std::move(abandoned));
}

// Whether the V4L2 node of a UVC camera (by libcamera id) is gone: none of /dev/video*
// with that id opens. False for cameras of other pipelines (no node to ask).
bool uvc_node_gone(const std::string& libcamera_id) {
  if (!is_libcamera_uvc_id(libcamera_id)) return false;
  for (const std::string& path : list_video_device_paths()) {
    if (libcamera_uvc_id(path) != libcamera_id) continue;
    if (V4l2Camera::open(system_v4l2_io(), path)) return false;
  }
  return true;
}

class LibcameraCamera final : public Camera {
 public:
  LibcameraCamera(std::shared_ptr<libcamera::CameraManager> manager,
                  std::shared_ptr<libcamera::Camera> camera)
      : manager_(std::move(manager)),
        camera_(std::move(camera)),
        identity_(identity_of(*camera_)),
        bindings_(libcamera_backend::bind_controls(camera_->controls())) {}

  ~LibcameraCamera() override {
    (void)stop();
    if (!abandoned_) camera_->release();
  }

  const CameraIdentity& identity() const override { return identity_; }

  Result<std::vector<PixelFormatInfo>> formats() override {
    auto config = camera_->generateConfiguration({libcamera::StreamRole::VideoRecording});
    if (!config || config->empty())
      return make_error("unsupported", identity_.name + " offers no video stream");
    const libcamera::StreamFormats& formats = config->at(0).formats();
    std::vector<PixelFormatInfo> out;
    for (const libcamera::PixelFormat& format : formats.pixelformats()) {
      PixelFormatInfo info;
      info.fourcc = libcamera_backend::fourcc_of(format);
      info.description = format.toString();
      // libcamera 0.0.3 has no frame interval enumeration: sizes only.
      for (const libcamera::Size& size : formats.sizes(format))
        info.sizes.push_back({size.width, size.height, {}});
      out.push_back(std::move(info));
    }
    return out;
  }

  Result<std::vector<ControlInfo>> controls() override {
    std::vector<ControlInfo> out;
    for (const ControlBinding& b : bindings_) {
      ControlInfo info = b.info;
      if (auto it = current_.find(info.name); it != current_.end()) info.current = it->second;
      out.push_back(std::move(info));
    }
    return out;
  }

  Result<int64_t> get_control(const std::string& name) override {
    const ControlBinding* b = binding(name);
    if (!b) return unknown_control(name);
    // What the last completed request reported, else what was last asked, else the default.
    if (last_metadata_.contains(b->id->id()))
      return libcamera_backend::from_control_value(*b, last_metadata_.get(b->id->id()));
    auto it = current_.find(name);
    return it != current_.end() ? it->second : b->info.default_value;
  }

  Result<int64_t> set_control(const std::string& name, int64_t value) override {
    const ControlBinding* b = binding(name);
    if (!b) return unknown_control(name);
    auto control_value = libcamera_backend::to_control_value(*b, value);
    if (!control_value) return control_value.error();
    pending_[b->id->id()] = *control_value;
    current_[name] = value;
    // The aliases of one libcamera control stay in step.
    for (const ControlBinding& other : bindings_)
      if (other.id == b->id && &other != b)
        current_[other.info.name] = libcamera_backend::from_control_value(other, *control_value);
    if (b->id->id() == libcamera::controls::EXPOSURE_TIME && binding("ae_enable")) {
      pending_[libcamera::controls::AE_ENABLE] = libcamera::ControlValue(false);  // manual exposure
      current_["ae_enable"] = 0;
    }
    return value;
  }

  Result<StreamFormat> configure(const StreamFormat& requested) override {
    if (streaming_)
      return make_error("busy", "stop streaming before configuring " + identity_.name);
    auto config = camera_->generateConfiguration({libcamera::StreamRole::VideoRecording});
    if (!config || config->empty())
      return make_error("unsupported", identity_.name + " offers no video stream");
    libcamera::StreamConfiguration& cfg = config->at(0);
    if (!requested.fourcc.empty())
      cfg.pixelFormat = libcamera_backend::pixel_format_of(requested.fourcc);
    if (requested.width && requested.height) cfg.size = {requested.width, requested.height};
    if (config->validate() == libcamera::CameraConfiguration::Invalid)
      return make_error("out_of_range", "libcamera rejected the configuration " + cfg.toString());
    if (int error = camera_->configure(config.get()); error < 0)
      return make_error(error == -EBUSY ? ErrorCode::kBusy : ErrorCode::kIoError,
                        "cannot configure " + identity_.name + ": " + std::strerror(-error));
    config_ = std::move(config);
    return stream_format();
  }

  Status start(int buffer_count) override {
    if (streaming_) return {};
    if (!config_)
      if (auto configured = configure({}); !configured) return configured.error();
    libcamera::Stream* stream = config_->at(0).stream();
    allocator_ = std::make_unique<libcamera::FrameBufferAllocator>(camera_);
    if (int count = allocator_->allocate(stream); count <= 0)
      return fail_start("cannot allocate buffers", count);
    // libcamera picks the count (cfg.bufferCount); more requests than buffers cannot run.
    const auto& buffers = allocator_->buffers(stream);
    const size_t count =
        std::min<size_t>(buffers.size(), static_cast<size_t>(std::max(buffer_count, 1)));
    for (size_t i = 0; i < count; ++i) {
      std::unique_ptr<libcamera::Request> request = camera_->createRequest(i);
      if (!request || request->addBuffer(stream, buffers[i].get()) < 0)
        return fail_start("cannot create requests", -ENOMEM);
      const libcamera::FrameBuffer::Plane& plane = buffers[i]->planes()[0];
      size_t length = 0;
      for (const auto& p : buffers[i]->planes())
        if (p.fd.get() == plane.fd.get()) length = std::max<size_t>(length, p.offset + p.length);
      MappedBuffer memory(mmap(nullptr, length, PROT_READ, MAP_SHARED, plane.fd.get(), 0), length);
      if (!memory) return fail_start("cannot map a buffer", -errno);
      mappings_.push_back({std::move(memory), plane.offset});
      requests_.push_back(std::move(request));
    }
    camera_->requestCompleted.connect(this, &LibcameraCamera::on_request_completed);
    if (int error = camera_->start(); error < 0) return fail_start("cannot start", error);
    streaming_ = true;
    have_sequence_ = false;
    for (auto& request : requests_)
      if (int error = queue(request.get()); error < 0)
        return fail_start("cannot queue a request", error);
    return {};
  }

  Status stop() override {
    if (!allocator_) return {};
    if (streaming_ && uvc_node_gone(camera_->id())) {
      abandon();
      return make_error("no_device", identity_.name + ": the camera is gone (unplugged)");
    }
    if (streaming_) camera_->stop();  // completes every queued request, cancelled
    streaming_ = false;
    camera_->requestCompleted.disconnect(this);
    {
      std::lock_guard lock(mutex_);
      completed_.clear();
    }
    mappings_.clear();  // unmapped by their owners
    requests_.clear();
    allocator_->free(config_->at(0).stream());
    allocator_.reset();
    return {};
  }

  Result<Frame> dequeue(std::chrono::milliseconds timeout) override {
    if (!streaming_) return make_error("not_streaming", identity_.name + " is not streaming");
    libcamera::Request* request = nullptr;
    {
      std::unique_lock lock(mutex_);
      if (!completed_cv_.wait_for(lock, timeout, [&] { return !completed_.empty(); }))
        return make_error("timeout", "no frame from " + identity_.name + " within " +
                                         std::to_string(timeout.count()) + " ms");
      request = completed_.front();
      completed_.pop_front();
    }
    const size_t index = request->cookie();
    const libcamera::FrameBuffer* buffer = request->buffers().begin()->second;
    const libcamera::FrameMetadata& buffer_meta = buffer->metadata();
    Frame frame;
    frame.buffer_index = static_cast<int>(index);
    frame.data = mappings_[index].memory.data() + mappings_[index].offset;
    frame.size = buffer_meta.planes()[0].bytesused;
    frame.meta.sequence = buffer_meta.sequence;
    frame.meta.timestamp_ns = request->metadata()
                                  .get(libcamera::controls::SensorTimestamp)
                                  .value_or(static_cast<int64_t>(buffer_meta.timestamp));
    frame.meta.clock = "monotonic";
    frame.meta.bytes_used = buffer_meta.planes()[0].bytesused;
    frame.meta.error = request->status() != libcamera::Request::RequestComplete ||
                       buffer_meta.status != libcamera::FrameMetadata::FrameSuccess;
    if (have_sequence_ && frame.meta.sequence > last_sequence_ + 1)
      frame.meta.dropped_before = frame.meta.sequence - last_sequence_ - 1;
    last_sequence_ = frame.meta.sequence;
    have_sequence_ = true;
    libcamera_backend::fill_settings(request->metadata(), &frame.meta);
    last_metadata_ = request->metadata();
    return frame;
  }

  Status requeue(const Frame& frame) override {
    if (!streaming_) return make_error("not_streaming", identity_.name + " is not streaming");
    if (frame.buffer_index < 0 || static_cast<size_t>(frame.buffer_index) >= requests_.size())
      return make_error("out_of_range",
                        "frame " + std::to_string(frame.buffer_index) + " is not one of ours");
    libcamera::Request* request = requests_[static_cast<size_t>(frame.buffer_index)].get();
    request->reuse(libcamera::Request::ReuseBuffers);
    if (int error = queue(request); error < 0)
      return make_error(
          error == -ENODEV ? ErrorCode::kNoDevice : ErrorCode::kIoError,
          "cannot queue a request to " + identity_.name + ": " + std::strerror(-error));
    return {};
  }

 private:
  struct Mapping {
    MappedBuffer memory;  // the planes' dmabuf, read-only
    size_t offset;        // of plane 0 within the mapping
  };

  // A camera unplugged while streaming: libcamera 0.0.3 without udev never learns it is
  // disconnected, and stopping it then fails the pipeline's assertion that every request
  // came back (the device cannot return them), which aborts the process. Its libcamera
  // objects (camera, buffers, requests) are kept, untouched, until the process ends; the
  // mappings are ours and go.
  void abandon() {
    camera_->requestCompleted.disconnect(this);
    {
      std::lock_guard lock(mutex_);
      completed_.clear();
    }
    mappings_.clear();
    auto kept = std::make_shared<Abandoned>();
    kept->camera = camera_;
    kept->config = std::move(config_);
    kept->allocator = std::move(allocator_);
    kept->requests = std::move(requests_);
    keep_abandoned(std::move(kept));
    streaming_ = false;
    abandoned_ = true;
  }

  const ControlBinding* binding(const std::string& name) const {
    for (const ControlBinding& b : bindings_)
      if (b.info.name == name) return &b;
    return nullptr;
  }

  Error unknown_control(const std::string& name) const {
    std::string known;
    for (const ControlBinding& b : bindings_) known += (known.empty() ? "" : ", ") + b.info.name;
    return make_error("unsupported",
                      identity_.name + " has no control '" + name + "' (it has: " + known + ")");
  }

  bool controls_travel_with_requests() const override { return true; }
  std::optional<int64_t> controls_sent_ns() const override {
    if (!pending_.empty()) return std::nullopt;
    return sent_ns_;
  }

  // Queues a request with the controls set since the last one.
  int queue(libcamera::Request* request) {
    const bool carries = !pending_.empty();
    for (const auto& [id, value] : pending_) request->controls().set(id, value);
    pending_.clear();
    const int result = camera_->queueRequest(request);
    if (carries) {
      // libcamera hands the request to its pipeline thread, which writes the controls
      // to the device a little later: the caller allows a frame for that.
      timespec now{};
      clock_gettime(CLOCK_MONOTONIC, &now);
      sent_ns_ = static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
    }
    return result;
  }

  Status fail_start(const std::string& what, int error) {
    (void)stop();
    return make_error(
        error == -EBUSY ? ErrorCode::kBusy : ErrorCode::kIoError,
        identity_.name + ": " + what + " (" + std::strerror(error < 0 ? -error : ENOMEM) + ")");
  }

  StreamFormat stream_format() const {
    const libcamera::StreamConfiguration& cfg = config_->at(0);
    StreamFormat format;
    format.fourcc = libcamera_backend::fourcc_of(cfg.pixelFormat);
    format.width = cfg.size.width;
    format.height = cfg.size.height;
    format.bytes_per_line = cfg.stride;
    format.size_bytes = cfg.frameSize;
    // The curve the pipeline reports for the stream (from the V4L2 format's colour fields
    // on uvcvideo). No colour space reported (libcamera gives none for a V4L2 colour space
    // left at DEFAULT or one it does not map) is unknown: capture takes a raw format's
    // samples as linear and refuses to read a processed one's as light.
    format.transfer = TransferFunction::kUnknown;
    if (cfg.colorSpace) {
      using Transfer = libcamera::ColorSpace::TransferFunction;
      switch (cfg.colorSpace->transferFunction) {
        case Transfer::Linear:
          format.transfer = TransferFunction::kLinear;
          break;
        case Transfer::Srgb:
          format.transfer = TransferFunction::kSrgb;
          break;
        case Transfer::Rec709:
          format.transfer = TransferFunction::kBt709;
          break;
      }
    }
    return format;
  }

  // libcamera's thread: completed (or cancelled, at stop) requests wait for dequeue().
  void on_request_completed(libcamera::Request* request) {
    if (request->status() == libcamera::Request::RequestCancelled) return;
    {
      std::lock_guard lock(mutex_);
      completed_.push_back(request);
    }
    completed_cv_.notify_one();
  }

  std::shared_ptr<libcamera::CameraManager> manager_;  // outlives camera_
  std::shared_ptr<libcamera::Camera> camera_;
  CameraIdentity identity_;
  std::vector<ControlBinding> bindings_;
  std::map<unsigned int, libcamera::ControlValue> pending_;  // for the next request queued
  std::map<std::string, int64_t> current_;                   // last asked, by camlab name
  std::optional<int64_t> sent_ns_;  // CLOCK_MONOTONIC when controls last went with a request
  libcamera::ControlList last_metadata_;
  std::unique_ptr<libcamera::CameraConfiguration> config_;
  std::unique_ptr<libcamera::FrameBufferAllocator> allocator_;
  std::vector<std::unique_ptr<libcamera::Request>> requests_;  // cookie = index
  std::vector<Mapping> mappings_;                              // parallel to requests_
  bool streaming_ = false;
  bool abandoned_ = false;  // see abandon()
  bool have_sequence_ = false;
  uint64_t last_sequence_ = 0;

  std::mutex mutex_;  // completed_ is filled on libcamera's thread
  std::condition_variable completed_cv_;
  std::deque<libcamera::Request*> completed_;
};

}  // namespace

Result<std::vector<CameraIdentity>> list_libcamera_cameras() {
  auto manager = shared_manager();
  if (!manager) return manager.error();
  std::vector<CameraIdentity> out;
  for (const auto& camera : (*manager)->cameras()) out.push_back(identity_of(*camera));
  return out;
}

Result<std::unique_ptr<Camera>> open_libcamera_camera(const std::string& id) {
  auto manager = shared_manager();
  if (!manager) return manager.error();
  const std::string libcamera_id =
      id.rfind(kIdPrefix, 0) == 0 ? id.substr(std::strlen(kIdPrefix)) : id;
  std::shared_ptr<libcamera::Camera> camera = (*manager)->get(libcamera_id);
  if (!camera) return make_error("no_device", "libcamera has no camera '" + libcamera_id + "'");
  if (int error = camera->acquire(); error < 0)
    return make_error("busy", "cannot acquire " + libcamera_id + ": " + std::strerror(-error) +
                                  " (another process or object uses it)");
  return std::unique_ptr<Camera>(new LibcameraCamera(std::move(*manager), std::move(camera)));
}

}  // namespace camlab::device
