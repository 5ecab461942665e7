#include "base/file_mode.h"

#include <sys/stat.h>

#include <atomic>
#include <cstdio>
#include <cstring>
#include <fstream>

namespace camlab {

namespace {

// The umask, read from /proc rather than by umask(2), which can only be read by setting
// it: another thread creating a file in between would get the wrong mode.
mode_t process_umask() {
  std::ifstream status("/proc/self/status");
  std::string line;
  while (std::getline(status, line)) {
    unsigned value = 0;
    if (std::sscanf(line.c_str(), "Umask: %o", &value) == 1) return static_cast<mode_t>(value);
  }
  return 022;  // kernels before 4.7 do not say: the usual default
}

// -1: not chosen, follow the umask.
std::atomic<int> g_chosen_mode{-1};

}  // namespace

mode_t data_file_mode() {
  const int chosen = g_chosen_mode.load();
  if (chosen >= 0) return static_cast<mode_t>(chosen);
  static const mode_t from_umask = 0666 & ~process_umask();
  return from_umask;
}

void set_data_file_mode(mode_t mode) { g_chosen_mode = static_cast<int>(mode & 0777); }

Result<mode_t> parse_data_file_mode(const std::string& text) {
  const std::string rule =
      "a file mode is 3 or 4 octal digits within 0666 that keep the owner's read and write "
      "(0600 .. 0666), e.g. 0640";
  if (text.empty() || text.size() > 4 || text.find_first_not_of("01234567") != std::string::npos)
    return make_error("invalid_argument",
                      "'" + text.substr(0, 20) + "' is not an octal mode: " + rule);
  const mode_t mode = static_cast<mode_t>(std::stoul(text, nullptr, 8));
  if ((mode & ~static_cast<mode_t>(0666)) != 0 || (mode & 0600) != 0600)
    return make_error("invalid_argument", "file mode " + text + " is not allowed: " + rule);
  return mode;
}

}  // namespace camlab
