#include "capture/capture_runner.h"

#include <time.h>

#include <algorithm>
#include <deque>
#include <set>

#include "capture/control_keeper.h"
#include "capture/drop_attribution.h"
#include "capture/frame_convert.h"
#include "capture/frame_report.h"
#include "capture/frame_writer.h"
#include "capture/settings_json.h"
#include "capture/settle_tracker.h"

namespace camlab::capture {

namespace {

// A wait for a frame is cut into slices this long, so that a cancel (a user's, a shutdown,
// or the camera found unplugged by the daemon's rescan) is seen within one slice even when
// the camera has stopped delivering.
constexpr std::chrono::milliseconds kCancelSlice{100};
// Without usable timestamps, the frames that may have started before a write are those in
// the driver's buffers; drivers may grant more than asked (a minimum of their own), so
// count at least this many.
constexpr int kMinBuffersAssumed = 8;

int64_t monotonic_ns() {
  timespec now{};
  clock_gettime(CLOCK_MONOTONIC, &now);  // the clock of V4L2's monotonic timestamps
  return static_cast<int64_t>(now.tv_sec) * 1'000'000'000 + now.tv_nsec;
}

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// The latency range the settle rule uses. A camera whose controls travel with requests
// (libcamera) has them written by its pipeline thread a moment after they were queued,
// and its probed latency may be off by that moment: one frame either way is allowed.
std::pair<int, int> latency_range(const device::Camera& camera, const CaptureOptions& options) {
  const int max_frames = options.control_latency_frames;
  const int min_frames = options.control_latency_min_frames < 0
                             ? options.control_latency_frames
                             : options.control_latency_min_frames;
  if (!camera.controls_travel_with_requests()) return {max_frames, min_frames};
  return {max_frames + 1, std::max(0, min_frames - 1)};
}

class Runner {
 public:
  Runner(device::Camera& camera, const CapturePlan& plan, const CaptureOptions& options,
         CaptureObserver* observer)
      : camera_(camera),
        plan_(plan),
        options_(options),
        observer_(observer),
        tracker_(latency_range(camera, options).first, latency_range(camera, options).second),
        drops_(options.buffer_count) {}

  Result<CaptureSummary> run(const std::filesystem::path& folder);

 private:
  // Frames still wanted of a step: repeats first_repeat .. first_repeat + count - 1.
  struct Want {
    int step = 0;
    int first_repeat = 0;
    int count = 0;
  };
  // One control change (a step written, or written again) and what it gave.
  struct Change {
    Want want;
    int kept = 0;
    nlohmann::json settings;
    std::map<std::string, double> expected_report;  // what its frames should report
  };

  Status start_stream();
  Status write_change(const Want& want, bool with_fixed, int buffers_in_driver);
  // For a camera whose controls travel with requests: the change written before this
  // requeue counts from when its request went out.
  void register_deferred_change();
  Status process(const device::Frame& frame);
  // The change a frame carries by its own report (see capture/frame_report.h): the
  // latest open change written before the frame started whose settings it reports; -1
  // when it reports none of them (settling); nullopt when the report does not say.
  std::optional<int> change_by_report(const device::Frame& frame) const;
  void close_windows(uint64_t last_sequence);
  Status write_next_when_secured(uint64_t last_sequence);
  void report_written();
  // The next frame within options_.frame_timeout; on a cancel meanwhile, an error with
  // summary_.cancelled set.
  Result<device::Frame> dequeue_or_cancel();
  std::string unstable_stream_message(int delivered) const;
  void finish(const std::chrono::steady_clock::time_point& started);

