#include "device/v4l2/v4l2_camera.h"

#include <fcntl.h>
#include <linux/videodev2.h>
#include <sys/mman.h>

#include <cerrno>
#include <cstring>

#include "device/v4l2/v4l2_control_names.h"
#include "device/v4l2/v4l2_transfer.h"

namespace camlab::device {

namespace {

// V4L2's quantization and encoding, resolved as the kernel's V4L2_MAP_* macros do for the
// colour spaces cameras use: only an explicit full range or BT.709 departs from the
// limited-range BT.601 default of YUV formats.
YcbcrQuantization quantization_of(const v4l2_pix_format& pix) {
  if (pix.quantization == V4L2_QUANTIZATION_FULL_RANGE) return YcbcrQuantization::kFull;
  if (pix.quantization == V4L2_QUANTIZATION_LIM_RANGE) return YcbcrQuantization::kLimited;
  return pix.colorspace == V4L2_COLORSPACE_JPEG ? YcbcrQuantization::kFull
                                                : YcbcrQuantization::kDefault;
}

YcbcrEncoding ycbcr_encoding_of(const v4l2_pix_format& pix) {
  if (pix.ycbcr_enc == V4L2_YCBCR_ENC_709) return YcbcrEncoding::kBt709;
  if (pix.ycbcr_enc == V4L2_YCBCR_ENC_601) return YcbcrEncoding::kBt601;
  if (pix.ycbcr_enc == V4L2_YCBCR_ENC_DEFAULT && pix.colorspace == V4L2_COLORSPACE_REC709)
    return YcbcrEncoding::kBt709;
  return YcbcrEncoding::kDefault;
}

std::string fourcc_text(uint32_t fourcc) {
  std::string text(4, ' ');
  for (int i = 0; i < 4; ++i) text[i] = static_cast<char>((fourcc >> (8 * i)) & 0xff);
  return text;
}

uint32_t fourcc_from_text(std::string text) {
  text.resize(4, ' ');
  return v4l2_fourcc(text[0], text[1], text[2], text[3]);
}

ControlType control_type(uint32_t v4l2_type) {
  switch (v4l2_type) {
    case V4L2_CTRL_TYPE_INTEGER:
      return ControlType::kInteger;
    case V4L2_CTRL_TYPE_BOOLEAN:
      return ControlType::kBoolean;
    case V4L2_CTRL_TYPE_MENU:
      return ControlType::kMenu;
    case V4L2_CTRL_TYPE_INTEGER_MENU:
      return ControlType::kIntegerMenu;
    case V4L2_CTRL_TYPE_BUTTON:
      return ControlType::kButton;
    case V4L2_CTRL_TYPE_INTEGER64:
      return ControlType::kInteger64;
    default:
      return ControlType::kOther;
  }
}

}  // namespace

Error V4l2Camera::errno_error(const std::string& what, int err) const {
  const std::string where = identity_.path.empty() ? std::string("device") : identity_.path;
  if (err == ENODEV || err == ENXIO)
    return make_error("no_device", where + ": " + what + ": the camera is gone (unplugged?)");
  if (err == EBUSY)
    return make_error("busy", where + ": " + what + ": device busy (in use by another process?)");
  if (err == ERANGE)
    return make_error("out_of_range", where + ": " + what + ": value out of range");
  if (err == EACCES) return make_error("permission", where + ": " + what + ": permission denied");
  return make_error("io_error", where + ": " + what + ": " + std::strerror(err));
}

Result<std::unique_ptr<V4l2Camera>> V4l2Camera::open(std::shared_ptr<V4l2Io> io,
                                                     const std::string& path) {
  const int fd = io->open(path.c_str(), O_RDWR | O_NONBLOCK);
  if (fd < 0) {
    const int err = errno;
    // ENODEV/ENXIO: the node exists but its device is gone (unplugged).
    if (err == ENOENT || err == ENODEV || err == ENXIO)
      return make_error("no_device", path + ": no such device");
    return make_error(err == EACCES ? ErrorCode::kPermission : ErrorCode::kIoError,
                      path + ": cannot open: " + std::strerror(err));
  }
  std::unique_ptr<V4l2Camera> camera(new V4l2Camera(std::move(io), fd));
  camera->identity_.path = path;
  v4l2_capability cap{};
  if (xioctl(*camera->io_, fd, VIDIOC_QUERYCAP, &cap) != 0)
    return camera->errno_error("VIDIOC_QUERYCAP (not a V4L2 device?)", errno);
  const uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) ? cap.device_caps : cap.capabilities;
  if (!(caps & V4L2_CAP_VIDEO_CAPTURE) || !(caps & V4L2_CAP_STREAMING))
    return make_error("unsupported",
                      path + " is not a streaming single-plane video capture device");
  camera->identity_.backend = "v4l2";
  camera->identity_.name = reinterpret_cast<const char*>(cap.card);
  camera->identity_.driver = reinterpret_cast<const char*>(cap.driver);
  camera->identity_.bus_info = reinterpret_cast<const char*>(cap.bus_info);
  camera->identity_.id = "v4l2:" + camera->identity_.bus_info;
  return camera;
}

