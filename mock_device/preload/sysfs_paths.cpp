#include "mock_device/preload/sysfs_paths.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <climits>
#include <cstdlib>
#include <cstring>

#include "mock_device/preload/directory_listing.h"
#include "mock_device/preload/real_libc.h"
#include "mock_device/v4l2/fake_sysfs.h"

namespace camlab::mock::preload {

namespace {

struct Config {
  int count = 1;
  std::string root;       // the fake sysfs; empty: none
  std::string udev_root;  // the fake udev database; empty: none
  std::string v4l_root;   // what /dev/v4l holds; empty: none
};

const Config& config() {
  static const Config c = [] {
    Config c;
    if (const char* text = std::getenv("CAMLAB_VCAM_COUNT")) c.count = std::max(1, std::atoi(text));
    if (const char* root = std::getenv("CAMLAB_VCAM_SYSFS")) c.root = root;
    if (const char* root = std::getenv("CAMLAB_VCAM_UDEV")) c.udev_root = root;
    if (const char* root = std::getenv("CAMLAB_VCAM_DEV_V4L")) c.v4l_root = root;
    return c;
  }();
  return c;
}

bool starts_with(const char* text, const char* prefix) {
  return std::strncmp(text, prefix, std::strlen(prefix)) == 0;
}

// Whether a relative path names something a fake tree starts with (the folders and links
// the listings gain, directory_listing.h): only those can lead from a real folder into a
// fake tree.
bool may_enter_fake_tree(const char* path) {
  return std::strstr(path, "video4linux") || std::strstr(path, "media") ||
         std::strstr(path, "camlab_vcam_hcd") || std::strstr(path, "81:") ||
         std::strstr(path, "236:");
}

}  // namespace

int vcam_count() { return config().count; }
bool has_fake_sysfs() { return !config().root.empty(); }
bool has_fake_udev_database() { return !config().udev_root.empty(); }

bool has_fake_dev_v4l() { return !config().v4l_root.empty(); }

const char* device_behind_v4l_link(const char* path, std::string* storage) {
  const Config& c = config();
  if (!path || c.v4l_root.empty() || !starts_with(path, "/dev/v4l/by-")) return nullptr;
  std::string redirected;
  if (!redirect_sysfs_path(path, &redirected)) return nullptr;
  char target[PATH_MAX];
  const ssize_t n = real().readlink(redirected.c_str(), target, sizeof target - 1);
  if (n <= 0) return nullptr;
  target[n] = '\0';
  // write_v4l_links' targets: ../../videoN.
  const char* name = std::strrchr(target, '/');
  name = name ? name + 1 : target;
  if (std::strncmp(name, "video", 5) != 0) return nullptr;
  *storage = std::string("/dev/") + name;
  return storage->c_str();
}

const char* redirect_sysfs_path(const char* path, std::string* storage) {
  const Config& c = config();
  if (!path) return nullptr;
  if (!c.v4l_root.empty() && starts_with(path, "/dev/v4l") && (path[8] == '\0' || path[8] == '/')) {
    *storage = c.v4l_root + (path + 8);  // keep everything after "/dev/v4l"
    return storage->c_str();
  }
  if (!c.udev_root.empty() && starts_with(path, "/run/udev/")) {
    if (!camlab::mock::is_fake_udev_path(path, c.count)) return nullptr;
    *storage = c.udev_root + (path + 9);  // keep everything after "/run/udev"
    return storage->c_str();
  }
  if (c.root.empty() || !starts_with(path, "/sys/")) return nullptr;
  // Header-only and allocation-free (mock_device/v4l2/fake_sysfs.h): the preload links none
  // of the mock device library.
  if (!camlab::mock::is_fake_sysfs_path(path, c.count)) return nullptr;
  *storage = c.root + (path + 4);  // keep everything after "/sys"
  return storage->c_str();
}

const char* redirect_sysfs_path_at(int dirfd, const char* path, std::string* storage) {
  if (!path || path[0] == '\0') return nullptr;
  if (path[0] == '/') return redirect_sysfs_path(path, storage);
  if ((!has_fake_sysfs() && !has_fake_udev_database()) || !may_enter_fake_tree(path))
    return nullptr;
  std::string folder = path_of_fd(dirfd);
  if (folder.empty() || folder[0] != '/') return nullptr;
  if (folder.back() != '/') folder += '/';
  const std::string joined = folder + path;
  if (!redirect_sysfs_path(joined.c_str(), storage)) return nullptr;
  return storage->c_str();
}

bool is_inside_fake_sysfs(const std::string& real_path) {
  const std::string& root = config().root;
  return !root.empty() && real_path.compare(0, root.size(), root) == 0 &&
         (real_path.size() == root.size() || real_path[root.size()] == '/');
}

void unredirect_sysfs_path(char* resolved) {
  const std::string& root = config().root;
  if (root.empty() || std::strncmp(resolved, root.c_str(), root.size()) != 0) return;
  const char* rest = resolved + root.size();
  if (*rest != '/' && *rest != '\0') return;
  std::string back = std::string("/sys") + rest;
  std::memcpy(resolved, back.c_str(), back.size() + 1);  // root is longer than "/sys"
}

}  // namespace camlab::mock::preload
