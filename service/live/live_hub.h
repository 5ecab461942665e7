// The live view's thread: it turns the frames camera feeds copy (service/live/live_feed.h)
// into what viewers receive, so that neither a camera's worker nor an HTTP thread ever
// converts or encodes a frame:
// - viewers (a live-view stream each): the next frame newer than the last one sent, no
//   sooner than the viewer's frame-rate cap allows, rendered for display
//   (display_frame.h) and encoded as JPEG; viewers of one camera asking the same
//   rendering share one encode;
// - one-off waits for the next raw frame of a camera (the histogram);
// - any other display work posted to it (thumbnails of stored frames).
//
// Frame pacing: a viewer's frames are due on a grid of 1/cap seconds, so it receives its
// cap on average whenever the camera delivers faster (a late frame does not push the next
// one later); when no new frame comes for kRepeatAfter, the last one is sent again,
// marked repeated, which keeps a connection whose client left from lingering.
//
// Thread-safe. Callbacks run on the hub's thread and must be quick (post to a strand).
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <optional>
#include <thread>
#include <vector>

#include "base/result.h"
#include "service/live/display_frame.h"
#include "service/live/live_feed.h"

namespace camlab::service {

inline constexpr double kMinLiveFps = 0.2;
inline constexpr double kMaxLiveFps = 30;
inline constexpr int kMaxViewersPerCamera = 8;
inline constexpr std::chrono::milliseconds kRepeatAfter{5000};
// A one-off wait for a frame may ask for at most this long.
inline constexpr std::chrono::milliseconds kMaxFrameWait{10000};

struct ViewerOptions {
  double fps_cap = 10;  // kMinLiveFps..kMaxLiveFps frames/s
  DisplayOptions display;
};

struct EncodedFrame {
  std::shared_ptr<const std::vector<uint8_t>> jpeg;
  int width_px = 0, height_px = 0;
  uint64_t sequence = 0;     // the driver's frame sequence number
  int64_t timestamp_ns = 0;  // the driver's timestamp (CLOCK_MONOTONIC for V4L2)
  uint64_t generation = 0;   // the feed's count of copied frames
  bool repeated = false;     // no newer frame came within kRepeatAfter
};

class LiveHub {
 public:
  class Viewer;
  using FrameCallback = std::function<void(Result<std::shared_ptr<const LiveFrame>>)>;

  // `on_thread_start` runs first on the hub's thread (the daemon lowers its priority there,
  // as for the HTTP threads: a capture's work comes first).
  explicit LiveHub(std::function<void()> on_thread_start = {});
  ~LiveHub();
  LiveHub(const LiveHub&) = delete;
  LiveHub& operator=(const LiveHub&) = delete;

  void start();
  // Ends every viewer and wait with "shutting_down", and joins the thread.
  void stop();

  // A new viewer of `feed`; "too_many_connections" beyond kMaxViewersPerCamera,
  // "out_of_range" for a cap outside [kMinLiveFps, kMaxLiveFps], "no_device" once the
  // feed is closed, "shutting_down" once stopping.
  Result<std::shared_ptr<Viewer>> open_viewer(const std::shared_ptr<LiveFeed>& feed,
                                              const ViewerOptions& options);

  // Calls `done` once, on the hub's thread, with the first frame `feed` copies after this
  // call, or with "timeout" after `timeout` (at most kMaxFrameWait), "no_device" when the
  // feed closes, "shutting_down" when the hub stops. Keeps the feed wanted meanwhile.
  void next_frame(const std::shared_ptr<LiveFeed>& feed, std::chrono::milliseconds timeout,
                  FrameCallback done);

  // Runs `work` on the hub's thread; false (not run) once stopping.
  bool post(std::function<void()> work);

  // Frames sent to viewers since start (the metrics).
  uint64_t frames_sent() const;

 private:
  struct ViewerState;
  struct FrameWait {
    std::shared_ptr<LiveFeed> feed;
    uint64_t after_generation = 0;
    int64_t deadline_ns = 0;
    FrameCallback done;
  };
  struct Work {
    std::shared_ptr<ViewerState> viewer;  // a frame to render and send, or an error
    std::shared_ptr<const LiveFrame> frame;
    std::optional<Error> error;
    bool repeat = false;
  };

  void run();
  void close_viewer(const std::shared_ptr<ViewerState>& state);
  void listen_to(const std::shared_ptr<LiveFeed>& feed);
  // Decides what is due now (callers hold mutex_); returns when to look again.
  int64_t collect_due(
      int64_t now_ns, std::vector<Work>* work,
      std::vector<std::pair<FrameCallback, Result<std::shared_ptr<const LiveFrame>>>>* waits_done);
  void render_and_send(Work& work);

  const std::function<void()> on_thread_start_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool started_ = false;
  std::list<std::shared_ptr<ViewerState>> viewers_;
  std::list<FrameWait> waits_;
  std::deque<std::function<void()>> tasks_;
  uint64_t frames_sent_ = 0;
  std::thread thread_;
  // The last encodes (thread only): viewers asking the same rendering of the same frame.
  struct CachedEncode {
    const LiveFeed* feed = nullptr;
    uint64_t generation = 0;
    DisplayOptions display;
    EncodedFrame frame;
  };
  std::deque<CachedEncode> encode_cache_;
};

class LiveHub::Viewer {
 public:
  using Deliver = std::function<void(Result<EncodedFrame>)>;
  Viewer(LiveHub* hub, std::shared_ptr<ViewerState> state) : hub_(hub), state_(std::move(state)) {}
  ~Viewer() { close(); }
  Viewer(const Viewer&) = delete;
  Viewer& operator=(const Viewer&) = delete;

  // Asks for the next frame: `deliver` is called once, on the hub's thread (see LiveHub).
  // One request at a time; a second while one is pending replaces it.
  void next(Deliver deliver);
  // The client went away: a pending request is dropped (never called) and the viewer
  // leaves the feed. Idempotent.
  void close();

 private:
  LiveHub* hub_;
  std::shared_ptr<ViewerState> state_;
};

}  // namespace camlab::service
