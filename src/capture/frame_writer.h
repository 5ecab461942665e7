// Writes a capture's frames to its folder on a thread of its own, so that PNG encoding
// and fsync never hold the frame loop: the loop must dequeue promptly, or frames pile up
// in the driver and every control change lands later (more frames consumed).
//
// The queue is bounded (docs/architecture.md): push() blocks while it is full, so a disk
// slower than the camera slows the capture rather than growing memory.
//
// Thread-safe between one producer (the camera's worker) and the internal writer thread;
// results are collected on the producer's thread (take_written), so observers run there.
#pragma once

#include <condition_variable>
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

  FrameWriter(image::CaptureFolderWriter folder, size_t max_queued);
  ~FrameWriter();  // writes what is queued, then joins
  FrameWriter(const FrameWriter&) = delete;
  FrameWriter& operator=(const FrameWriter&) = delete;

  // Queues a frame (taking the image's pixels, or a camera's JPEG stream when `jpeg` is
  // not empty); blocks while the queue is full. Fails with the first write error once one
  // happened (nothing more is written then).
  Status push(cv::Mat image, image::FrameSidecar sidecar, std::vector<uint8_t> jpeg = {});

  // Frames written since the last call, in order.
  std::vector<Written> take_written();

  // Waits until every queued frame is written; then, if `complete`, marks the folder
  // complete. Returns the first write error, if any.
  Status close(bool complete);

 private:
  struct Job {
    cv::Mat image;
    image::FrameSidecar sidecar;
    std::vector<uint8_t> jpeg;
  };
  void run();

  image::CaptureFolderWriter folder_;
  const size_t max_queued_;
  std::mutex mutex_;
  std::condition_variable changed_;
  std::deque<Job> queue_;
  bool busy_ = false;  // the writer thread holds a job
  std::vector<Written> written_;
  std::optional<Error> error_;
  bool stopping_ = false;
  std::thread thread_;
};

}  // namespace camlab::capture
