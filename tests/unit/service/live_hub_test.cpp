// The live view's feed and hub (service/live/) without a camera: frames offered by a
// producer thread as a camera's worker would. Checks what the hub promises: a feed copies
// only while someone watches; a viewer never gets more than its cap (an upper bound, which
// holds on any machine), every frame newer than the last, never one twice; viewers asking
// the same rendering share one encode; limits and errors (out of range, too many viewers,
// the camera gone, the daemon stopping, no frame in time) are said, never hung on.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <future>
#include <thread>
#include <vector>

#include "image/jpeg_codec.h"
#include "service/live/live_hub.h"

namespace camlab::service {
namespace {

using namespace std::chrono_literals;

device::StreamFormat grey_format() {
  device::StreamFormat format;
  format.fourcc = "GREY";
  format.width = 64;
  format.height = 48;
  format.bytes_per_line = 64;
  format.size_bytes = 64 * 48;
  return format;
}

// Offers frames with increasing sequence numbers (and a value that changes with them).
class Producer {
 public:
  Producer(LiveFeed& feed, std::chrono::milliseconds period)
      : thread_([this, &feed, period] {
          std::vector<uint8_t> pixels(64 * 48);
          for (uint64_t sequence = 0; !stop_; ++sequence) {
            std::fill(pixels.begin(), pixels.end(), static_cast<uint8_t>(sequence % 200 + 20));
            device::Frame frame;
            frame.data = pixels.data();
            frame.size = pixels.size();
            frame.meta.sequence = sequence;
            frame.meta.bytes_used = static_cast<uint32_t>(pixels.size());
            feed.offer(frame, grey_format());
            offered_ = sequence + 1;
            std::this_thread::sleep_for(period);
          }
        }) {}
  ~Producer() {
    stop_ = true;
    thread_.join();
  }
  uint64_t offered() const { return offered_; }

