#include "service/live/live_hub.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "base/log.h"
#include "image/jpeg_codec.h"

namespace camlab::service {

struct LiveHub::ViewerState {
  std::shared_ptr<LiveFeed> feed;
  ViewerOptions options;
  int64_t interval_ns = 0;
  Viewer::Deliver pending;  // empty: nothing asked
  uint64_t last_generation = 0;
  int64_t next_due_ns = 0;  // 0: the first frame goes at once
  int64_t last_sent_ns = 0;
  std::optional<EncodedFrame> last_sent;
  bool closed = false;
  bool warned = false;  // hub thread only: a frame that could not be shown was logged
};

namespace {

bool same_rendering(const DisplayOptions& a, const DisplayOptions& b) {
  return a.max_width_px == b.max_width_px && a.clipping == b.clipping &&
         a.focus_peaking == b.focus_peaking && a.peaking_threshold == b.peaking_threshold &&
         a.jpeg_quality == b.jpeg_quality;
}

constexpr size_t kEncodeCacheSize = 8;

}  // namespace

LiveHub::LiveHub(std::function<void()> on_thread_start)
    : on_thread_start_(std::move(on_thread_start)) {}

LiveHub::~LiveHub() { stop(); }

void LiveHub::start() {
  std::lock_guard lock(mutex_);
  if (started_ || stopping_) return;
  started_ = true;
  thread_ = std::thread([this] { run(); });
}

void LiveHub::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
  // What the thread did not answer (it never started, or stopped first).
  std::list<std::shared_ptr<ViewerState>> viewers;
  std::list<FrameWait> waits;
  {
    std::lock_guard lock(mutex_);
    viewers.swap(viewers_);
    waits.swap(waits_);
    tasks_.clear();
  }
  const Error stopping = make_error("shutting_down", "camlabd is shutting down");
  for (auto& v : viewers) {
    Viewer::Deliver deliver = std::move(v->pending);
    v->feed->remove_viewer(v->options.fps_cap);
    if (deliver) deliver(stopping);
  }
  for (auto& w : waits) w.done(stopping);
}

uint64_t LiveHub::frames_sent() const {
  std::lock_guard lock(mutex_);
  return frames_sent_;
}

void LiveHub::listen_to(const std::shared_ptr<LiveFeed>& feed) {
  // Under the lock, so that a copy made while the thread decides to sleep is not missed.
  feed->set_frame_listener([this] {
    { std::lock_guard lock(mutex_); }
    wake_.notify_all();
  });
}

Result<std::shared_ptr<LiveHub::Viewer>> LiveHub::open_viewer(const std::shared_ptr<LiveFeed>& feed,
                                                              const ViewerOptions& options) {
  if (!(options.fps_cap >= kMinLiveFps && options.fps_cap <= kMaxLiveFps))
    return make_error("out_of_range", "fps = " + std::to_string(options.fps_cap) +
                                          " is outside the allowed range [" +
                                          std::to_string(kMinLiveFps) + ", " +
                                          std::to_string(kMaxLiveFps) + "] frames/s");
  if (feed->closed()) return make_error("no_device", "camera " + feed->camera_id() + " is gone");
  auto state = std::make_shared<ViewerState>();
  state->feed = feed;
  state->options = options;
  state->interval_ns = static_cast<int64_t>(std::llround(1e9 / options.fps_cap));
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return make_error("shutting_down", "camlabd is shutting down");
    const auto open = std::count_if(viewers_.begin(), viewers_.end(),
                                    [&](const auto& v) { return v->feed == feed; });
    if (open >= kMaxViewersPerCamera)
      return make_error("too_many_connections", "camera " + feed->camera_id() + " already has " +
                                                    std::to_string(open) + " live viewers (limit " +
                                                    std::to_string(kMaxViewersPerCamera) + ")");
    viewers_.push_back(state);
  }
  listen_to(feed);
  feed->add_viewer(options.fps_cap);
  return std::make_shared<Viewer>(this, std::move(state));
}

