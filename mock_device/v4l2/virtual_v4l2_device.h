// The virtual camera as a V4L2 device: one core model of the device (formats, controls
// with the camera spec's latency in frames, a videobuf2-like buffer queue, control events,
// priorities, a frame clock), fed by the renderer. It answers V4L2 ioctls with kernel
// semantics (0 or -errno), so that a transport can put it in front of any client: in
// process through VirtualV4l2Io (mock_device/v4l2/virtual_v4l2_io.h), and across processes
// through the preload library (device issue, to come).
//
// Frames: while streaming, a producer thread ticks at the frame interval; each tick is a
// sequence number. A tick with a queued buffer renders into it (in the format set, from
// the sensor's DN: virtual_v4l2_formats.h); a tick without one is a dropped frame, as
// on hardware. Controls set
// while frame n is the next to start show in frame n + control_latency_frames.
//
// Faults for tests: unplug (ENODEV from then on, POLLERR), replug (the camera is plugged
// in again: a new device, as the kernel makes one), EIO on the next dequeues, dropped
// frames (sequence gaps), a stall (no frames until cleared).
//
// The parts: VirtualV4l2Files (per open file: priority, events, eventfd),
// VirtualV4l2Controls, VirtualV4l2Queue (buffers) and VirtualV4l2FrameClock; the device
// dispatches the ioctls to them through one table (find_ioctl, as v4l2-ioctl.c's
// v4l2_ioctls[]), makes the checks that span them (priorities, stream state) and renders.
//
// Thread-safe: every entry point takes the device mutex, which serialises the parts.
#pragma once

#include <linux/videodev2.h>
#include <sys/types.h>

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <thread>
#include <vector>

#include "base/result.h"
#include "mock_device/render/renderer.h"
#include "mock_device/v4l2/virtual_v4l2_controls.h"
#include "mock_device/v4l2/virtual_v4l2_files.h"
#include "mock_device/v4l2/virtual_v4l2_formats.h"
#include "mock_device/v4l2/virtual_v4l2_frame_clock.h"
#include "mock_device/v4l2/virtual_v4l2_queue.h"

namespace camlab::mock {

struct VirtualDeviceOptions {
  int index = 0;  // /dev/videoN
  uint64_t seed = 1;
  int view = 0;          // which view of the scene the device looks at
  bool realtime = true;  // pace frames at the frame interval (false: as fast as rendered)
  // A rig member: frames start on this grid (VirtualV4l2FrameClock::set_grid), shared by
  // the rig's cameras; unset, a stream's first frame starts at STREAMON.
  std::optional<std::chrono::steady_clock::time_point> frame_grid_origin;
  // > 0: the scene's views follow the clock, as a board a person moves in front of a rig:
  // frame f shows view (tick f / view_every_frames) mod views, counted on the grid, so
  // frames one trigger starts show one view in every camera. 0: always `view`.
  int view_every_frames = 0;
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
  using BufferMemory = VirtualV4l2Queue::BufferMemory;  // memfd, address, length
  int buffer_for_mmap(off_t offset, size_t length, BufferMemory* out);
  void note_mapping(off_t offset, int delta);  // mmap (+1) / munmap (-1) bookkeeping
  // A dequeued USERPTR buffer's frame (VirtualV4l2Queue::userptr_source), or -errno; the
  // memory stays while the buffer is dequeued and the buffers are not freed.
  int userptr_source(uint32_t index, BufferMemory* out);

  // poll(2) semantics for an open file: POLLIN|POLLRDNORM when a buffer is done,
  // POLLPRI when an event is pending, POLLERR when unplugged or not streaming.
  short poll_events(int file, short requested);
  // Blocks until poll_events(file, requested) is non-zero or the timeout expires.
  short wait_events(int file, short requested, int timeout_ms);

  // Fault injection.
  void unplug();
  // Plugs an unplugged camera in again (no-op otherwise). As with a kernel device that is
  // removed and registered again, files opened before the unplug stay dead (ENODEV,
  // POLLERR|POLLHUP until closed), and the new device has no buffers, its controls at
  // their defaults. Mappings of the old buffers stay valid for their holders.
  void replug();
  bool unplugged() const;
  void fail_next_dequeues(int count);
  void drop_next_frames(int count);
  void stall(bool stalled);

  // Moves a scene target (the board a person holds) in the view this device looks at.
  // Checked at once (the name must exist; errors as Renderer::set_target_pose); applied by
  // the producer before its next render, since the renderer is not shared while rendering,
  // so every frame whose rendering starts after this call shows the new pose.
  Status set_target_pose(const std::string& target, const RtCamTarget& pose);

  const CameraSpec& camera() const { return renderer_.camera(); }
  int index() const { return options_.index; }