V4l2Camera::~V4l2Camera() {
  if (streaming_) (void)stop();
  // The mappings and the fd go with their owners.
}

Result<std::vector<PixelFormatInfo>> V4l2Camera::formats() {
  std::vector<PixelFormatInfo> out;
  for (uint32_t i = 0;; ++i) {
    v4l2_fmtdesc desc{};
    desc.index = i;
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    if (xioctl(*io_, fd_.get(), VIDIOC_ENUM_FMT, &desc) != 0) {
      if (errno == EINVAL) break;
      return errno_error("VIDIOC_ENUM_FMT", errno);
    }
    PixelFormatInfo format{
        fourcc_text(desc.pixelformat), reinterpret_cast<const char*>(desc.description), {}};
    for (uint32_t j = 0;; ++j) {
      v4l2_frmsizeenum size{};
      size.index = j;
      size.pixel_format = desc.pixelformat;
      if (xioctl(*io_, fd_.get(), VIDIOC_ENUM_FRAMESIZES, &size) != 0) break;
      FrameSizeInfo info;
      if (size.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
        info.width = size.discrete.width;
        info.height = size.discrete.height;
      } else {  // stepwise/continuous: report the largest size
        info.width = size.stepwise.max_width;
        info.height = size.stepwise.max_height;
      }
      for (uint32_t k = 0;; ++k) {
        v4l2_frmivalenum interval{};
        interval.index = k;
        interval.pixel_format = desc.pixelformat;
        interval.width = info.width;
        interval.height = info.height;
        if (xioctl(*io_, fd_.get(), VIDIOC_ENUM_FRAMEINTERVALS, &interval) != 0) break;
        if (interval.type == V4L2_FRMIVAL_TYPE_DISCRETE)
          info.intervals.push_back({interval.discrete.numerator, interval.discrete.denominator});
        else
          info.intervals.push_back(
              {interval.stepwise.min.numerator, interval.stepwise.min.denominator});
        if (interval.type != V4L2_FRMIVAL_TYPE_DISCRETE) break;
      }
      format.sizes.push_back(std::move(info));
      if (size.type != V4L2_FRMSIZE_TYPE_DISCRETE) break;
    }
    out.push_back(std::move(format));
  }
  return out;
}

Result<int64_t> V4l2Camera::read_control(uint32_t id, bool is_64_bit) {
  v4l2_ext_control control{};
  control.id = id;
  v4l2_ext_controls controls{};
  controls.which = V4L2_CTRL_WHICH_CUR_VAL;
  controls.count = 1;
  controls.controls = &control;
  if (xioctl(*io_, fd_.get(), VIDIOC_G_EXT_CTRLS, &controls) != 0)
    return errno_error("VIDIOC_G_EXT_CTRLS", errno);
  return is_64_bit ? control.value64 : control.value;
}