void LiveHub::Viewer::next(Deliver deliver) {
  {
    std::lock_guard lock(hub_->mutex_);
    if (!hub_->stopping_) {
      if (state_->closed) return;
      state_->pending = std::move(deliver);
      deliver = nullptr;
    }
  }
  // The hub has stopped: nobody would answer later.
  if (deliver) return deliver(make_error("shutting_down", "camlabd is shutting down"));
  hub_->wake_.notify_all();
}

void LiveHub::Viewer::close() { hub_->close_viewer(state_); }

void LiveHub::close_viewer(const std::shared_ptr<ViewerState>& state) {
  Viewer::Deliver dropped;  // destroyed after the lock is released (see run())
  {
    std::lock_guard lock(mutex_);
    if (state->closed) return;
    state->closed = true;
    dropped = std::move(state->pending);
    state->pending = nullptr;
    viewers_.remove(state);
  }
  // stop() has removed it already when the hub stopped first; removing twice is harmless.
  state->feed->remove_viewer(state->options.fps_cap);
}

void LiveHub::next_frame(const std::shared_ptr<LiveFeed>& feed, std::chrono::milliseconds timeout,
                         FrameCallback done) {
  const auto wait = std::clamp(timeout, std::chrono::milliseconds(0), kMaxFrameWait);
  const auto latest = feed->latest();
  FrameWait entry{feed, latest ? latest->generation : 0,
                  monotonic_now_ns() + std::chrono::nanoseconds(wait).count(), std::move(done)};
  {
    std::unique_lock lock(mutex_);
    if (stopping_) {
      lock.unlock();
      entry.done(make_error("shutting_down", "camlabd is shutting down"));
      return;
    }
    waits_.push_back(std::move(entry));
  }
  listen_to(feed);
  feed->touch();
  wake_.notify_all();
}

bool LiveHub::post(std::function<void()> work) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_) return false;
    tasks_.push_back(std::move(work));
  }
  wake_.notify_all();
  return true;
}

int64_t LiveHub::collect_due(
    int64_t now, std::vector<Work>* work,
    std::vector<std::pair<FrameCallback, Result<std::shared_ptr<const LiveFrame>>>>* waits_done) {
  int64_t wake_at = std::numeric_limits<int64_t>::max();
  for (const auto& v : viewers_) {
    if (!v->pending) continue;
    if (v->feed->closed()) {
      work->push_back({v, nullptr,
                       make_error("no_device", "camera " + v->feed->camera_id() + " is gone"),
                       false});
      continue;
    }
    const auto latest = v->feed->latest();
    const bool fresh = latest && latest->generation > v->last_generation;
    if (fresh && now >= v->next_due_ns) {
      work->push_back({v, latest, std::nullopt, false});
    } else if (fresh) {
      wake_at = std::min(wake_at, v->next_due_ns);
    } else if (v->last_sent) {
      const int64_t repeat_at = v->last_sent_ns + std::chrono::nanoseconds(kRepeatAfter).count();
      if (now >= repeat_at)
        work->push_back({v, nullptr, std::nullopt, true});
      else
        wake_at = std::min(wake_at, repeat_at);
    }
  }
  for (auto it = waits_.begin(); it != waits_.end();) {
    const auto latest = it->feed->latest();
    if (it->feed->closed()) {
      waits_done->emplace_back(
          std::move(it->done),
          make_error("no_device", "camera " + it->feed->camera_id() + " is gone"));
    } else if (latest && latest->generation > it->after_generation) {
      waits_done->emplace_back(std::move(it->done), latest);
    } else if (now >= it->deadline_ns) {
      waits_done->emplace_back(
          std::move(it->done),
          make_error("timeout", "camera " + it->feed->camera_id() +
                                    " gave no frame in time (it may be unavailable, or measuring "
                                    "its control latency)"));
    } else {
      wake_at = std::min(wake_at, it->deadline_ns);
      ++it;
      continue;
    }
    it = waits_.erase(it);
  }
  return wake_at;
}

