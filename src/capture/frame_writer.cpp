#include "capture/frame_writer.h"

#include <algorithm>

namespace camlab::capture {

FrameWriter::FrameWriter(image::CaptureFolderWriter folder, size_t max_queued)
    : folder_(std::move(folder)), max_queued_(std::max<size_t>(max_queued, 1)) {
  thread_ = std::thread([this] { run(); });
}

FrameWriter::~FrameWriter() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  changed_.notify_all();
  thread_.join();
}

Status FrameWriter::push(cv::Mat image, image::FrameSidecar sidecar, std::vector<uint8_t> jpeg) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return queue_.size() < max_queued_ || error_; });
  if (error_) return *error_;
  queue_.push_back({std::move(image), std::move(sidecar), std::move(jpeg)});
  changed_.notify_all();
  return {};
}

std::vector<FrameWriter::Written> FrameWriter::take_written() {
  std::lock_guard lock(mutex_);
  std::vector<Written> out;
  out.swap(written_);
  return out;
}

Status FrameWriter::close(bool complete) {
  std::unique_lock lock(mutex_);
  changed_.wait(lock, [&] { return (queue_.empty() && !busy_) || error_; });
  if (error_) return *error_;
  // The writer thread is idle and stays so: the folder is ours to finish.
  if (complete) {
    if (Status s = folder_.finish(); !s) {
      error_ = s.error();
      return s;
    }
  }
  return {};
}

void FrameWriter::run() {
  std::unique_lock lock(mutex_);
  for (;;) {
    changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
    if (queue_.empty() || error_) {
      if (stopping_) return;
      queue_.clear();  // after an error nothing more is written
      changed_.notify_all();
      continue;
    }
    Job job = std::move(queue_.front());
    queue_.pop_front();
    busy_ = true;
    changed_.notify_all();  // room in the queue
    lock.unlock();
    auto entry = job.jpeg.empty() ? folder_.add_frame(job.image, job.sidecar)
                                  : folder_.add_jpeg_frame(job.jpeg, job.sidecar);
    lock.lock();
    busy_ = false;
    if (entry)
      written_.push_back({*entry, std::move(job.sidecar)});
    else
      error_ = entry.error();
    changed_.notify_all();
  }
}

}  // namespace camlab::capture