Result<std::vector<ControlInfo>> V4l2Camera::controls() {
  std::vector<ControlInfo> out;
  uint32_t next = V4L2_CTRL_FLAG_NEXT_CTRL;
  for (;;) {
    v4l2_query_ext_ctrl query{};
    query.id = next;
    if (xioctl(*io_, fd_.get(), VIDIOC_QUERY_EXT_CTRL, &query) != 0) {
      if (errno == EINVAL) break;
      return errno_error("VIDIOC_QUERY_EXT_CTRL", errno);
    }
    next = query.id | V4L2_CTRL_FLAG_NEXT_CTRL;
    if (query.type == V4L2_CTRL_TYPE_CTRL_CLASS || (query.flags & V4L2_CTRL_FLAG_DISABLED))
      continue;
    ControlInfo info;
    info.id = query.id;
    info.label = query.name;
    info.name = control_name_from_label(query.name);
    info.type = control_type(query.type);
    info.minimum = query.minimum;
    info.maximum = query.maximum;
    info.step = static_cast<int64_t>(query.step);
    info.default_value = query.default_value;
    info.unit = control_unit(query.id);
    info.read_only = query.flags & V4L2_CTRL_FLAG_READ_ONLY;
    info.inactive = query.flags & V4L2_CTRL_FLAG_INACTIVE;
    if (info.type == ControlType::kMenu || info.type == ControlType::kIntegerMenu) {
      for (int64_t i = query.minimum; i <= query.maximum; ++i) {
        v4l2_querymenu item{};
        item.id = query.id;
        item.index = static_cast<uint32_t>(i);
        if (xioctl(*io_, fd_.get(), VIDIOC_QUERYMENU, &item) != 0) continue;  // holes are allowed
        info.menu.emplace_back(i, info.type == ControlType::kMenu
                                      ? std::string(reinterpret_cast<const char*>(item.name))
                                      : std::to_string(item.value));
      }
    }
    if (info.type != ControlType::kButton && !(query.flags & V4L2_CTRL_FLAG_WRITE_ONLY)) {
      auto current = read_control(query.id, query.type == V4L2_CTRL_TYPE_INTEGER64);
      if (!current) return current.error();
      info.current = *current;
    }
    out.push_back(std::move(info));
  }
  return out;
}

Result<ControlInfo> V4l2Camera::find_control(const std::string& name) {
  auto all = controls();
  if (!all) return all.error();
  std::string known;
  for (const auto& c : *all) {
    if (c.name == name) return c;
    known += (known.empty() ? "" : ", ") + c.name;
  }
  return make_error("unknown_control",
                    identity_.path + " has no control '" + name + "' (it has: " + known + ")");
}

Result<int64_t> V4l2Camera::get_control(const std::string& name) {
  auto control = find_control(name);
  if (!control) return control.error();
  return control->current;
}

Result<int64_t> V4l2Camera::set_control(const std::string& name, int64_t value) {
  auto control = find_control(name);
  if (!control) return control.error();
  if (control->read_only) return make_error("unsupported", name + " is read-only");
  if (value < control->minimum || value > control->maximum)
    return make_error("out_of_range",
                      name + " = " + std::to_string(value) + " is outside [" +
                          std::to_string(control->minimum) + ", " +
                          std::to_string(control->maximum) + "]" +
                          (control->unit.empty() ? "" : " (" + control->unit + ")"));
  // A manual value is ignored while the automatic mode is on: switch it off first.
  if (control->id == V4L2_CID_EXPOSURE_ABSOLUTE) {
    auto mode = read_control(V4L2_CID_EXPOSURE_AUTO);
    if (mode && *mode != V4L2_EXPOSURE_MANUAL) {
      if (Status set = write_control(V4L2_CID_EXPOSURE_AUTO, V4L2_EXPOSURE_MANUAL, false); !set)
        return set.error();
    }
  } else if (control->id == V4L2_CID_FOCUS_ABSOLUTE) {
    auto mode = read_control(V4L2_CID_FOCUS_AUTO);
    if (mode && *mode != 0) {
      if (Status set = write_control(V4L2_CID_FOCUS_AUTO, 0, false); !set) return set.error();
    }
  }
  if (Status set = write_control(control->id, value, control->type == ControlType::kInteger64);
      !set)
    return make_error(set.error().code, "setting " + name + " = " + std::to_string(value) + ": " +
                                            set.error().message);
  return read_control(control->id, control->type == ControlType::kInteger64);  // what was applied
}