void LiveHub::render_and_send(Work& work) {
  ViewerState& v = *work.viewer;
  Viewer::Deliver deliver;
  std::optional<EncodedFrame> out;
  std::optional<Error> error = work.error;
  if (!error && work.repeat) {
    out = v.last_sent;
    out->repeated = true;
  } else if (!error) {
    const LiveFrame& frame = *work.frame;
    for (const CachedEncode& cached : encode_cache_)
      if (cached.feed == v.feed.get() && cached.generation == frame.generation &&
          same_rendering(cached.display, v.options.display))
        out = cached.frame;
    if (!out) {
      auto converted = convert_live_frame(frame);
      auto shown = converted ? display_image(*converted, v.options.display)
                             : Result<cv::Mat>(converted.error());
      auto jpeg = shown ? image::encode_jpeg(*shown, v.options.display.jpeg_quality)
                        : Result<std::vector<uint8_t>>(shown.error());
      if (jpeg) {
        EncodedFrame encoded;
        encoded.jpeg = std::make_shared<const std::vector<uint8_t>>(std::move(*jpeg));
        encoded.width_px = shown->cols;
        encoded.height_px = shown->rows;
        encoded.sequence = frame.meta.sequence;
        encoded.timestamp_ns = frame.meta.timestamp_ns;
        encoded.generation = frame.generation;
        out = encoded;
        encode_cache_.push_back({v.feed.get(), frame.generation, v.options.display, encoded});
        if (encode_cache_.size() > kEncodeCacheSize) encode_cache_.pop_front();
      } else {
        // One bad frame (a corrupt MJPEG frame, say) is skipped, not fatal to the stream;
        // logged once per viewer, not once a frame.
        if (!v.warned)
          log_warning(log::Category::kHttp,
                      "live view of %s: frame %llu not shown (later ones skipped silently): %s",
                      v.feed->camera_id().c_str(),
                      static_cast<unsigned long long>(frame.meta.sequence),
                      jpeg.error().message.c_str());
        v.warned = true;
      }
    }
  }
  {
    std::lock_guard lock(mutex_);
    if (v.closed) return;
    const int64_t now = monotonic_now_ns();
    if (work.frame) v.last_generation = work.frame->generation;
    if (out) {
      deliver = std::move(v.pending);
      v.pending = nullptr;
      if (!out->repeated) {
        // On the grid while less than one interval late; a new grid after a pause.
        const int64_t base =
            v.next_due_ns == 0 || now - v.next_due_ns > v.interval_ns ? now : v.next_due_ns;
        v.next_due_ns = base + v.interval_ns;
        v.last_sent = out;
        ++frames_sent_;
      }
      v.last_sent_ns = now;
    } else if (error) {
      deliver = std::move(v.pending);
      v.pending = nullptr;
    }
  }
  if (deliver) {
    if (out)
      deliver(std::move(*out));
    else
      deliver(*error);
  }
}

void LiveHub::run() {
  if (on_thread_start_) on_thread_start_();
  std::unique_lock lock(mutex_);
  while (!stopping_) {
    std::vector<Work> work;
    std::vector<std::pair<FrameCallback, Result<std::shared_ptr<const LiveFrame>>>> waits_done;
    const int64_t wake_at = collect_due(monotonic_now_ns(), &work, &waits_done);
    std::deque<std::function<void()>> tasks;
    tasks.swap(tasks_);
    if (work.empty() && waits_done.empty() && tasks.empty()) {
      if (wake_at == std::numeric_limits<int64_t>::max()) {
        wake_.wait(lock);
      } else {
        const int64_t wait_ns = std::max<int64_t>(0, wake_at - monotonic_now_ns());
        wake_.wait_for(lock, std::chrono::nanoseconds(wait_ns));
      }
      continue;
    }
    lock.unlock();
    for (auto& [done, result] : waits_done) done(std::move(result));
    for (Work& w : work) render_and_send(w);
    for (auto& task : tasks) task();
    // Destroyed before the lock is taken again: a callback may hold the last reference to
    // its HTTP session, whose stream then closes its viewer under this same lock.
    waits_done.clear();
    work.clear();
    tasks.clear();
    lock.lock();
  }
}

}  // namespace camlab::service
