// VirtualV4l2Device: the producer thread. At each tick of the frame clock it applies the
// control values whose latency has passed, and renders the frame into the oldest queued
// buffer (a tick without one is a lost frame, as on hardware). The first frame after
// STREAMON is started at once (rendered ahead when a previous stream ended with the same
// settings); the ticks follow it.
#include <time.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <opencv2/imgproc.hpp>

#include "base/log.h"
#include "mock_device/render/sensor_model.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"
#include "mock_device/v4l2/virtual_v4l2_frame_encoder.h"
#include "optics/optics.h"

namespace camlab::mock {

RenderSettings VirtualV4l2Device::settings_in_effect() const {
  const CameraSpec& camera = renderer_.camera();
  RenderSettings s;
  s.gain = static_cast<double>(controls_.in_effect(V4L2_CID_GAIN)) / camera.controls.gain_unity;
  s.f_number =
      camera.lens.iris.f_numbers[static_cast<size_t>(controls_.in_effect(V4L2_CID_IRIS_ABSOLUTE))];
  s.focus_position = static_cast<int>(controls_.in_effect(V4L2_CID_FOCUS_ABSOLUTE));
  if (controls_.in_effect(V4L2_CID_FOCUS_AUTO) != 0 && !renderer_.scene().targets.empty()) {
    // Autofocus: on the first target's distance, to the nearest motor step.
    const auto& target = renderer_.scene().targets.front();
    const double distance_mm = renderer_.scene().pose(target, options_.view)[5] * 1e3;
    auto z_s = optics::lens_to_sensor_mm(camera.lens.focal_mm, distance_mm);
    if (z_s)
      s.focus_position =
          std::clamp(static_cast<int>(std::lround((*z_s - camera.lens.focal_mm) /
                                                  camera.lens.focus.extension_mm_per_step)),
                     camera.lens.focus.position_min, camera.lens.focus.position_max);
  }
  const ControlRange& range = camera.controls.exposure_time_absolute;
  if (controls_.in_effect(V4L2_CID_EXPOSURE_AUTO) != V4L2_EXPOSURE_MANUAL) {
    // Aperture priority: put a mid-grey (18% reflectance) at 18% of the DN range.
    const double lens_to_sensor_mm =
        camera.lens.focal_mm + s.focus_position * camera.lens.focus.extension_mm_per_step;
    const double e_per_us = electrons_per_unit_reflectance(
        camera, renderer_.scene().illuminance_lux, 1.0, s.f_number, lens_to_sensor_mm);
    const double range_dn = (1 << camera.sensor.bit_depth) - 1 - camera.sensor.black_level_dn;
    const double t_us = range_dn / (e_per_us * camera.sensor.conversion_gain_dn_per_e * s.gain);
    s.exposure_us = std::clamp(t_us, range.min * 100.0, range.max * 100.0);
  } else {
    s.exposure_us = static_cast<double>(controls_.in_effect(V4L2_CID_EXPOSURE_ABSOLUTE)) * 100.0;
  }
  return s;
}

namespace {

bool same_settings(const RenderSettings& a, const RenderSettings& b) {
  return a.exposure_us == b.exposure_us && a.gain == b.gain && a.f_number == b.f_number &&
         a.focus_position == b.focus_position;
}

}  // namespace

void VirtualV4l2Device::prepare_first_frame(std::unique_lock<std::mutex>& lock) {
  prepare_pending_ = false;
  apply_target_moves();
  const RenderSettings settings = settings_in_effect();
  // The stream's own frame 0 serves when its settings are still those in effect.
  if (prepared_.valid && same_settings(prepared_.settings, settings)) return;
  RenderOptions options;
  options.seed = options_.seed;
  options.frame_number = 0;
  lock.unlock();
  auto frame = renderer_.render(settings, options_.view, options);
  lock.lock();
  prepared_.valid = frame.ok();
  if (frame) {
    prepared_.settings = settings;
    prepared_.image = std::move(frame->image);
  }
}

bool VirtualV4l2Device::render_into(int index, uint64_t sequence,
                                    std::unique_lock<std::mutex>& lock, uint32_t* bytes_used,
                                    bool* failed) {
  *failed = false;
  *bytes_used = 0;
  apply_target_moves();
  const RenderSettings settings = settings_in_effect();
  const v4l2_pix_format format = format_;
  const OfferedFormat offered = *find_format(format.pixelformat);
  RenderOptions options;
  options.seed = options_.seed;
  options.frame_number = sequence;
  const uint64_t generation = queue_.generation();
  int view = options_.view;
  if (options_.view_every_frames > 0) {
    const int64_t tick = std::max<int64_t>(0, clock_.grid_tick_index(sequence));
    view = static_cast<int>((tick / options_.view_every_frames) % renderer_.scene().view_count);
  }
  const bool ready = sequence == 0 && view == options_.view && prepared_.valid &&
                     same_settings(prepared_.settings, settings);
  // Render and encode without the lock: ioctls (controls, status) must not wait on a frame.
  lock.unlock();
  Result<RenderedFrame> frame = make_error("internal", "not rendered");
  if (ready) {
    RenderedFrame kept;
    kept.image = prepared_.image;
    frame = std::move(kept);
  } else {
    frame = renderer_.render(settings, view, options);
    if (sequence == 0 && view == options_.view && frame)
      prepared_ = {true, settings, frame->image};  // for next time
  }
  Result<std::vector<uint8_t>> bytes = make_error("internal", "not rendered");
  if (frame)
    bytes = encode_frame(frame->image, renderer_.camera().sensor, renderer_.camera().isp, offered,
                         format);
  else
    bytes = frame.error();
  lock.lock();
  // The stream may have stopped, or the buffers been freed, while the frame rendered.
  uint8_t* out = queue_.filling_memory(index, generation);
  if (out == nullptr) return false;
  if (!bytes) {
    // A driver that cannot fill a buffer returns it flagged, never keeps it: the client
    // sees V4L2_BUF_FLAG_ERROR instead of waiting forever.
    if (!render_error_reported_) {
      log_warning(log::Category::kVcam, "cannot render frame %llu: %s",
                  static_cast<unsigned long long>(sequence), bytes.error().message.c_str());
      render_error_reported_ = true;  // a repeating error is logged once
    }
    std::memset(out, 0, format.sizeimage);
    *failed = true;
    return true;
  }
  // sizeimage bytes, or a JPEG's own length (at most sizeimage).
  std::memcpy(out, bytes->data(), bytes->size());
  *bytes_used = static_cast<uint32_t>(bytes->size());
  return true;
}

void VirtualV4l2Device::produce_frames() {
  std::unique_lock lock(mutex_);
  while (!stop_producer_) {
    if (!queue_.streaming() || clock_.stalled() || unplugged_) {
      // A stream ended: while none runs, have the next one's first frame ready (its own
      // frame 0 if the settings are unchanged, else one rendered now: the scene integral
      // is cached by then, so it costs one frame's noise).
      if (clock_.running() && !queue_.streaming()) prepare_pending_ = true;
      clock_.stop();
      if (prepare_pending_ && !queue_.streaming() && !unplugged_) {
        prepare_first_frame(lock);
        continue;  // re-check the stream state after the unlocked render
      }
      changed_.wait(lock);
      continue;
    }
    if (!clock_.realtime() && !queue_.has_queued() && !clock_.dropping()) {
      // As fast as rendered, but a frame is only started when a buffer waits for it.
      changed_.wait(lock);
      continue;
    }
    // STREAMON: the first frame starts at once, not at a tick, so that with the scene
    // integral already computed it is done within one frame interval (a client with a
    // one-second timeout must not time out on a camera that has rendered before).
    const bool first_frame = !clock_.running();
    if (first_frame) {
      clock_.start();
      // On a rig's grid the first frame waits for its tick, as a triggered sensor does.
      if (clock_.on_grid() && clock_.realtime() &&
          changed_.wait_until(lock, clock_.next_tick(), [&] {
            return stop_producer_ || !queue_.streaming() || clock_.stalled();
          }))
        continue;
      if (clock_.realtime()) clock_.advance();  // the first tick is this frame's
    } else if (clock_.realtime()) {
      if (changed_.wait_until(lock, clock_.next_tick(), [&] {
            return stop_producer_ || !queue_.streaming() || clock_.stalled();
          }))
        continue;
      clock_.advance();
    }
    const uint64_t sequence = clock_.take_sequence();
    // Control values whose latency has passed reach the sensor with this frame.
    controls_.apply_due(sequence);
    if (clock_.take_drop()) continue;
    if (!queue_.has_queued()) continue;  // no buffer: the frame is lost, its number too
    const int index = queue_.start_filling();
    timespec start{};
    clock_gettime(CLOCK_MONOTONIC, &start);
    bool failed = false;
    uint32_t bytes_used = 0;
    if (!render_into(index, sequence, lock, &bytes_used, &failed))
      continue;  // stream stopped meanwhile
    // A first frame that took longer than an interval (it integrated the scene) starts
    // the clock's ticks from its end: the stream starts late, as a sensor's does, rather
    // than with a gap of lost sequence numbers.
    if (first_frame && clock_.realtime() &&
        VirtualV4l2FrameClock::Clock::now() > clock_.next_tick())
      clock_.start();
    v4l2_buffer done{};
    done.index = static_cast<uint32_t>(index);
    done.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    // A flagged buffer reports the whole frame, as before; MJPG its JPEG's length.
    done.bytesused = failed ? format_.sizeimage : bytes_used;
    done.flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE |
                 (failed ? V4L2_BUF_FLAG_ERROR : 0u);
    done.field = V4L2_FIELD_NONE;
    // Start of exposure: in real time the frame's tick on the clock's grid (steady_clock is
    // CLOCK_MONOTONIC), so a frame rendered late or after dropped ones is still stamped
    // sequence x interval from the first; as fast as rendered, when its render began.
    if (clock_.realtime()) {
      const auto since_boot = std::chrono::duration_cast<std::chrono::microseconds>(
          clock_.tick_of(sequence).time_since_epoch());
      done.timestamp.tv_sec = static_cast<time_t>(since_boot.count() / 1000000);
      done.timestamp.tv_usec = static_cast<suseconds_t>(since_boot.count() % 1000000);
    } else {
      done.timestamp.tv_sec = start.tv_sec;
      done.timestamp.tv_usec = start.tv_nsec / 1000;
    }
    done.sequence = static_cast<uint32_t>(sequence);
    queue_.complete(index, done, format_.sizeimage);
    signal_readiness();
    changed_.notify_all();
  }
}

}  // namespace camlab::mock
