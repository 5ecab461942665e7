// The virtual camera as a V4L2 device: one core model of the device (formats, controls
// with the camera spec's latency in frames, a videobuf2-like buffer queue, control events,
// priorities, a frame clock), fed by the renderer. It answers V4L2 ioctls with kernel
// semantics (0 or -errno), so that a transport can put it in front of any client: in
// process through VirtualV4l2Io (mock_device/v4l2/virtual_v4l2_io.h), and across processes
// through the preload library (device issue, to come).
//
// Frames: while streaming, a producer thread ticks at the frame interval; each tick is a
// sequence number. A tick with a queued buffer renders into it (GREY, Y16 or YUYV from
// the sensor's DN); a tick without one is a dropped frame, as on hardware. Controls set
// while frame n is the next to start show in frame n + control_latency_frames.
//
// Faults for tests: unplug (ENODEV from then on, POLLERR), EIO on the next dequeues,
// dropped frames (sequence gaps), a stall (no frames until cleared).
//
// Thread-safe: every entry point takes the device mutex.
#pragma once

#include <linux/videodev2.h>
#include <sys/types.h>

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "base/result.h"
#include "mock_device/render/renderer.h"

namespace camlab::mock {

struct VirtualDeviceOptions {
  int index = 0;              // /dev/videoN
  uint64_t seed = 1;
  int view = 0;               // which view of the scene the device looks at
  bool realtime = true;       // pace frames at the frame interval (false: as fast as rendered)
};

class VirtualV4l2Device {
 public:
  static Result<std::unique_ptr<VirtualV4l2Device>> create(CameraSpec camera, SceneSpec scene,
                                                           VirtualDeviceOptions options);
  ~VirtualV4l2Device();

  // Open files: each has its own priority and event subscriptions.
  int open_file(bool nonblocking);
  // Ties an eventfd to an open file: it is kept readable exactly while poll() would
  // report POLLIN (a filled buffer) or POLLERR, so select, poll and epoll on the fd work
  // without interposition.
  void attach_eventfd(int file, int eventfd);
  void close_file(int file);

  // Whether the device implements an ioctl (others are ENOTTY, checked before the
  // argument, as the kernel does).
  static bool is_supported_ioctl(unsigned long request);

  // A V4L2 ioctl on an open file: 0 or -errno. `arg` points to the ioctl's struct.
  //
  // Buffer sharing (what libcamera uses): VIDIOC_EXPBUF returns in `fd` a new fd of this
  // process for an MMAP buffer's memfd (its own open file description, with the access
  // mode and O_CLOEXEC asked for); the caller owns it. REQBUFS/QBUF/DQBUF/QUERYBUF with
  // V4L2_MEMORY_DMABUF import buffers: QBUF maps the fd in m.fd (a memfd, or any
  // mappable regular file at least sizeimage long) and the device renders into it;
  // m.fd is reported back unchanged, as vb2 does.
  int ioctl(int file, unsigned long request, void* arg);
  // The same, for a transport serving another process: for QBUF with
  // V4L2_MEMORY_DMABUF, `dmabuf_fd` is this process's fd for the buffer the client named
  // in m.fd (received with SCM_RIGHTS; the device maps it and does not keep the fd),
  // while m.fd stays the client's number. -1: m.fd is an fd of this process.
  int ioctl(int file, unsigned long request, void* arg, int dmabuf_fd);

  // The buffer memory an mmap at `offset` of `length` bytes maps (a memfd and its
  // offset within it), or -errno.
  struct BufferMemory {
    int memfd;
    uint8_t* address;  // the device's own mapping
    size_t length;
  };
  int buffer_for_mmap(off_t offset, size_t length, BufferMemory* out);
  void note_mapping(off_t offset, int delta);  // mmap (+1) / munmap (-1) bookkeeping

  // poll(2) semantics for an open file: POLLIN|POLLRDNORM when a buffer is done,
  // POLLPRI when an event is pending, POLLERR when unplugged or not streaming.
  short poll_events(int file, short requested);
  // Blocks until poll_events(file, requested) is non-zero or the timeout expires.
  short wait_events(int file, short requested, int timeout_ms);

  // Fault injection.
  void unplug();
  void fail_next_dequeues(int count);
  void drop_next_frames(int count);
  void stall(bool stalled);

  const CameraSpec& camera() const { return renderer_.camera(); }
  int index() const { return options_.index; }