  device::Camera& camera_;
  const CapturePlan& plan_;
  const CaptureOptions& options_;
  CaptureObserver* observer_;
  SettleTracker tracker_;
  DropAttribution drops_;
  std::optional<ControlKeeper> keeper_;
  std::optional<FrameWriter> writer_;
  device::StreamFormat format_;
  std::deque<Want> to_write_;  // steps not yet begun, in plan order
  std::deque<Want> retakes_;   // repeats lost to drops, written before the next new step
  std::vector<Change> changes_;
  size_t oldest_open_ = 0;
  int kept_total_ = 0;
  int written_total_ = 0;
  int not_kept_since_last_ = 0;  // discarded + dropped since the last kept frame
  bool streaming_ = false;
  std::optional<int> deferred_buffers_;  // a change waiting for its request (libcamera)
  // The controls the plan varies, when a frame's metadata can report every one of them.
  std::set<std::string> reported_controls_;
  CaptureSummary summary_;
};

Status Runner::write_change(const Want& want, bool with_fixed, int buffers_in_driver) {
  const int64_t began_ns = monotonic_ns();
  if (with_fixed)
    for (const auto& [name, value] : plan_.fixed_controls)
      if (auto applied = keeper_->write(camera_, name, value); !applied) return applied.error();
  const CaptureStep& step = plan_.steps[static_cast<size_t>(want.step)];
  for (const auto& [name, value] : step.controls)
    if (auto applied = keeper_->write(camera_, name, value); !applied) return applied.error();
  // A frame that started between the two clock reads may carry the change or not: the
  // tracker opens its window after such a frame and closes the previous one before it.
  if (camera_.controls_travel_with_requests() && streaming_)
    deferred_buffers_ = buffers_in_driver;  // registered when the next request goes out
  else
    tracker_.on_change(began_ns, monotonic_ns(), buffers_in_driver);
  Change change;
  change.want = want;
  change.settings = settings_json(keeper_->values(), plan_.traits);
  change.expected_report = expected_report(keeper_->values(), reported_controls_);
  if (!step.requested.empty()) change.settings["requested"] = step.requested;
  changes_.push_back(std::move(change));
  return {};
}

std::optional<int> Runner::change_by_report(const device::Frame& frame) const {
  if (reported_controls_.empty() || changes_.empty()) return std::nullopt;
  if (!reports_all(frame.meta, changes_.back().expected_report)) return std::nullopt;
  for (size_t i = changes_.size(); i-- > oldest_open_;) {
    const auto first = tracker_.first_frame_after(static_cast<int>(i));
    if (!first || *first > frame.meta.sequence) continue;  // written after it started
    const Change& c = changes_[i];
    if (c.kept < c.want.count && report_matches(frame.meta, c.expected_report))
      return static_cast<int>(i);
  }
  return -1;
}

void Runner::register_deferred_change() {
  if (!deferred_buffers_) return;
  tracker_.on_change(camera_.controls_sent_ns().value_or(monotonic_ns()), *deferred_buffers_);
  deferred_buffers_.reset();
}

void Runner::close_windows(uint64_t last_sequence) {
  // A window that closed short (frames dropped or flagged) is written again later for the
  // repeats it lacks, before the steps not yet begun.
  while (oldest_open_ + 1 < changes_.size() &&
         tracker_.window_closed(static_cast<int>(oldest_open_), last_sequence)) {
    const Change& c = changes_[oldest_open_];
    if (c.kept < c.want.count) {
      retakes_.push_back({c.want.step, c.want.first_repeat + c.kept, c.want.count - c.kept});
      ++summary_.steps_retaken;
    }
    ++oldest_open_;
  }
}

Status Runner::write_next_when_secured(uint64_t last_sequence) {
  if (to_write_.empty() && retakes_.empty()) return {};
  const int latest = static_cast<int>(changes_.size()) - 1;
  auto secured = tracker_.frames_secured_after(latest, last_sequence);
  if (!secured) return {};  // the latest change has not reached a frame yet
  const Change& c = changes_.back();
  if (c.kept + *secured < c.want.count) return {};
  std::deque<Want>& queue = retakes_.empty() ? to_write_ : retakes_;
  const Want next = queue.front();
  queue.pop_front();
  // The frame in hand is not yet back in the driver.
  return write_change(next, false, std::max(options_.buffer_count, kMinBuffersAssumed) - 1);
}

Status Runner::process(const device::Frame& frame) {
  const uint64_t sequence = frame.meta.sequence;
  const bool monotonic = frame.meta.clock == "monotonic";
  const double interval_s = format_.interval.seconds();
  const DropAttribution::Skipped skipped =
      drops_.on_frame(sequence, frame.meta.timestamp_ns, monotonic, frame.buffer_index,
                      interval_s > 0 ? static_cast<int64_t>(interval_s * 1e9) : 0);
  summary_.frames_dropped_by_device += skipped.by_device;
  summary_.frames_dropped_by_camlab += skipped.by_camlab;
  summary_.frames_dropped += skipped.by_device + skipped.by_camlab;
  not_kept_since_last_ += skipped.by_device + skipped.by_camlab;
  int index = tracker_.on_frame(sequence, frame.meta.timestamp_ns, monotonic);
  // The frame's own report of its settings, where the camera gives one, overrules the
  // latency rule: it is what the sensor used.
  const std::optional<int> reported = change_by_report(frame);
  if (reported) index = *reported;
  // An index, not a pointer: writing the next change below grows changes_.
  bool keep =
      index >= 0 && !frame.meta.error && check_frame(frame, format_).ok() &&
      changes_[static_cast<size_t>(index)].kept < changes_[static_cast<size_t>(index)].want.count;
  // A frame the writer has no room for is not kept (the step is taken again): waiting for
  // the disk here would leave the driver without buffers and lose frames anyway, later.
  const bool refused = keep && !writer_->has_room();
  int repeat = 0;
  if (refused) {
    keep = false;
    ++summary_.frames_refused_by_writer;
    ++summary_.frames_dropped_by_camlab;
    ++summary_.frames_dropped;
    ++not_kept_since_last_;
  } else if (keep) {
    Change& change = changes_[static_cast<size_t>(index)];
    repeat = change.want.first_repeat + change.kept++;
    ++kept_total_;
  } else {
    ++summary_.frames_discarded;
    ++not_kept_since_last_;
  }
  close_windows(sequence);
  // The next step's controls go out before anything slow, while the frame after this one
  // has most likely not started yet.
  Status written = write_next_when_secured(sequence);

  std::optional<ConvertedFrame> converted;
  if (keep) {
    auto c = convert_frame(frame, format_, plan_.traits.sensor_bit_depth,
                           plan_.traits.black_level_dn, plan_.traits.isp_subtracts_black);
    if (!c) {  // cannot happen after check_frame; never write a wrong frame
      (void)camera_.requeue(frame);
      drops_.on_requeue(monotonic_ns());
      register_deferred_change();
      return c.error();
    }
    converted = std::move(*c);
  }
  // After the controls went out and the kept frame was copied: a viewer's copy is the
  // last thing that holds the buffer.
  if (options_.frame_tap) options_.frame_tap->offer(frame, format_);
  Status requeued = camera_.requeue(frame);
  drops_.on_requeue(monotonic_ns());
  register_deferred_change();
  if (keep) {
    const Change& change = changes_[static_cast<size_t>(index)];
    const CaptureStep& step = plan_.steps[static_cast<size_t>(change.want.step)];
    image::FrameSidecar sidecar;
    sidecar.sequence = sequence;
    sidecar.timestamp_ns = frame.meta.timestamp_ns;
    sidecar.clock = frame.meta.clock.empty() ? "monotonic" : frame.meta.clock;
    sidecar.pixel_format = converted->pixel_format;
    sidecar.delivered_format = converted->delivered_format;
    sidecar.layout = converted->layout;
    sidecar.cfa_pattern = converted->cfa_pattern;
    sidecar.bit_depth = converted->bit_depth;
    sidecar.black_level_dn = converted->black_level_dn;
    sidecar.white_level_dn = converted->white_level_dn;
    sidecar.linear = converted->linear;
    sidecar.transfer = converted->transfer;
    sidecar.frames_discarded = not_kept_since_last_;
    sidecar.settings = change.settings;
    if (nlohmann::json report = report_json(frame.meta); !report.empty()) {
      sidecar.settings["reported"] = std::move(report);
      sidecar.settings["in_effect_by"] = reported ? "frame_report" : "control_latency";
    }
    sidecar.labels = step.labels;
    sidecar.labels["repeat"] = repeat;
    not_kept_since_last_ = 0;
    if (Status pushed = writer_->push(std::move(converted->image), std::move(sidecar),
                                      std::move(converted->jpeg));
        !pushed)
      return pushed;
  }
  if (!written) return written;
  return requeued;
}

Result<device::Frame> Runner::dequeue_or_cancel() {
  const auto deadline = std::chrono::steady_clock::now() + options_.frame_timeout;
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
        deadline - std::chrono::steady_clock::now());
    auto frame = camera_.dequeue(std::clamp(left, std::chrono::milliseconds(1), kCancelSlice));
    if (frame || frame.error().code != ErrorCode::kTimeout) return frame;
    if (options_.cancel && options_.cancel->load()) {
      summary_.cancelled = true;
      return make_error("cancelled", "cancelled while waiting for a frame");
    }
    if (left <= kCancelSlice)
      return make_error("timeout", camera_.identity().path + ": no frame within " +
                                       std::to_string(options_.frame_timeout.count()) + " ms");
  }
}

