// The V4L2 backend: a Camera on real V4L2 ioctls (QUERYCAP, ENUM_FMT/FRAMESIZES/
// FRAMEINTERVALS, G/S_FMT, G/S_PARM, QUERY_EXT_CTRL/QUERYMENU, G/S_EXT_CTRLS, REQBUFS/
// QUERYBUF/QBUF/DQBUF, STREAMON/STREAMOFF) with MMAP buffers and poll timeouts.
//
// Every kernel resource has an owner: the fd (closed on destruction), each mapping
// (unmapped), the stream (STREAMOFF and REQBUFS 0 on stop or destruction). ioctls are
// retried on EINTR. A sequence gap is reported as dropped frames, V4L2_BUF_FLAG_ERROR as
// Frame::meta.error, ENODEV as "no_device" (unplugged), a poll timeout as "timeout".
//
// Thread-bound (a camera's worker thread owns it).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "device/camera.h"
#include "device/v4l2/v4l2_io.h"

namespace camlab::device {

class V4l2Camera final : public Camera {
 public:
  // Opens `path` (non-blocking) through `io` and checks it is a streaming capture device.
  static Result<std::unique_ptr<V4l2Camera>> open(std::shared_ptr<V4l2Io> io,
                                                  const std::string& path);
  ~V4l2Camera() override;

  const CameraIdentity& identity() const override { return identity_; }
  Result<std::vector<PixelFormatInfo>> formats() override;
  Result<std::vector<ControlInfo>> controls() override;
  Result<int64_t> get_control(const std::string& name) override;
  // Manual exposure needs exposure_auto = manual and manual focus needs focus_auto off:
  // setting exposure_time_absolute or focus_absolute switches those first.
  Result<int64_t> set_control(const std::string& name, int64_t value) override;
  Result<StreamFormat> configure(const StreamFormat& requested) override;
  Status start(int buffer_count) override;
  Status stop() override;
  Result<Frame> dequeue(std::chrono::milliseconds timeout) override;
  Status requeue(const Frame& frame) override;

  // Number of mappings currently held (for leak checks in tests).
  size_t mapped_buffer_count() const { return buffers_.size(); }

 private:
  V4l2Camera(std::shared_ptr<V4l2Io> io, int fd)
      : io_(std::move(io)), fd_(fd, V4l2IoFdCloser{io_.get()}) {}
  Error errno_error(const std::string& what, int err) const;
  Result<ControlInfo> find_control(const std::string& name);
  Result<int64_t> read_control(uint32_t id, bool is_64_bit = false);
  Status write_control(uint32_t id, int64_t value, bool is_64_bit);
  // Unmaps every buffer and asks the driver to free them (REQBUFS 0), so that the queue
  // is free for the next start or another client; errors are ignored (a gone device
  // has freed them already).
  void free_buffers();

  std::shared_ptr<V4l2Io> io_;  // first: the owners below close and unmap through it
  V4l2Fd fd_;
  CameraIdentity identity_;
  std::vector<V4l2Mapping> buffers_;
  bool streaming_ = false;
  bool have_sequence_ = false;
  uint64_t last_sequence_ = 0;
};

}  // namespace camlab::device
