// camlab's one log: lines on stderr, each written with one write(2) so that lines from
// threads and processes never interleave:
//
//   camlabd 2026-11-23T23:50:00Z info jobs: job 7 (bracket) started on camera v4l2:...
//   camlab 2026-11-23T23:50:01Z debug calib: stage 0.041 s rms 0.2143 outliers 0 ...
//
// Each line has a category (the part of camlab that speaks) and a level. What is written
// is chosen once per process by the environment variable CAMLAB_LOG, a comma-separated
// list of LEVEL (every category) or CATEGORY=LEVEL, e.g. CAMLAB_LOG=calib=debug or
// CAMLAB_LOG=warning,jobs=debug. The default level is info. Levels: debug, info,
// warning, error, off. A malformed CAMLAB_LOG is reported once and otherwise ignored.
//
// Thread-safe.
#pragma once

#include <cstdarg>
#include <string>
#include <string_view>

namespace camlab::log {

enum class Level { kDebug, kInfo, kWarning, kError, kOff };

enum class Category {
  kDaemon,   // "camlabd": start, stop, configuration
  kHttp,     // "http": connections
  kJobs,     // "jobs": capture, calibration and analysis jobs
  kCameras,  // "cameras": opening, losing and probing cameras
  kCalib,    // "calib": the calibration solve's stages
  kVcam,     // "vcam": the virtual camera's device
};

std::string_view name_of(Category category);
std::string_view name_of(Level level);

// The threshold of every category, parsed from a CAMLAB_LOG value. Items that are not
// LEVEL or CATEGORY=LEVEL are left out and listed in *bad (comma-separated).
struct Thresholds {
  Level by_category[6];
  Level of(Category category) const { return by_category[static_cast<int>(category)]; }
};
Thresholds parse_thresholds(std::string_view spec, std::string* bad);

// The program name that starts every line ("camlab" unless set; camlabd sets "camlabd").
// Call before any thread logs.
void set_program_name(std::string_view name);

// The file descriptor lines are written to: STDERR_FILENO unless set. Code that captures
// fd 2 for a while (a library's chatter: calib/library_stderr.h) points the log at a
// duplicate of the real stderr meanwhile, so camlab's own lines still reach the user; it
// must keep that descriptor open for as long as any thread may still be writing.
void set_output_fd(int fd);

// Whether a line of `category` at `level` would be written: guard costly messages with it.
bool enabled(Category category, Level level);

void write(Category category, Level level, const char* format, ...)
    __attribute__((format(printf, 3, 4)));
void vwrite(Category category, Level level, const char* format, va_list args)
    __attribute__((format(printf, 3, 0)));

}  // namespace camlab::log

namespace camlab {

// The usual calls: log_info(log::Category::kJobs, "job %lld started", id).
void log_debug(log::Category category, const char* format, ...)
    __attribute__((format(printf, 2, 3)));
void log_info(log::Category category, const char* format, ...)
    __attribute__((format(printf, 2, 3)));
void log_warning(log::Category category, const char* format, ...)
    __attribute__((format(printf, 2, 3)));
void log_error(log::Category category, const char* format, ...)
    __attribute__((format(printf, 2, 3)));

}  // namespace camlab