Status V4l2Camera::write_control(uint32_t id, int64_t value, bool is_64_bit) {
  v4l2_ext_control ext{};
  ext.id = id;
  if (is_64_bit)
    ext.value64 = value;
  else
    ext.value = static_cast<int32_t>(value);
  v4l2_ext_controls controls{};
  controls.which = V4L2_CTRL_WHICH_CUR_VAL;
  controls.count = 1;
  controls.controls = &ext;
  if (xioctl(*io_, fd_.get(), VIDIOC_S_EXT_CTRLS, &controls) != 0)
    return errno_error("VIDIOC_S_EXT_CTRLS", errno);
  return {};
}

Result<StreamFormat> V4l2Camera::configure(const StreamFormat& requested) {
  if (streaming_)
    return make_error("busy", identity_.path + ": stop streaming before changing the format");
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  format.fmt.pix.width = requested.width;
  format.fmt.pix.height = requested.height;
  format.fmt.pix.pixelformat = fourcc_from_text(requested.fourcc);
  format.fmt.pix.field = V4L2_FIELD_NONE;
  if (xioctl(*io_, fd_.get(), VIDIOC_S_FMT, &format) != 0)
    return errno_error("VIDIOC_S_FMT", errno);
  StreamFormat applied;
  applied.fourcc = fourcc_text(format.fmt.pix.pixelformat);
  applied.width = format.fmt.pix.width;
  applied.height = format.fmt.pix.height;
  applied.bytes_per_line = format.fmt.pix.bytesperline;
  applied.size_bytes = format.fmt.pix.sizeimage;
  applied.quantization = quantization_of(format.fmt.pix);
  applied.ycbcr_encoding = ycbcr_encoding_of(format.fmt.pix);
  // xfer_func is an extended field: valid only with the magic the kernel's core sets.
  applied.transfer = transfer_function_of(format.fmt.pix.colorspace,
                                          format.fmt.pix.priv == V4L2_PIX_FMT_PRIV_MAGIC
                                              ? format.fmt.pix.xfer_func
                                              : static_cast<uint32_t>(V4L2_XFER_FUNC_DEFAULT));
  v4l2_streamparm parm{};
  parm.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (requested.interval.denominator != 0) {
    parm.parm.capture.timeperframe = {requested.interval.numerator, requested.interval.denominator};
    if (xioctl(*io_, fd_.get(), VIDIOC_S_PARM, &parm) != 0 && errno != ENOTTY)
      return errno_error("VIDIOC_S_PARM", errno);
  }
  if (xioctl(*io_, fd_.get(), VIDIOC_G_PARM, &parm) == 0)
    applied.interval = {parm.parm.capture.timeperframe.numerator,
                        parm.parm.capture.timeperframe.denominator};
  return applied;
}

void V4l2Camera::free_buffers() {
  buffers_.clear();  // unmapped by their owners; the driver frees only unmapped buffers
  v4l2_requestbuffers request{};
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  (void)xioctl(*io_, fd_.get(), VIDIOC_REQBUFS, &request);
}

