#include "capture/frame_writer.h"

#include <algorithm>
#include <chrono>

namespace camlab::capture {

FrameWriter::FrameWriter(image::CaptureFolderWriter folder, Limits limits)
    : folder_(std::move(folder)), limits_(limits) {
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

bool FrameWriter::has_room() const {
  std::lock_guard lock(mutex_);
  return frames_held_ < limits_.max_frames && bytes_held_ < limits_.max_bytes;
}

Status FrameWriter::push(cv::Mat image, image::FrameSidecar sidecar, std::vector<uint8_t> jpeg) {
  std::lock_guard lock(mutex_);
  if (error_) return *error_;
  if (closed_ || close_request_ != CloseRequest::kNone)
    return make_error("invalid_argument", "the frame writer is closed");
  if (frames_held_ >= limits_.max_frames || bytes_held_ >= limits_.max_bytes)
    return make_error("busy", "the frame writer holds " + std::to_string(frames_held_) +
                                  " frames (" + std::to_string(bytes_held_ >> 20) +
                                  " MiB), its limit: the disk is slower than the camera");
  const size_t bytes = image.total() * image.elemSize() + jpeg.size();
  queue_.push_back({std::move(image), std::move(sidecar), std::move(jpeg), bytes});
  ++frames_held_;
  bytes_held_ += bytes;
  stats_.most_frames_held = std::max(stats_.most_frames_held, frames_held_);
  stats_.most_bytes_held = std::max(stats_.most_bytes_held, bytes_held_);
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
  if (!closed_) {
    if (close_request_ == CloseRequest::kNone)
      close_request_ = complete ? CloseRequest::kFinish : CloseRequest::kCommit;
    changed_.notify_all();
    changed_.wait(lock, [&] { return closed_; });
  }
  if (error_) return *error_;
  return {};
}

FrameWriter::Stats FrameWriter::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void FrameWriter::run() {
  std::unique_lock lock(mutex_);
  int reported = 0;  // frames moved to written_ so far
  // After any work on the folder: the frames it now lists go to written_.
  auto note_listed = [&](int listed) {
    if (listed > listed_) ++stats_.commits;
    listed_ = listed;
    while (reported < listed_ && !unlisted_.empty()) {
      written_.push_back(std::move(unlisted_.front()));
      unlisted_.pop_front();
      ++reported;
    }
    changed_.notify_all();
  };
  for (;;) {
    if (!queue_.empty() && !error_) {
      Job job = std::move(queue_.front());
      queue_.pop_front();
      lock.unlock();
      auto entry = job.jpeg.empty() ? folder_.add_frame(job.image, job.sidecar)
                                    : folder_.add_jpeg_frame(job.jpeg, job.sidecar);
      const int listed = folder_.committed_count();
      lock.lock();
      --frames_held_;
      bytes_held_ -= job.bytes;
      if (entry)
        unlisted_.push_back({*entry, std::move(job.sidecar)});
      else if (!error_)
        error_ = entry.error();
      note_listed(listed);
      continue;
    }
    if (!queue_.empty()) {  // after an error nothing more is written
      queue_.clear();
      frames_held_ = bytes_held_ = 0;
      changed_.notify_all();
      continue;
    }
    if (close_request_ != CloseRequest::kNone && !closed_) {
      const bool finish = close_request_ == CloseRequest::kFinish;
      const bool failed = error_.has_value();
      lock.unlock();
      Status done = failed ? Status{} : finish ? folder_.finish() : folder_.commit();
      const int listed = folder_.committed_count();
      lock.lock();
      if (!done && !error_) error_ = done.error();
      note_listed(listed);
      closed_ = true;
      changed_.notify_all();
      continue;
    }
    if (stopping_) return;  // the folder commits what it wrote when it goes
    const auto due = folder_.commit_due();
    if (due && !error_ && std::chrono::steady_clock::now() >= *due) {
      lock.unlock();
      Status committed = folder_.commit();
      const int listed = folder_.committed_count();
      lock.lock();
      if (!committed && !error_) error_ = committed.error();
      note_listed(listed);
      continue;
    }
    if (due && !error_)
      changed_.wait_until(lock, *due);
    else
      changed_.wait(lock);
  }
}

}  // namespace camlab::capture
