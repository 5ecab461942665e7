#include "base/log.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <cstdarg>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <iterator>
#include <string>

namespace camlab::log {

namespace {

constexpr std::array<std::string_view, 6> kCategoryNames = {"camlabd", "http",  "jobs",
                                                            "cameras", "calib", "vcam"};
constexpr std::array<std::string_view, 5> kLevelNames = {"debug", "info", "warning", "error",
                                                         "off"};

// Lines longer than this are cut (a log line is for a person to read).
constexpr size_t kMaxMessageBytes = 4096;

std::atomic<int> g_output_fd{STDERR_FILENO};

void write_stderr(const std::string& line) {
  // One write(2): atomic for lines under PIPE_BUF, so threads never interleave.
  [[maybe_unused]] ssize_t n = ::write(g_output_fd.load(), line.data(), line.size());
}

bool parse_level(std::string_view text, Level* level) {
  for (size_t i = 0; i < kLevelNames.size(); ++i) {
    if (text == kLevelNames[i]) {
      *level = static_cast<Level>(i);
      return true;
    }
  }
  return false;
}

// CAMLAB_LOG, read once; a malformed item is reported once.
const Thresholds& thresholds() {
  static const Thresholds parsed = [] {
    const char* given = std::getenv("CAMLAB_LOG");
    std::string bad;
    Thresholds t = parse_thresholds(given ? given : "", &bad);
    if (!bad.empty()) {
      std::string known = "categories";
      for (auto name : kCategoryNames) known += " " + std::string(name);
      write_stderr("CAMLAB_LOG: ignoring '" + bad + "' (levels debug info warning error off; " +
                   known + ")\n");
    }
    return t;
  }();
  return parsed;
}

std::string& program_name() {
  static std::string name = "camlab";
  return name;
}

}  // namespace

Thresholds parse_thresholds(std::string_view spec, std::string* bad) {
  static_assert(std::size(Thresholds{}.by_category) == kCategoryNames.size());
  Thresholds t;
  std::fill(std::begin(t.by_category), std::end(t.by_category), Level::kInfo);
  auto reject = [bad](std::string_view item) {
    if (!bad->empty()) *bad += ", ";
    *bad += item;
  };
  while (!spec.empty()) {
    const size_t comma = spec.find(',');
    const std::string_view item = spec.substr(0, comma);
    spec = comma == std::string_view::npos ? std::string_view() : spec.substr(comma + 1);
    if (item.empty()) continue;
    const size_t equals = item.find('=');
    Level level;
    if (equals == std::string_view::npos) {
      if (parse_level(item, &level))
        std::fill(std::begin(t.by_category), std::end(t.by_category), level);
      else
        reject(item);
      continue;
    }
    const std::string_view category = item.substr(0, equals);
    const auto known = std::find(kCategoryNames.begin(), kCategoryNames.end(), category);
    if (known == kCategoryNames.end() || !parse_level(item.substr(equals + 1), &level)) {
      reject(item);
      continue;
    }
    t.by_category[known - kCategoryNames.begin()] = level;
  }
  return t;
}

void vwrite(Category category, Level level, const char* format, va_list args) {
  if (!enabled(category, level)) return;
  char message[kMaxMessageBytes];
  std::vsnprintf(message, sizeof message, format, args);
  const std::time_t now = std::time(nullptr);
  std::tm tm{};
  gmtime_r(&now, &tm);
  char stamp[32];
  std::strftime(stamp, sizeof stamp, "%Y-%m-%dT%H:%M:%SZ", &tm);
  std::string line = program_name();
  line += ' ';
  line += stamp;
  line += ' ';
  line += name_of(level);
  line += ' ';
  line += name_of(category);
  line += ": ";
  line += message;
  line += '\n';
  write_stderr(line);
}

std::string_view name_of(Category category) {
  return kCategoryNames[static_cast<size_t>(category)];
}

std::string_view name_of(Level level) { return kLevelNames[static_cast<size_t>(level)]; }

void set_program_name(std::string_view name) { program_name() = std::string(name); }

void set_output_fd(int fd) { g_output_fd.store(fd >= 0 ? fd : STDERR_FILENO); }

bool enabled(Category category, Level level) {
  return level != Level::kOff && level >= thresholds().of(category);
}

void write(Category category, Level level, const char* format, ...) {
  va_list args;
  va_start(args, format);
  vwrite(category, level, format, args);
  va_end(args);
}

}  // namespace camlab::log

namespace camlab {

// The four levels' calls differ only in their level; printf-style arguments cannot be
// forwarded through a template, hence the macro.
#define CAMLAB_DEFINE_LOG_CALL(function, level)                    \
  void function(log::Category category, const char* format, ...) { \
    va_list args;                                                  \
    va_start(args, format);                                        \
    log::vwrite(category, level, format, args);                    \
    va_end(args);                                                  \
  }

CAMLAB_DEFINE_LOG_CALL(log_debug, log::Level::kDebug)
CAMLAB_DEFINE_LOG_CALL(log_info, log::Level::kInfo)
CAMLAB_DEFINE_LOG_CALL(log_warning, log::Level::kWarning)
CAMLAB_DEFINE_LOG_CALL(log_error, log::Level::kError)

#undef CAMLAB_DEFINE_LOG_CALL

}  // namespace camlab
