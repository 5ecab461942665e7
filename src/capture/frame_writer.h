// Writes a capture's frames to its folder on a thread of its own, so that PNG encoding
// and the disk never hold the frame loop: the loop must dequeue promptly, or frames pile
// up in the driver, the driver runs out of buffers and drops frames, and every control
// change lands later (more frames consumed). A slow disk delays storage, not the choice
// of frames.
//
// The queue is bounded (docs/architecture.md) in frames and in bytes of pixels held in
// memory, and push() never waits: when it is full the frame loop does not keep the frame
// (it counts it as dropped by camlabd and takes the step again), rather than stop
// dequeuing. Frames are committed by the folder's policy (capture_folder.h): every 16
// frames or 250 ms, and at close; a frame is reported written (take_written) once it is
// listed in the journal, so whoever counts reported frames never counts more than the
// folder lists.
//
// Thread-safe between one producer (the camera's worker) and the internal writer thread;
// results are collected on the producer's thread (take_written), so observers run there.
#pragma once

#include <condition_variable>
#include <cstddef>
#include <deque>
#include <mutex>
#include <opencv2/core.hpp>
#include <optional>
#include <thread>
#include <vector>

#include "base/result.h"
#include "image/capture_folder.h"

namespace camlab::capture {

class FrameWriter {
 public:
  struct Written {
    image::CaptureFrameEntry entry;
    image::FrameSidecar sidecar;
  };
  // Frames held in memory: queued, and the one being written.
  struct Limits {
    size_t max_frames = 512;
    size_t max_bytes = size_t{256} << 20;  // pixels (or JPEG bytes) held
  };
  struct Stats {
    size_t most_frames_held = 0;  // the deepest the queue got
    size_t most_bytes_held = 0;
    int commits = 0;  // commits that listed frames
  };

  FrameWriter(image::CaptureFolderWriter folder, Limits limits);
  ~FrameWriter();  // writes and commits what is queued, then joins
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;

  // Whether push() would take a frame now: fewer than max_frames held and fewer than
  // max_bytes (a frame that fits under the bytes bound is taken whole, so the bound is
  // exceeded by at most one frame). Only the producer adds frames, so room seen here is
  // still there at its next push.
  bool has_room() const;

  // Queues a frame (taking the image's pixels, or a camera's JPEG stream when `jpeg` is
  // not empty) without waiting: "busy" when there is no room (nothing is queued); the
  // first write error once one happened (nothing more is written then).
  Status push(cv::Mat image, image::FrameSidecar sidecar, std::vector<uint8_t> jpeg = {});

  // Frames listed in the folder's journal since the last call, in order.
  std::vector<Written> take_written();

  // Waits until every queued frame is written and listed; then, if `complete`, marks the
  // folder complete. Returns the first write error, if any. Nothing is queued after it.
  Status close(bool complete);

  Stats stats() const;

 private:
  struct Job {
    cv::Mat image;
    image::FrameSidecar sidecar;
    std::vector<uint8_t> jpeg;
    size_t bytes = 0;
  };
  enum class CloseRequest { kNone, kCommit, kFinish };
  void run();

  image::CaptureFolderWriter folder_;  // the writer thread's (and close()'s, through it)
  const Limits limits_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Job> queue_;
  size_t frames_held_ = 0, bytes_held_ = 0;  // queued, and the job being written
  std::deque<Written> unlisted_;             // written, waiting for a commit
  int listed_ = 0;                           // frames the folder has committed
  std::vector<Written> written_;
  std::optional<Error> error_;
  CloseRequest close_request_ = CloseRequest::kNone;
  bool closed_ = false;
  bool stopping_ = false;
  Stats stats_;
  std::thread thread_;
};

}  // namespace camlab::capture
