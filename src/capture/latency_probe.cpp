#include "capture/latency_probe.h"

#include <time.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <optional>

#include "capture/control_keeper.h"
#include "capture/frame_convert.h"
#include "capture/settle_tracker.h"
#include "image/pixel_format.h"

namespace camlab::capture {

namespace {

constexpr const char* kExposure = "exposure_time_absolute";
constexpr int kBuffers = 4;
constexpr auto kFrameTimeout = std::chrono::milliseconds(3000);
constexpr auto kCancelSlice = std::chrono::milliseconds(100);
// Frames averaged for a plateau, after the longest latency has passed.
constexpr int kPlateauFrames = 3;
// Halvings or doublings of the exposure tried to find two levels the signal tells apart.
constexpr int kMaxLevelSearches = 8;

int64_t monotonic_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

struct Sample {
  uint64_t sequence = 0;
  double mean = 0;
  bool usable = false;     // the driver did not flag it and the mean could be read
  bool after_gap = false;  // sequence numbers were skipped just before it
};

class Probe {
 public:
  Probe(device::Camera& camera, int max_latency_frames, const std::atomic<bool>* cancel)
      : camera_(camera), max_latency_(max_latency_frames), tracker_(0, 0), cancel_(cancel) {}

  Result<LatencyProbeResult> run(int repetitions);
  Status restore();
  int frames_consumed() const { return result_.frames_consumed; }

 private:
  Status start();
  Result<Sample> next_frame();
  Status set_exposure(int64_t units);
  // Sets the exposure and returns the mean signal once it has surely settled, with the
  // spread of the frames averaged.
  Result<std::pair<double, double>> plateau(int64_t units);
  // Measures one step to `units`: the frames from n to the first past `threshold`;
  // nullopt when a gap made the count unreliable, -1 when the signal never crossed.
  Result<std::optional<int>> step(int64_t units, double threshold, bool upwards);

