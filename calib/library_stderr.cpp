#include "calib/library_stderr.h"

#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstdio>
#include <mutex>
#include <string>
#include <string_view>

#include "base/log.h"
#include "base/unique_fd.h"

namespace camlab::calib {

namespace {

constexpr size_t kMaxCapturedBytes = 1 << 20;
constexpr int kMaxLoggedLines = 200;

struct CaptureState {
  std::mutex mutex;
  int depth = 0;  // live captures
  // A duplicate of the real stderr, kept open for the process's life: a thread may still
  // be writing a log line to it just after a capture ends. Each outermost capture points
  // it at fd 2's current file again (dup3 onto the same number), so a caller that moved
  // fd 2 meanwhile is followed.
  UniqueFd real_stderr;
  UniqueFd captured;  // the memfd behind fd 2 while depth > 0; invalid when not redirected
};

CaptureState& state() {
  static CaptureState* s = new CaptureState;  // never destroyed: captures may outlive statics
  return *s;
}

// Logs the memfd's lines (debug, calib) after fd 2 is back.
void log_captured(int fd) {
  std::string text;
  char buf[4096];
  off_t offset = 0;
  while (text.size() < kMaxCapturedBytes) {
    const ssize_t n = ::pread(fd, buf, sizeof buf, offset);
    if (n <= 0) break;
    text.append(buf, static_cast<size_t>(n));
    offset += n;
  }
  int lines = 0, dropped = 0;
  size_t pos = 0;
  while (pos < text.size()) {
    size_t end = text.find('\n', pos);
    if (end == std::string::npos) end = text.size();
    std::string_view line(text.data() + pos, end - pos);
    pos = end + 1;
    if (line.empty()) continue;
    if (lines < kMaxLoggedLines) {
      log_debug(log::Category::kCalib, "mrcal: %.*s", static_cast<int>(line.size()), line.data());
      ++lines;
    } else {
      ++dropped;
    }
  }
  if (dropped > 0 || text.size() >= kMaxCapturedBytes)
    log_debug(log::Category::kCalib, "mrcal: %d more lines (or more than %zu bytes) not logged",
              dropped, kMaxCapturedBytes);
}

}  // namespace

LibraryStderrCapture::LibraryStderrCapture() {
  CaptureState& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (s.depth++ > 0) return;
  std::fflush(stderr);
  UniqueFd memfd(::memfd_create("camlab-library-stderr", MFD_CLOEXEC));
  if (!memfd) return;
  if (!s.real_stderr) {
    s.real_stderr = UniqueFd(::fcntl(STDERR_FILENO, F_DUPFD_CLOEXEC, 3));
    if (!s.real_stderr) return;
  } else if (::dup3(STDERR_FILENO, s.real_stderr.get(), O_CLOEXEC) < 0) {
    return;
  }
  log::set_output_fd(s.real_stderr.get());
  if (::dup2(memfd.get(), STDERR_FILENO) < 0) {
    log::set_output_fd(STDERR_FILENO);
    return;
  }
  s.captured = std::move(memfd);
}

LibraryStderrCapture::~LibraryStderrCapture() {
  CaptureState& s = state();
  std::lock_guard<std::mutex> lock(s.mutex);
  if (--s.depth > 0 || !s.captured) return;
  std::fflush(stderr);
  // fd 2 back to the real stderr first, then the log, so no line is written to the memfd
  // after it is read.
  ::dup2(s.real_stderr.get(), STDERR_FILENO);
  log::set_output_fd(STDERR_FILENO);
  UniqueFd captured = std::move(s.captured);
  log_captured(captured.get());
}

}  // namespace camlab::calib