 private:
  // One ioctl being answered: the open file, its argument (not null: checked before
  // dispatch), and what a few handlers need beyond it.
  struct Call {
    int file;
    void* arg;
    int dmabuf_fd;                       // QBUF: see ioctl(file, request, arg, dmabuf_fd)
    std::unique_lock<std::mutex>& lock;  // the device mutex, held; DQBUF waits on it
    template <class T>
    T* arg_as() const {
      return static_cast<T*>(arg);
    }
  };
  using Handler = int (VirtualV4l2Device::*)(Call& call);
  struct IoctlInfo {
    unsigned long request;
    Handler handler;
  };
  // The ioctl table (virtual_v4l2_device.cpp): the one list of what the device answers.
  static const IoctlInfo* find_ioctl(unsigned long request);

  VirtualV4l2Device(Renderer renderer, VirtualDeviceOptions options);

  // The handlers, one per ioctl (virtual_v4l2_ioctls.cpp): 0 or -errno, with the mutex
  // held.
  int querycap(Call& call);
  int enum_fmt(Call& call);
  int enum_framesizes(Call& call);
  int enum_frameintervals(Call& call);
  int g_fmt(Call& call);
  int s_fmt(Call& call);
  int try_fmt(Call& call);
  int g_parm(Call& call);
  int s_parm(Call& call);
  int enuminput(Call& call);
  int g_input(Call& call);
  int s_input(Call& call);
  int g_priority(Call& call);
  int s_priority(Call& call);
  int queryctrl(Call& call);
  int query_ext_ctrl(Call& call);
  int querymenu(Call& call);
  int g_ctrl(Call& call);
  int s_ctrl(Call& call);
  int g_ext_ctrls(Call& call);
  int s_ext_ctrls(Call& call);
  int try_ext_ctrls(Call& call);
  int subscribe_event(Call& call);
  int unsubscribe_event(Call& call);
  int dqevent(Call& call);
  int reqbufs(Call& call);
  int querybuf(Call& call);
  int qbuf(Call& call);
  int dqbuf(Call& call);
  int expbuf(Call& call);
  int streamon(Call& call);
  int streamoff(Call& call);

  // Helpers of the handlers.
  const OfferedFormat* find_format(uint32_t fourcc) const;  // null: not offered
  int set_format(v4l2_format* format, bool apply);
  // G/S_CTRL through the extended ioctl `request` with one control, as v4l2-ctrls does.
  int old_ctrl(Call& call, unsigned long request);
  int set_controls(int file, v4l2_ext_controls* controls);
  // Queues a V4L2_EVENT_CTRL for every subscribed file (or only `only_file`), except the
  // originator of the change unless it subscribed with ALLOW_FEEDBACK.
  void queue_control_event(uint32_t id, uint32_t changes, int originator, int only_file = 0);
  short poll_events_locked(int file, short requested) const;
  void signal_readiness();  // updates every attached eventfd; call with the mutex held

  // The producer thread (virtual_v4l2_producer.cpp).
  void produce_frames();
  // Renders frame `sequence` into buffer `index` in the format set (unlocking while
  // rendering and encoding), its length in *bytes_used; false when the stream stopped or
  // the buffers changed meanwhile. A frame that cannot be rendered sets *failed and is
  // returned flagged with an error.
  bool render_into(int index, uint64_t sequence, std::unique_lock<std::mutex>& lock,
                   uint32_t* bytes_used, bool* failed);
  RenderSettings settings_in_effect() const;
  // Renders frame 0 for the settings in effect while no stream runs (unlocking meanwhile).
  void prepare_first_frame(std::unique_lock<std::mutex>& lock);

  Renderer renderer_;
  VirtualDeviceOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;  // frame done, event, unplug, stream state
  VirtualV4l2Files files_;
  VirtualV4l2Controls controls_;
  VirtualV4l2Queue queue_;
  VirtualV4l2FrameClock clock_;
  std::vector<OfferedFormat> formats_;  // what ENUM_FMT lists, for the camera's sensor
  v4l2_pix_format format_{};            // always one of formats_, sized by fill_pix_format
  bool unplugged_ = false;
  std::set<int> dead_files_;  // opened before an unplug that a replug ended: ENODEV
  int fail_dequeues_ = 0;
  bool render_error_reported_ = false;
  // Frame 0 of the last stream (or rendered ahead once a stream has ended, if the settings
  // changed during it): the next STREAMON's first frame if its settings are still those
  // in effect. Frame 0's noise is the same whenever it is drawn (noise is a function of
  // the seed and frame number), so it is the very frame a render at STREAMON would give,
  // minus the wait. Producer thread only.
  struct PreparedFrame {
    bool valid = false;
    RenderSettings settings;
    cv::Mat image;  // raw DN, as Renderer::render gives
  };
  PreparedFrame prepared_;
  // Target moves not yet given to the renderer (set_target_pose), oldest first; the
  // producer applies them (apply_target_moves) with the mutex held, before it renders.
  std::vector<std::pair<std::string, RtCamTarget>> pending_target_moves_;
  void apply_target_moves();
  bool prepare_pending_ = false;
  std::thread producer_;
  bool stop_producer_ = false;
};

}  // namespace camlab::mock
