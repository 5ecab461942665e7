#include "mock_device/preload/directory_listing.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstddef>
#include <cstdio>
#include <cstring>
#include <map>
#include <mutex>
#include <set>
#include <string_view>

#include "mock_device/preload/real_libc.h"
#include "mock_device/preload/sysfs_paths.h"
#include "mock_device/v4l2/fake_sysfs.h"

namespace camlab::mock::preload {

namespace {

// One followed stream: the extras still to hand out, the names the real folder listed
// (an extra it already has is not listed twice), and the dirent readdir returns (valid
// until the next readdir of the stream, as POSIX allows).
struct Stream {
  std::vector<ExtraEntry> extras;
  size_t next_extra = 0;
  std::set<std::string> seen;
  dirent entry{};
};

std::mutex& streams_mutex() {
  static std::mutex m;
  return m;
}
std::map<DIR*, Stream>& streams() {
  static std::map<DIR*, Stream> s;
  return s;
}

std::string_view without_trailing_slashes(const char* path) {
  std::string_view p(path);
  while (p.size() > 1 && p.back() == '/') p.remove_suffix(1);
  return p;
}

}  // namespace

std::vector<ExtraEntry> extra_entries(const char* path) {
  std::vector<ExtraEntry> extras;
  if (!path) return extras;
  const std::string_view p = without_trailing_slashes(path);
  const int count = vcam_count();
  if (p == "/dev") {
    for (int n = 0; n < count; ++n) extras.push_back({"video" + std::to_string(n), DT_CHR});
    for (int n = 0; n < count; ++n) extras.push_back({"media" + std::to_string(n), DT_CHR});
    if (has_fake_dev_v4l()) extras.push_back({"v4l", DT_DIR});
  }
  if (!has_fake_sysfs()) return extras;
  if (p == "/sys/class") {
    extras.push_back({"video4linux", DT_DIR});
    extras.push_back({"media", DT_DIR});
  } else if (p == "/sys/bus") {
    extras.push_back({"media", DT_DIR});
  } else if (p == "/sys/dev/char") {
    for (int n = 0; n < count; ++n)
      extras.push_back({std::to_string(kVideoMajor) + ":" + std::to_string(n), DT_LNK});
    for (int n = 0; n < count; ++n)
      extras.push_back({std::to_string(kMediaMajor) + ":" + std::to_string(n), DT_LNK});
  } else if (p == "/sys/devices/platform") {
    extras.push_back({std::string(kHostControllerPath).substr(p.size() + 1), DT_DIR});
  } else if (p == "/run/udev/data" && has_fake_udev_database()) {
    for (int n = 0; n < count; ++n)
      extras.push_back({"c" + std::to_string(kVideoMajor) + ":" + std::to_string(n), DT_REG});
  }
  return extras;
}

bool listing_is_virtual(const char* path) {
  if (!path) return false;
  std::string storage;
  return !extra_entries(path).empty() || redirect_sysfs_path(path, &storage) != nullptr;
}

void track_directory(DIR* dir, std::vector<ExtraEntry> extras) {
  if (!dir || extras.empty()) return;
  std::lock_guard lock(streams_mutex());
  Stream& s = streams()[dir];
  s = Stream{};
  s.extras = std::move(extras);
}

dirent* read_directory(DIR* dir) {
  {
    std::lock_guard lock(streams_mutex());
    if (streams().find(dir) == streams().end()) return real().readdir(dir);
  }
  // The real entries first (a DIR* is used by one thread at a time: no lock held across
  // the real call, whose entry the stream's owner reads).
  const int saved_errno = errno;
  errno = 0;
  dirent* real_entry = real().readdir(dir);
  const int read_errno = errno;
  std::lock_guard lock(streams_mutex());
  auto it = streams().find(dir);
  if (it == streams().end()) {
    errno = read_errno ? read_errno : saved_errno;
    return real_entry;
  }
  Stream& s = it->second;
  if (real_entry) {
    s.seen.insert(real_entry->d_name);
    errno = saved_errno;
    return real_entry;
  }
  if (read_errno != 0) {  // an error, not the end: say so, add nothing
    errno = read_errno;
    return nullptr;
  }
  while (s.next_extra < s.extras.size()) {
    const ExtraEntry& extra = s.extras[s.next_extra++];
    if (s.seen.count(extra.name)) continue;
    s.entry = dirent{};
    // Inode numbers of the extras: nonzero (0 means a deleted entry to some readers),
    // and far from the small numbers of /dev's tmpfs.
    s.entry.d_ino = 0x7CA3000000ull + s.next_extra;
    s.entry.d_off = static_cast<off_t>(0x7CA3000000ll + static_cast<long long>(s.next_extra));
    s.entry.d_reclen = sizeof(dirent);
    s.entry.d_type = extra.type;
    std::strncpy(s.entry.d_name, extra.name.c_str(), sizeof s.entry.d_name - 1);
    errno = saved_errno;
    return &s.entry;
  }
  errno = saved_errno;
  return nullptr;
}

void forget_directory(DIR* dir) {
  std::lock_guard lock(streams_mutex());
  streams().erase(dir);
}

void rewind_directory(DIR* dir) {
  std::lock_guard lock(streams_mutex());
  auto it = streams().find(dir);
  if (it == streams().end()) return;
  it->second.next_extra = 0;
  it->second.seen.clear();
}

std::string path_of_fd(int fd) {
  char link[32];
  if (fd == AT_FDCWD)
    std::snprintf(link, sizeof link, "/proc/self/cwd");
  else
    std::snprintf(link, sizeof link, "/proc/self/fd/%d", fd);
  char target[PATH_MAX];
  const ssize_t n = real().readlink(link, target, sizeof target - 1);
  if (n <= 0) return {};
  return std::string(target, static_cast<size_t>(n));
}

}  // namespace camlab::mock::preload