Status V4l2Camera::start(int buffer_count) {
  if (streaming_) return make_error("busy", identity_.path + " is already streaming");
  if (buffer_count < 2 || buffer_count > 32)
    return make_error("out_of_range",
                      "buffer count " + std::to_string(buffer_count) + " is not in [2, 32]");
  const int fd = fd_.get();
  v4l2_requestbuffers request{};
  request.count = static_cast<uint32_t>(buffer_count);
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  if (xioctl(*io_, fd, VIDIOC_REQBUFS, &request) != 0) return errno_error("VIDIOC_REQBUFS", errno);
  // From here until the stream is on, every failure gives the buffers back (unmapped, and
  // REQBUFS 0), or the driver keeps them allocated to this fd and the next start, or
  // another client, gets EBUSY. The error is made first: freeing changes errno.
  auto give_back = [this](Error error) {
    free_buffers();
    return error;
  };
  if (request.count < 2)
    return give_back(
        make_error("io_error", identity_.path + ": the driver granted fewer than 2 buffers"));
  for (uint32_t i = 0; i < request.count; ++i) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer.index = i;
    if (xioctl(*io_, fd, VIDIOC_QUERYBUF, &buffer) != 0)
      return give_back(errno_error("VIDIOC_QUERYBUF", errno));
    V4l2Mapping mapping(
        io_->mmap(buffer.length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, buffer.m.offset),
        buffer.length, V4l2IoUnmapper{io_.get()});
    if (!mapping) return give_back(errno_error("mmap of buffer " + std::to_string(i), errno));
    buffers_.push_back(std::move(mapping));
    if (xioctl(*io_, fd, VIDIOC_QBUF, &buffer) != 0)
      return give_back(errno_error("VIDIOC_QBUF", errno));
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if (xioctl(*io_, fd, VIDIOC_STREAMON, &type) != 0)
    return give_back(errno_error("VIDIOC_STREAMON", errno));
  streaming_ = true;
  have_sequence_ = false;
  return {};
}

Status V4l2Camera::stop() {
  if (!streaming_) return {};
  streaming_ = false;
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  const bool streamoff_ok = xioctl(*io_, fd_.get(), VIDIOC_STREAMOFF, &type) == 0;
  const int streamoff_errno = errno;
  // Freeing the buffers may fail when the device is gone; the mappings are released.
  free_buffers();
  if (!streamoff_ok) return errno_error("VIDIOC_STREAMOFF", streamoff_errno);
  return {};
}

Result<Frame> V4l2Camera::dequeue(std::chrono::milliseconds timeout) {
  if (!streaming_) return make_error("not_streaming", identity_.path + " is not streaming");
  pollfd pfd{fd_.get(), POLLIN, 0};
  int ready;
  do {
    ready = io_->poll(&pfd, 1, static_cast<int>(timeout.count()));
  } while (ready < 0 && errno == EINTR);
  if (ready < 0) return errno_error("poll", errno);
  if (ready == 0)
    return make_error(
        "timeout", identity_.path + ": no frame within " + std::to_string(timeout.count()) + " ms");
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  if (xioctl(*io_, fd_.get(), VIDIOC_DQBUF, &buffer) != 0)
    return errno_error("VIDIOC_DQBUF", errno);
  if (buffer.index >= buffers_.size())
    return make_error("io_error", identity_.path + ": driver returned buffer index " +
                                      std::to_string(buffer.index));
  Frame frame;
  frame.buffer_index = static_cast<int>(buffer.index);
  frame.data = buffers_[buffer.index].data();
  frame.size = buffer.bytesused;
  frame.meta.sequence = buffer.sequence;
  frame.meta.timestamp_ns = static_cast<int64_t>(buffer.timestamp.tv_sec) * 1'000'000'000 +
                            static_cast<int64_t>(buffer.timestamp.tv_usec) * 1000;
  frame.meta.clock =
      (buffer.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC
          ? "monotonic"
          : "unknown";
  frame.meta.bytes_used = buffer.bytesused;
  frame.meta.error = buffer.flags & V4L2_BUF_FLAG_ERROR;
  if (have_sequence_ && buffer.sequence > last_sequence_ + 1)
    frame.meta.dropped_before = buffer.sequence - last_sequence_ - 1;
  have_sequence_ = true;
  last_sequence_ = buffer.sequence;
  return frame;
}

Status V4l2Camera::requeue(const Frame& frame) {
  if (!streaming_) return make_error("not_streaming", identity_.path + " is not streaming");
  if (frame.buffer_index < 0 || frame.buffer_index >= static_cast<int>(buffers_.size()))
    return make_error("invalid_argument", "frame does not belong to this stream");
  v4l2_buffer buffer{};
  buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  buffer.memory = V4L2_MEMORY_MMAP;
  buffer.index = static_cast<uint32_t>(frame.buffer_index);
  if (xioctl(*io_, fd_.get(), VIDIOC_QBUF, &buffer) != 0) return errno_error("VIDIOC_QBUF", errno);
  return {};
}

}  // namespace camlab::device
