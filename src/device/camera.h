// The Camera interface: what camlab needs of any camera (V4L2, libcamera, the virtual
// one), in the units a camera engineer reads.
//
// A Camera is thread-bound: one thread (the camera's worker, docs/architecture.md) owns it.
// Errors are values (Result/Status) with stable codes: "no_device" (unplugged: ENODEV),
// "timeout", "io_error", "out_of_range", "busy", "not_streaming", "unsupported".
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"
#include "base/transfer_function.h"

namespace camlab::device {

struct CameraIdentity {
  std::string id;       // stable: backend + bus info (survives renumbering of /dev/video*)
  std::string backend;  // "v4l2", "libcamera", "virtual"
  std::string path;     // e.g. /dev/video0
  std::string name;     // the card name
  std::string driver;
  std::string bus_info;
};

struct FrameInterval {
  uint32_t numerator = 0;  // seconds = numerator / denominator
  uint32_t denominator = 0;
  double seconds() const { return denominator ? static_cast<double>(numerator) / denominator : 0; }
};

struct FrameSizeInfo {
  uint32_t width = 0;
  uint32_t height = 0;
  std::vector<FrameInterval> intervals;
};

struct PixelFormatInfo {
  std::string fourcc;  // "GREY", "Y16 ", "YUYV", "pRAA", "MJPG" ...
  std::string description;
  std::vector<FrameSizeInfo> sizes;
};

enum class ControlType { kInteger, kBoolean, kMenu, kIntegerMenu, kButton, kInteger64, kOther };

struct ControlInfo {
  uint32_t id = 0;
  std::string name;   // V4L2 style: "exposure_time_absolute"
  std::string label;  // as the driver names it: "Exposure Time, Absolute"
  ControlType type = ControlType::kInteger;
  int64_t minimum = 0;
  int64_t maximum = 0;
  int64_t step = 1;
  int64_t default_value = 0;
  int64_t current = 0;
  std::string unit;  // "100 us", "steps", "" when the control has none
  std::vector<std::pair<int64_t, std::string>> menu;
  bool read_only = false;
  bool inactive = false;  // e.g. exposure_time_absolute while exposure_auto is on
};

// How a YUV format's samples map to R, G, B, as the driver declares it (V4L2's
// quantization and ycbcr_enc); kDefault means the format's default: limited range and
// BT.601 for YUYV, NV12 and YU12.
enum class YcbcrQuantization { kDefault, kFull, kLimited };
enum class YcbcrEncoding { kDefault, kBt601, kBt709 };

struct StreamFormat {
  std::string fourcc;
  uint32_t width = 0;
  uint32_t height = 0;
  uint32_t bytes_per_line = 0;
  uint32_t size_bytes = 0;
  FrameInterval interval;
  YcbcrQuantization quantization = YcbcrQuantization::kDefault;
  YcbcrEncoding ycbcr_encoding = YcbcrEncoding::kDefault;
  // How the values relate to light, as the camera declares it (base/transfer_function.h);
  // linear unless it says otherwise.
  TransferFunction transfer = TransferFunction::kLinear;
};

struct FrameMetadata {
  uint64_t sequence = 0;
  int64_t timestamp_ns = 0;
  std::string clock;  // "monotonic"
  uint32_t bytes_used = 0;
  bool error = false;           // the driver flagged the buffer (V4L2_BUF_FLAG_ERROR)
  uint64_t dropped_before = 0;  // sequence numbers skipped since the previous frame
  // Settings in effect for this frame as the camera reported them with it (libcamera's
  // request metadata); empty when the backend or pipeline does not report them, never
  // filled from what was asked.
  std::optional<int64_t> exposure_us;
  std::optional<double> analogue_gain;  // libcamera's AnalogueGain (1.0 = unity)
  std::optional<double> lens_position;  // libcamera's LensPosition, dioptres
  std::optional<int64_t> focus_fom;     // libcamera's FocusFoM: the pipeline's sharpness figure
};

// A filled buffer, borrowed until requeue(): data points into the driver's mapping.
struct Frame {
  const uint8_t* data = nullptr;
  size_t size = 0;
  int buffer_index = -1;
  FrameMetadata meta;
};

class Camera {
 public:
  virtual ~Camera() = default;

  virtual const CameraIdentity& identity() const = 0;
  virtual Result<std::vector<PixelFormatInfo>> formats() = 0;
  virtual Result<std::vector<ControlInfo>> controls() = 0;

  // By V4L2-style name; the value in the control's own unit. set_control returns the
  // value the driver actually applied (read back), which may be clamped or stepped.
  virtual Result<int64_t> get_control(const std::string& name) = 0;
  virtual Result<int64_t> set_control(const std::string& name, int64_t value) = 0;

  // Requests a format and frame interval; returns what the driver chose.
  virtual Result<StreamFormat> configure(const StreamFormat& requested) = 0;
  virtual Status start(int buffer_count) = 0;
  virtual Status stop() = 0;
  virtual Result<Frame> dequeue(std::chrono::milliseconds timeout) = 0;
  virtual Status requeue(const Frame& frame) = 0;

  // When a control set with set_control() reaches the device. V4L2 applies it during the
  // call (the default: nullopt). libcamera applies controls per request: a value goes out
  // with the next request queued (start() or requeue()), and this is the CLOCK_MONOTONIC
  // time in ns at which the last controls set went out that way; nullopt while some wait
  // for a request. The settle rule counts from this time for such cameras.
  virtual bool controls_travel_with_requests() const { return false; }
  virtual std::optional<int64_t> controls_sent_ns() const { return std::nullopt; }
};

}  // namespace camlab::device
