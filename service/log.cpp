#include "service/log.h"

#include <unistd.h>

#include <cstdarg>
#include <cstdio>
#include <ctime>
#include <string>

namespace camlab::service {

namespace {

void write_line(const char* level, const char* format, va_list args) {
  char message[2048];
  std::vsnprintf(message, sizeof message, format, args);
  std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
  const std::string line = std::string("camlabd ") + stamp + " " + level + ": " + message + "\n";
  // One write(2): atomic for lines under PIPE_BUF, so threads never interleave.
  [[maybe_unused]] ssize_t n = ::write(STDERR_FILENO, line.data(), line.size());
}

}  // namespace

void log_info(const char* format, ...) {
  va_list args;
  va_start(args, format);
  write_line("info", format, args);
  va_end(args);
}

void log_warning(const char* format, ...) {
  va_list args;
  va_start(args, format);
  write_line("warning", format, args);
  va_end(args);
}

void log_error(const char* format, ...) {
  va_list args;
  va_start(args, format);
  write_line("error", format, args);
  va_end(args);
}

}  // namespace camlab::service