  device::Camera& camera_;
  int max_latency_;
  SettleTracker tracker_;
  bool deferred_change_ = false;  // written, waiting for the requeue that sends it
  const std::atomic<bool>* cancel_;
  std::optional<ControlKeeper> keeper_;
  device::ControlInfo exposure_;
  device::StreamFormat format_;
  double full_scale_ = 255;
  std::optional<uint64_t> first_sequence_, last_sequence_;
  LatencyProbeResult result_;
};

Status Probe::start() {
  auto formats = camera_.formats();
  if (!formats) return formats.error();
  // The mean signal needs no resolution: the smallest size of the deepest greyscale
  // format; else of any format camlab reads, linear ones (raw Bayer, RGB) before JPEG.
  const device::PixelFormatInfo* chosen = nullptr;
  for (const char* fourcc : {"Y16 ", "GREY", "YUYV"}) {
    auto it = std::find_if(formats->begin(), formats->end(),
                           [&](const auto& f) { return f.fourcc == fourcc; });
    if (it != formats->end() && !it->sizes.empty()) {
      chosen = &*it;
      break;
    }
  }
  for (bool want_linear : {true, false}) {
    for (const auto& f : *formats) {
      if (chosen) break;
      const auto info = image::pixel_format_info(f.fourcc);
      if (info && info->linear == want_linear && !f.sizes.empty()) chosen = &f;
    }
  }
  if (!chosen)
    return make_error("unsupported", "the camera offers no format camlab reads (" +
                                         image::capturable_fourcc_list() + ")");
  const auto& size = *std::min_element(
      chosen->sizes.begin(), chosen->sizes.end(), [](const auto& a, const auto& b) {
        return uint64_t{a.width} * a.height < uint64_t{b.width} * b.height;
      });
  device::StreamFormat requested;
  requested.fourcc = chosen->fourcc;
  requested.width = size.width;
  requested.height = size.height;
  auto applied = camera_.configure(requested);
  if (!applied) return applied.error();
  format_ = *applied;
  if (!can_convert(format_.fourcc))
    return make_error("unsupported", "the camera chose format " + format_.fourcc);
  // frame_mean's units: 16-bit words for MSB-aligned formats, else the format's DN.
  const auto info = image::pixel_format_info(format_.fourcc);
  full_scale_ = info->packing == image::SamplePacking::k16High
                    ? 65535.0
                    : std::ldexp(1.0, info->bits_per_sample) - 1;
  return camera_.start(kBuffers);
}

Result<Sample> Probe::next_frame() {
  // In slices, so that a cancel (the camera found unplugged, a user's) is seen while the
  // camera delivers nothing.
  Result<device::Frame> frame = make_error("timeout", "no frame");
  for (auto waited = std::chrono::milliseconds(0);; waited += kCancelSlice) {
    if (cancel_ && cancel_->load())
      return make_error("cancelled", "the latency probe was cancelled");
    frame = camera_.dequeue(std::min(kCancelSlice, kFrameTimeout - waited));
    if (frame || frame.error().code != ErrorCode::kTimeout ||
        waited + kCancelSlice >= kFrameTimeout)
      break;
  }
  if (!frame) return frame.error();
  Sample sample;
  sample.sequence = frame->meta.sequence;
  auto mean = frame_mean(*frame, format_);
  sample.usable = mean.ok() && !frame->meta.error;
  if (sample.usable) sample.mean = *mean;
  tracker_.on_frame(sample.sequence, frame->meta.timestamp_ns, frame->meta.clock == "monotonic");
  if (Status s = camera_.requeue(*frame); !s) return s.error();
  if (deferred_change_) {  // its controls went out with this requeue (libcamera)
    tracker_.on_change(camera_.controls_sent_ns().value_or(monotonic_ns()), 32);
    deferred_change_ = false;
  }
  sample.after_gap = last_sequence_ && sample.sequence != *last_sequence_ + 1;
  if (!first_sequence_) first_sequence_ = sample.sequence;
  last_sequence_ = sample.sequence;
  result_.frames_consumed = static_cast<int>(*last_sequence_ - *first_sequence_ + 1);
  result_.mean_dn_trace.push_back(sample.usable ? sample.mean : std::nan(""));
  return sample;
}

Status Probe::set_exposure(int64_t units) {
  const int64_t began_ns = monotonic_ns();
  if (auto applied = keeper_->write(camera_, kExposure, units); !applied) return applied.error();
  // A camera whose controls travel with requests sends them with the next requeue, and
  // the change counts from then (next_frame registers it).
  if (camera_.controls_travel_with_requests()) {
    deferred_change_ = true;
    return {};
  }
  // Every buffer may be in the driver: the bound used without timestamps.
  tracker_.on_change(began_ns, monotonic_ns(), 32);
  return {};
}

Result<std::pair<double, double>> Probe::plateau(int64_t units) {
  if (Status s = set_exposure(units); !s) return s.error();
  const int change = tracker_.change_count() - (deferred_change_ ? 0 : 1);
  std::vector<double> means;
  while (static_cast<int>(means.size()) < kPlateauFrames) {
    Sample sample;
    CAMLAB_ASSIGN(sample, next_frame());
    const auto n = tracker_.first_frame_after(change);
    if (!n || sample.sequence < *n + static_cast<uint64_t>(max_latency_) + 1) continue;
    if (sample.usable) means.push_back(sample.mean);
  }
  double sum = 0, spread = 0;
  for (double m : means) sum += m;
  const double mean = sum / static_cast<double>(means.size());
  for (double m : means) spread = std::max(spread, std::abs(m - mean));
  return std::make_pair(mean, spread);
}

Result<std::optional<int>> Probe::step(int64_t units, double threshold, bool upwards) {
  if (Status s = set_exposure(units); !s) return s.error();
  const int change = tracker_.change_count() - (deferred_change_ ? 0 : 1);
  bool gap = false;
  for (;;) {
    Sample sample;
    CAMLAB_ASSIGN(sample, next_frame());
    const auto n = tracker_.first_frame_after(change);
    if (!n) continue;  // started before the write
    // A frame lost or flagged may have been the first at the new level; one that started
    // while the write was under way (a slow write, or a thread preempted before it read
    // the clock) may have been n itself: the count from n_hi is then one short.
    gap |= sample.after_gap || !sample.usable || tracker_.frame_started_during_write(change);
    const int frames = static_cast<int>(sample.sequence - *n);
    const bool crossed =
        sample.usable && (upwards ? sample.mean > threshold : sample.mean < threshold);
    if (crossed) return gap ? std::nullopt : std::optional<int>(frames);
    if (frames > max_latency_) return gap ? std::nullopt : std::optional<int>(-1);
  }
}

Result<LatencyProbeResult> Probe::run(int repetitions) {
  auto controls = camera_.controls();
  if (!controls) return controls.error();
  auto it = std::find_if(controls->begin(), controls->end(),
                         [](const auto& c) { return c.name == kExposure; });
  if (it == controls->end() || it->read_only)
    return make_error("unsupported",
                      "the camera has no writable exposure_time_absolute control to step");
  exposure_ = *it;
  auto keeper = ControlKeeper::snapshot(camera_, {kExposure});
  if (!keeper) return keeper.error();
  keeper_ = std::move(*keeper);
  if (Status s = start(); !s) return s.error();

  // Two exposures a factor 2 apart whose plateaus the signal tells apart, unclipped.
  const int64_t grid = std::max<int64_t>(exposure_.step, 1);
  auto on_grid = [&](int64_t units) {
    units = std::clamp(units, exposure_.minimum, exposure_.maximum);
    return exposure_.minimum + (units - exposure_.minimum) / grid * grid;
  };
  int64_t high = on_grid(std::clamp(exposure_.current, exposure_.minimum, exposure_.maximum));
  int64_t low = on_grid(high / 2);
  if (low == high) high = on_grid(2 * low);
  if (low == high) return make_error("inconclusive", "the exposure control has a single value");
  double p_low = 0, p_high = 0;
  bool found = false;
  for (int attempt = 0; attempt < kMaxLevelSearches && !found; ++attempt) {
    std::pair<double, double> h, l;
    CAMLAB_ASSIGN(h, plateau(high));
    if (h.first > 0.85 * full_scale_ && on_grid(low / 2) < low) {  // clipping: go darker
      high = low;
      low = on_grid(low / 2);
      continue;
    }
    CAMLAB_ASSIGN(l, plateau(low));
    p_low = l.first;
    p_high = h.first;
    // Apart by far more than the frame-to-frame spread and a quantisation step.
    const double noise = std::max({h.second, l.second, 0.5 * full_scale_ / 255.0});
    if (p_high - p_low > 10 * noise) {
      found = true;
    } else if (on_grid(2 * high) > high && h.first < 0.4 * full_scale_) {  // too dark: go brighter
      low = high;
      high = on_grid(2 * high);
    } else {
      break;
    }
  }
  if (!found)
    return make_error(
        "inconclusive",
        "the mean signal does not change with exposure (" + std::to_string(p_low) + " vs " +
            std::to_string(p_high) +
            "): light the scene, or point the camera at something bright but unclipped");
  const double threshold = 0.5 * (p_low + p_high);

  // Alternate up and down, starting from the low plateau just measured.
  std::map<int, int> counts;
  int measured = 0;
  bool at_low = true;
  for (int attempt = 0; measured < repetitions && attempt < 2 * repetitions + 4; ++attempt) {
    std::optional<int> frames;
    CAMLAB_ASSIGN(frames, step(at_low ? high : low, threshold, at_low));
    at_low = !at_low;
    if (frames) {
      ++counts[*frames];
      ++measured;
    }
    // A step that never crossed, or was hidden by a gap, may not have settled yet:
    // settle at the low level again before the next one.
    if (!frames || *frames < 0) {
      std::pair<double, double> settled;
      CAMLAB_ASSIGN(settled, plateau(low));
      at_low = true;
    }
  }
  result_.repetitions = measured;
  for (const auto& [frames, count] : counts)
    if (count > result_.agreeing) {
      result_.agreeing = count;
      result_.latency_frames = frames;
    }
  std::string seen;
  for (const auto& [frames, count] : counts)
    seen += (seen.empty() ? "" : ", ") + std::to_string(count) + " x " +
            (frames < 0 ? "none within " + std::to_string(max_latency_) : std::to_string(frames));
  if (measured < repetitions)
    return make_error("inconclusive", "only " + std::to_string(measured) + " of " +
                                          std::to_string(repetitions) +
                                          " steps could be measured (frames dropped, or frames "
                                          "that started while the exposure was being written)");
  if (result_.latency_frames < 0 || 2 * result_.agreeing <= measured)
    return make_error("inconclusive", "the steps disagree on the latency (frames: " + seen + ")");
  return result_;
}

Status Probe::restore() {
  Status stopped = camera_.stop();
  Status restored = keeper_ ? keeper_->restore(camera_) : Status{};
  return stopped.ok() ? restored : stopped;
}

}  // namespace

Result<LatencyProbeResult> probe_control_latency(device::Camera& camera, int repetitions,
                                                 int max_latency_frames,
                                                 const std::atomic<bool>* cancel,
                                                 int* frames_consumed) {
  if (repetitions < 1 || repetitions > 20)
    return make_error("invalid_argument", "repetitions must be 1..20");
  if (max_latency_frames < 0 || max_latency_frames > 32)
    return make_error("invalid_argument", "max_latency_frames must be 0..32");
  Probe probe(camera, max_latency_frames, cancel);
  auto result = probe.run(repetitions);
  Status restored = probe.restore();
  if (frames_consumed) *frames_consumed = probe.frames_consumed();
  if (!result) return result;
  if (!restored) return restored.error();
  return result;
}

}  // namespace camlab::capture