 private:
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> offered_{0};
  std::thread thread_;
};

// The next frame a viewer receives (bounded wait).
Result<EncodedFrame> next_of(LiveHub::Viewer& viewer, std::chrono::milliseconds timeout = 5s) {
  auto promise = std::make_shared<std::promise<Result<EncodedFrame>>>();
  auto future = promise->get_future();
  viewer.next([promise](Result<EncodedFrame> frame) { promise->set_value(std::move(frame)); });
  if (future.wait_for(timeout) != std::future_status::ready)
    return make_error("timeout", "no frame within the test's bound");
  return future.get();
}

TEST(LiveFeed, CopiesFramesOnlyWhileSomeoneWatches) {
  auto feed = std::make_shared<LiveFeed>("cam", capture::CameraTraits{});
  EXPECT_FALSE(feed->wanted());
  {
    Producer producer(*feed, 5ms);
    std::this_thread::sleep_for(100ms);
    EXPECT_EQ(feed->latest(), nullptr);  // nobody watched: nothing copied
    feed->touch();
    EXPECT_TRUE(feed->wanted());
    std::this_thread::sleep_for(200ms);
  }
  auto latest = feed->latest();
  ASSERT_NE(latest, nullptr);
  EXPECT_EQ(latest->bytes.size(), 64u * 48u);
  EXPECT_EQ(latest->format.fourcc, "GREY");
  // A one-off request is served at 10 copies a second at most: 200 ms of 200 offers.
  EXPECT_LE(latest->generation, 4u);
  feed->close();
  EXPECT_FALSE(feed->wanted());
}

TEST(LiveHub, AViewerGetsNewerFramesNeverFasterThanItsCap) {
  LiveHub hub;
  hub.start();
  auto feed = std::make_shared<LiveFeed>("cam", capture::CameraTraits{});
  Producer producer(*feed, 4ms);  // 250 frames/s offered
  auto viewer = hub.open_viewer(feed, {10, {}});
  ASSERT_TRUE(viewer.ok()) << viewer.error().message;
  EXPECT_TRUE(feed->wanted());
  const auto start = std::chrono::steady_clock::now();
  uint64_t last_generation = 0, last_sequence = 0;
  int frames = 0;
  while (std::chrono::steady_clock::now() - start < 1500ms) {
    auto frame = next_of(**viewer);
    ASSERT_TRUE(frame.ok()) << frame.error().message;
    ASSERT_FALSE(frame->repeated);
    EXPECT_GT(frame->generation, last_generation);
    if (frames > 0) {
      EXPECT_GT(frame->sequence, last_sequence);
    }
    last_generation = frame->generation;
    last_sequence = frame->sequence;
    auto decoded = image::decode_jpeg(*frame->jpeg);
    ASSERT_TRUE(decoded.ok());
    EXPECT_EQ(decoded->cols, 64);
    ++frames;
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  // The grid allows the first frame at once and one per 100 ms after it.
  EXPECT_LE(frames, 1 + static_cast<int>(seconds * 10) + 1);
  EXPECT_GE(frames, 2);
  (*viewer)->close();
  EXPECT_EQ(feed->viewers(), 0);
}

TEST(LiveHub, ViewersAskingTheSameRenderingShareOneEncode) {
  LiveHub hub;
  hub.start();
  auto feed = std::make_shared<LiveFeed>("cam", capture::CameraTraits{});
  auto a = hub.open_viewer(feed, {5, {}});
  auto b = hub.open_viewer(feed, {5, {}});
  ASSERT_TRUE(a.ok() && b.ok());
  // One frame only, offered once both wait for it.
  std::vector<uint8_t> pixels(64 * 48, 77);
  device::Frame frame;
  frame.data = pixels.data();
  frame.size = pixels.size();
  auto pa = std::make_shared<std::promise<Result<EncodedFrame>>>();
  auto pb = std::make_shared<std::promise<Result<EncodedFrame>>>();
  (*a)->next([pa](Result<EncodedFrame> f) { pa->set_value(std::move(f)); });
  (*b)->next([pb](Result<EncodedFrame> f) { pb->set_value(std::move(f)); });
  feed->offer(frame, grey_format());
  auto fa = pa->get_future(), fb = pb->get_future();
  ASSERT_EQ(fa.wait_for(5s), std::future_status::ready);
  ASSERT_EQ(fb.wait_for(5s), std::future_status::ready);
  auto ra = fa.get(), rb = fb.get();
  ASSERT_TRUE(ra.ok() && rb.ok());
  EXPECT_EQ(ra->jpeg.get(), rb->jpeg.get());
}

TEST(LiveHub, LimitsAndEndsAreSaid) {
  LiveHub hub;
  hub.start();
  auto feed = std::make_shared<LiveFeed>("cam", capture::CameraTraits{});
  EXPECT_EQ(hub.open_viewer(feed, {0, {}}).error().code, ErrorCode::kOutOfRange);
  EXPECT_EQ(hub.open_viewer(feed, {31, {}}).error().code, ErrorCode::kOutOfRange);
  std::vector<std::shared_ptr<LiveHub::Viewer>> viewers;
  for (int i = 0; i < kMaxViewersPerCamera; ++i) {
    auto v = hub.open_viewer(feed, {1, {}});
    ASSERT_TRUE(v.ok());
    viewers.push_back(*v);
  }
  EXPECT_EQ(hub.open_viewer(feed, {1, {}}).error().code, ErrorCode::kTooManyConnections);

  // No frame in time: a timeout, not a hang.
  auto waited = std::make_shared<std::promise<ErrorCode>>();
  hub.next_frame(feed, 100ms, [waited](Result<std::shared_ptr<const LiveFrame>> frame) {
    waited->set_value(frame ? ErrorCode::kInternal : frame.error().code);
  });
  auto w = waited->get_future();
  ASSERT_EQ(w.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(w.get(), ErrorCode::kTimeout);

  // The camera is gone: a waiting viewer is told.
  auto gone = std::make_shared<std::promise<ErrorCode>>();
  viewers[0]->next([gone](Result<EncodedFrame> frame) {
    gone->set_value(frame ? ErrorCode::kInternal : frame.error().code);
  });
  feed->close();
  auto g = gone->get_future();
  ASSERT_EQ(g.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(g.get(), ErrorCode::kNoDevice);
  EXPECT_EQ(hub.open_viewer(feed, {1, {}}).error().code, ErrorCode::kNoDevice);

  // The daemon stops: a viewer waiting on another feed is told too.
  auto other = std::make_shared<LiveFeed>("other", capture::CameraTraits{});
  auto v = hub.open_viewer(other, {1, {}});
  ASSERT_TRUE(v.ok());
  auto stopping = std::make_shared<std::promise<ErrorCode>>();
  (*v)->next([stopping](Result<EncodedFrame> frame) {
    stopping->set_value(frame ? ErrorCode::kInternal : frame.error().code);
  });
  hub.stop();
  auto s = stopping->get_future();
  ASSERT_EQ(s.wait_for(5s), std::future_status::ready);
  EXPECT_EQ(s.get(), ErrorCode::kShuttingDown);
  EXPECT_EQ(hub.open_viewer(other, {1, {}}).error().code, ErrorCode::kShuttingDown);
}

// What an HTTP session is to its live stream: the owner whose destruction closes the viewer.
// The viewer's pending callback may hold the last reference to it; close() from elsewhere
// (the client left) drops that callback, which must not happen under the hub's lock.
TEST(LiveHub, ACallbackHoldingTheLastReferenceToItsViewerMayCloseItWhenDropped) {
  LiveHub hub;
  hub.start();
  auto feed = std::make_shared<LiveFeed>("cam", capture::CameraTraits{});
  auto viewer = hub.open_viewer(feed, {1, {}});
  ASSERT_TRUE(viewer.ok());
  struct ClosesWhenDropped {
    std::shared_ptr<LiveHub::Viewer> viewer;
    std::shared_ptr<std::promise<void>> closed = std::make_shared<std::promise<void>>();
    ~ClosesWhenDropped() {
      viewer->close();
      closed->set_value();
    }
  };
  auto owner = std::make_shared<ClosesWhenDropped>();
  owner->viewer = *viewer;
  auto closed = owner->closed->get_future();
  (*viewer)->next([owner](Result<EncodedFrame>) {});
  owner.reset();
  // The thread's reference may be the viewer's last: it is dropped, and said so, before the
  // hub goes out of scope (a viewer destroyed after its hub would lock a freed mutex).
  auto released = std::make_shared<std::promise<void>>();
  auto thread_done = released->get_future();
  std::thread([v = *viewer, released]() mutable {
    v->close();
    v.reset();
    released->set_value();
  }).detach();
  if (closed.wait_for(5s) != std::future_status::ready ||
      thread_done.wait_for(5s) != std::future_status::ready) {
    // A hub deadlocked on itself cannot be cleaned up: the process ends here.
    std::fprintf(stderr, "FAILED: close() did not return within 5 s (deadlocked)\n");
    std::_Exit(1);
  }
  EXPECT_EQ(feed->viewers(), 0);
  EXPECT_TRUE(hub.open_viewer(feed, {1, {}}).ok());  // the hub still serves
}

}  // namespace
}  // namespace camlab::service