std::string Runner::unstable_stream_message(int delivered) const {
  const CaptureSummary& s = summary_;
  std::string text = std::to_string(delivered) + " frames delivered for " +
                     std::to_string(kept_total_) + " kept: ";
  const std::string counts =
      " (" + std::to_string(s.frames_discarded) + " discarded, " +
      std::to_string(s.frames_refused_by_writer) + " refused by a full frame writer; besides, " +
      std::to_string(s.frames_dropped_by_device) + " dropped by the camera and " +
      std::to_string(s.frames_dropped_by_camlab - s.frames_refused_by_writer) +
      " lost while camlab held every buffer)";
  if (s.frames_refused_by_writer > s.frames_discarded)
    return text + "camlab could not keep up with the camera: the disk was slower" + counts;
  return text + "the camera flags or sends too many unusable frames" + counts;
}

void Runner::report_written() {
  for (auto& w : writer_->take_written()) {
    ++written_total_;
    if (!observer_) continue;
    CaptureProgress progress{written_total_, plan_.total_frames(), summary_.frames_discarded};
    observer_->on_frame(w.entry, w.sidecar, progress);
  }
}

Status Runner::start_stream() {
  auto applied = camera_.configure(plan_.format);
  if (!applied) return applied.error();
  format_ = *applied;
  if (format_.fourcc != plan_.format.fourcc || format_.width != plan_.format.width ||
      format_.height != plan_.format.height)
    return make_error("unsupported",
                      "the camera chose " + format_.fourcc + " " + std::to_string(format_.width) +
                          "x" + std::to_string(format_.height) + " when asked for " +
                          plan_.format.fourcc + " " + std::to_string(plan_.format.width) + "x" +
                          std::to_string(plan_.format.height));
  if (!can_convert(format_.fourcc))
    return make_error("unsupported", "pixel format '" + format_.fourcc +
                                         "' cannot be captured (camlab captures " +
                                         image::capturable_fourcc_list() + ")");
  // Step 0 goes out before the stream starts: every frame is after it.
  if (Status s = write_change(to_write_.front(), true, 0); !s) return s;
  to_write_.pop_front();
  Status started = camera_.start(options_.buffer_count);
  streaming_ = started.ok();
  return started;
}