 private:
  struct Control {
    v4l2_query_ext_ctrl query{};
    int64_t value = 0;
    std::vector<const char*> menu;  // for menus: names by index (nullptr = hole)
  };
  struct File {
    bool nonblocking = false;
    v4l2_priority priority = V4L2_PRIORITY_DEFAULT;
    std::map<uint32_t, uint32_t> subscriptions;  // control id -> V4L2_EVENT_SUB_FL_* flags
    std::deque<v4l2_event> events;
    uint32_t event_sequence = 0;
    int eventfd = -1;
    bool signalled = false;
  };
  struct Buffer {
    int memfd = -1;               // MMAP: the device's memory; DMABUF: -1
    uint8_t* address = nullptr;   // the device's mapping (of the memfd, or of the import)
    size_t length = 0;            // bytes mapped at address
    // DMABUF: the client's fd number (reported back), the imported file (to map it once
    // however often it is queued) and the plane length vb2 reports.
    int user_fd = 0;
    dev_t import_device = 0;
    ino_t import_inode = 0;
    uint32_t dmabuf_length = 0;
    enum class State { kDequeued, kQueued, kFilling, kDone } state = State::kDequeued;
    v4l2_buffer done{};  // filled when State::kDone
    int mappings = 0;
  };
  struct PendingControl {
    uint64_t apply_at_sequence;
    uint32_t id;
    int64_t value;
  };

  VirtualV4l2Device(Renderer renderer, VirtualDeviceOptions options);
  void add_controls();
  Control* control(uint32_t id);
  int query_ext_ctrl(v4l2_query_ext_ctrl* query);
  int control_ioctl(int file, unsigned long request, void* arg);
  int ext_ctrls(int file, unsigned long request, v4l2_ext_controls* controls);
  int set_control_value(int file, Control& c, int64_t value);
  // Queues a V4L2_EVENT_CTRL for every subscribed file (or only `only_file`), except the
  // originator of the change unless it subscribed with ALLOW_FEEDBACK.
  void queue_control_event(uint32_t id, uint32_t changes, int originator, int only_file = 0);
  int check_priority(int file) const;
  v4l2_priority max_priority() const;

  int set_format(v4l2_format* format, bool apply);
  int reqbufs(int file, v4l2_requestbuffers* request);
  int querybuf(v4l2_buffer* buffer) const;
  int qbuf(int file, v4l2_buffer* buffer, int dmabuf_fd);
  int import_dmabuf(Buffer& buffer, int fd, uint32_t asked_length);
  int expbuf(v4l2_exportbuffer* exported) const;
  int dqbuf(int file, v4l2_buffer* buffer, std::unique_lock<std::mutex>& lock);
  int streamon(int file);
  int streamoff(int file);
  void free_buffers();
  void produce_frames();
  // Renders frame `sequence` into buffer `index` (unlocking while rendering); false when
  // the stream stopped or the buffers changed meanwhile.
  // A frame that cannot be rendered sets *failed and is returned flagged with an error.
  void signal_readiness();  // updates every attached eventfd; call with the mutex held
  bool render_into(int index, uint64_t sequence, std::unique_lock<std::mutex>& lock, bool* failed);
  RenderSettings settings_in_effect() const;

  Renderer renderer_;
  VirtualDeviceOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;  // frame done, event, unplug, stream state
  std::map<int, File> files_;
  int next_file_ = 1;
  std::map<uint32_t, Control> controls_;       // by id, in id order (NEXT_CTRL walks it)
  std::map<uint32_t, int64_t> in_effect_;      // control values the sensor uses now
  std::vector<PendingControl> pending_;
  v4l2_pix_format format_{};
  v4l2_fract time_per_frame_{};
  std::vector<Buffer> buffers_;
  v4l2_memory memory_ = V4L2_MEMORY_MMAP;  // of the allocated buffers
  size_t buffer_stride_ = 0;
  uint64_t buffers_generation_ = 0;        // mmap offset of buffer i is i * buffer_stride_
  std::deque<int> queued_order_;    // buffers waiting to be filled, oldest first
  std::deque<int> done_order_;      // filled buffers waiting for DQBUF, oldest first
  int queue_owner_ = 0;  // file that allocated the buffers (0: none)
  bool streaming_ = false;
  uint64_t next_sequence_ = 0;
  bool unplugged_ = false;
  int fail_dequeues_ = 0;
  int drop_frames_ = 0;
  bool stalled_ = false;
  bool render_error_reported_ = false;
  std::thread producer_;
  bool stop_producer_ = false;
};

}  // namespace camlab::mock
