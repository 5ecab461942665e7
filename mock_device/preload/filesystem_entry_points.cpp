// The preload library's statfs and fstatfs: the fake sysfs is ordinary files in a
// temporary folder, but libudev accepts a device folder only on a sysfs filesystem
// (it checks with fstatfs on the folder it walked to), so files inside the fake tree
// report sysfs's magic number. Everything else is the real filesystem's answer.
#include <linux/magic.h>
#include <sys/statfs.h>

#include <string>

#include "mock_device/preload/directory_listing.h"
#include "mock_device/preload/real_libc.h"
#include "mock_device/preload/sysfs_paths.h"

namespace {

using camlab::mock::preload::real;
namespace preload = camlab::mock::preload;

void as_sysfs(struct statfs* st) { st->f_type = SYSFS_MAGIC; }

}  // namespace

#pragma GCC visibility push(default)
extern "C" {

int statfs(const char* path, struct statfs* st) {
  std::string storage;
  const char* redirected = preload::redirect_sysfs_path(path, &storage);
  const int result = real().statfs(redirected ? redirected : path, st);
  if (result == 0 && redirected) as_sysfs(st);
  return result;
}
// struct statfs64 is struct statfs on 64-bit glibc.
int statfs64(const char* path, struct statfs64* st) {
  return statfs(path, reinterpret_cast<struct statfs*>(st));
}

int fstatfs(int fd, struct statfs* st) {
  const int result = real().fstatfs(fd, st);
  // Only a folder on the fake tree's filesystem can be inside it: one look at
  // /proc/self/fd for those.
  if (result == 0 && preload::has_fake_sysfs() && st->f_type != SYSFS_MAGIC &&
      preload::is_inside_fake_sysfs(preload::path_of_fd(fd)))
    as_sysfs(st);
  return result;
}
int fstatfs64(int fd, struct statfs64* st) {
  return fstatfs(fd, reinterpret_cast<struct statfs*>(st));
}

}  // extern "C"
#pragma GCC visibility pop