Result<CaptureSummary> Runner::run(const std::filesystem::path& folder) {
  const auto started = std::chrono::steady_clock::now();
  if (plan_.steps.empty() || plan_.repeats < 1)
    return make_error("invalid_request", "the plan has no frames to take");
  if (options_.control_latency_frames < 0 || options_.control_latency_frames > 64)
    return make_error("invalid_argument", "control latency must be 0..64 frames");
  summary_.folder = folder;
  summary_.frames_minimum = plan_.total_frames() + tracker_.latency_max_frames();

  std::set<std::string> to_change;
  for (const auto& [name, value] : plan_.fixed_controls) to_change.insert(name);
  for (const auto& step : plan_.steps)
    for (const auto& [name, value] : step.controls) to_change.insert(name);
  // Frames can be kept by their own report when every control the steps vary is one a
  // frame's metadata can report (whether this camera reports it shows frame by frame).
  std::set<std::string> varied;
  const auto& first = plan_.steps.front().controls;
  for (const auto& step : plan_.steps) {
    for (const auto& [name, value] : step.controls)
      if (auto it = first.find(name); it == first.end() || it->second != value) varied.insert(name);
    for (const auto& [name, value] : first)
      if (!step.controls.contains(name)) varied.insert(name);
  }
  if (!varied.empty() && std::all_of(varied.begin(), varied.end(), is_reported_control))
    reported_controls_ = varied;
  auto keeper = ControlKeeper::snapshot(camera_, to_change);
  if (!keeper) return keeper.error();
  keeper_ = std::move(*keeper);

  auto created = image::CaptureFolderWriter::create(folder, plan_.kind, options_.source,
                                                    plan_.request, options_.commit_policy);
  if (!created) return created.error();
  writer_.emplace(std::move(*created), options_.writer_limits);

  for (int i = 0; i < static_cast<int>(plan_.steps.size()); ++i)
    to_write_.push_back({i, 0, plan_.repeats});
  if (Status s = start_stream(); !s) {
    (void)camera_.stop();
    (void)keeper_->restore(camera_);
    (void)writer_->close(false);
    return s.error();
  }

  // Frames lost or unusable are taken again, but not forever. The budget counts frames
  // delivered and not kept (flagged, unusable, settling, refused by the writer): frames
  // the camera skipped cost time, not work, and a camera slower than its frame interval
  // still finishes (the frame timeout ends a run when frames stop coming).
  const int budget =
      2 * (plan_.total_frames() + (static_cast<int>(plan_.steps.size()) + 1) *
                                      (tracker_.latency_max_frames() +
                                       std::max(options_.buffer_count, kMinBuffersAssumed) + 2)) +
      100;
  while (kept_total_ < plan_.total_frames()) {
    if (options_.cancel && options_.cancel->load()) {
      summary_.cancelled = true;
      break;
    }
    const int delivered =
        kept_total_ + summary_.frames_discarded + summary_.frames_refused_by_writer;
    if (delivered > budget) {
      summary_.failure = make_error("unstable_stream", unstable_stream_message(delivered));
      break;
    }
    auto frame = dequeue_or_cancel();
    if (!frame && summary_.cancelled) break;
    if (!frame) {
      summary_.failure = frame.error();
      break;
    }
    if (Status s = process(*frame); !s) {
      summary_.failure = s.error();
      break;
    }
    report_written();
  }
  finish(started);
  return summary_;
}

void Runner::finish(const std::chrono::steady_clock::time_point& started) {
  // The stream stops first: controls written while streaming would land mid-frame.
  Status stopped = camera_.stop();
  if (Status restored = keeper_->restore(camera_); !restored)
    summary_.restore_error = restored.error();
  if (!stopped && !summary_.failure) summary_.failure = stopped.error();
  const bool complete =
      kept_total_ == plan_.total_frames() && !summary_.failure && !summary_.cancelled;
  if (Status closed = writer_->close(complete); !closed && !summary_.failure)
    summary_.failure = closed.error();
  report_written();
  summary_.frames_kept = written_total_;
  summary_.writer = writer_->stats();
  summary_.frames_consumed = kept_total_ + summary_.frames_discarded + summary_.frames_dropped;
  summary_.wall_seconds = seconds_since(started);
}

}  // namespace

Result<CaptureSummary> run_capture(device::Camera& camera, const CapturePlan& plan,
                                   const std::filesystem::path& folder,
                                   const CaptureOptions& options, CaptureObserver* observer) {
  return Runner(camera, plan, options, observer).run(folder);
}

}  // namespace camlab::capture
