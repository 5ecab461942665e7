#include "mock_device/preload/sysfs_paths.h"

#include <algorithm>
#include <cstdlib>
#include <cstring>

#include "mock_device/v4l2/fake_sysfs.h"

namespace camlab::mock::preload {

namespace {

struct Config {
  int count = 1;
  std::string root;  // the fake tree; empty: no fake sysfs
};

const Config& config() {
  static const Config c = [] {
    Config c;
    if (const char* text = std::getenv("CAMLAB_VCAM_COUNT")) c.count = std::max(1, std::atoi(text));
    if (const char* root = std::getenv("CAMLAB_VCAM_SYSFS")) c.root = root;
    return c;
  }();
  return c;
}

bool starts_with(const char* text, const char* prefix) {
  return std::strncmp(text, prefix, std::strlen(prefix)) == 0;
}

}  // namespace

int vcam_count() { return config().count; }

const char* redirect_sysfs_path(const char* path, std::string* storage) {
  const Config& c = config();
  if (!path || c.root.empty() || !starts_with(path, "/sys/")) return nullptr;
  // Header-only and allocation-free (mock_device/v4l2/fake_sysfs.h): the preload links none
  // of the mock device library.
  if (!camlab::mock::is_fake_sysfs_path(path, c.count)) return nullptr;
  *storage = c.root + (path + 4);  // keep everything after "/sys"
  return storage->c_str();
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
