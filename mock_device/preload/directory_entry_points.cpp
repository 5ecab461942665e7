// The preload library's directory entry points (directory_listing.h): opendir and
// fdopendir start following a folder whose listing shows the virtual cameras, readdir
// (and readdir64, readdir_r, readdir64_r) hands out its entries, closedir, rewinddir and
// seekdir keep the bookkeeping, and scandir and glob are rebuilt on them for the folders
// that need it (glibc's own reach its internal opendir, past any preload). Folders of the
// fake trees are opened where they really are (sysfs_paths.h).
#include <dirent.h>
#include <fcntl.h>
#include <glob.h>
#include <sys/stat.h>

#include <cerrno>
#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <string>

#include "mock_device/preload/directory_listing.h"
#include "mock_device/preload/real_libc.h"
#include "mock_device/preload/sysfs_paths.h"

namespace {

using camlab::mock::preload::real;
namespace preload = camlab::mock::preload;

using Filter = int (*)(const dirent*);
using Compare = int (*)(const dirent**, const dirent**);

// The interposed opendir: redirected into a fake tree, and followed when its listing
// gains entries.
DIR* open_directory(const char* path) {
  std::string storage;
  const char* redirected = preload::redirect_sysfs_path(path, &storage);
  DIR* dir = real().opendir(redirected ? redirected : path);
  if (dir && !redirected) preload::track_directory(dir, preload::extra_entries(path));
  return dir;
}

void close_directory(DIR* dir) {
  preload::forget_directory(dir);
  real().closedir(dir);
}

// scandir(3) on the interposed opendir/readdir: the entries `filter` keeps, each in its
// own malloc'd dirent, in a malloc'd array sorted by `compare` (the caller frees both, as
// with glibc's).
int scan_directory(const char* path, dirent*** names, Filter filter, Compare compare) {
  DIR* dir = open_directory(path);
  if (!dir) return -1;
  dirent** list = nullptr;
  size_t count = 0, capacity = 0;
  bool failed = false;
  while (dirent* entry = preload::read_directory(dir)) {
    if (filter && !filter(entry)) continue;
    if (count == capacity) {
      capacity = capacity ? 2 * capacity : 16;
      auto* grown = static_cast<dirent**>(std::realloc(list, capacity * sizeof(dirent*)));
      if (!grown) {
        failed = true;
        break;
      }
      list = grown;
    }
    auto* copy = static_cast<dirent*>(std::malloc(sizeof(dirent)));
    if (!copy) {
      failed = true;
      break;
    }
    std::memcpy(copy, entry, offsetof(dirent, d_name));
    std::strncpy(copy->d_name, entry->d_name, sizeof copy->d_name - 1);
    copy->d_name[sizeof copy->d_name - 1] = '\0';
    list[count++] = copy;
  }
  close_directory(dir);
  if (failed) {
    for (size_t i = 0; i < count; ++i) std::free(list[i]);
    std::free(list);
    errno = ENOMEM;
    return -1;
  }
  if (compare && count > 1)
    std::qsort(list, count, sizeof(dirent*),
               reinterpret_cast<int (*)(const void*, const void*)>(compare));
  *names = list;
  return static_cast<int>(count);
}

// The folder a *at() call names, as an absolute path, when it is one whose listing is
// virtual; empty otherwise.
std::string virtual_folder_at(int dirfd, const char* path) {
  if (!path) return {};
  std::string absolute;
  if (path[0] == '/') {
    absolute = path;
  } else {
    const std::string folder = preload::path_of_fd(dirfd);
    if (folder.empty()) return {};
    absolute = folder + "/" + path;
  }
  return preload::listing_is_virtual(absolute.c_str()) ? absolute : std::string();
}

// readdir_r(3): the next entry copied into the caller's, 0 or the error.
int read_into(DIR* dir, dirent* entry, dirent** result) {
  const int saved_errno = errno;
  errno = 0;
  dirent* next = preload::read_directory(dir);
  const int error = errno;
  errno = saved_errno;
  if (!next) {
    *result = nullptr;
    return error;
  }
  std::memcpy(entry, next, sizeof(dirent));
  *result = entry;
  return 0;
}

// Whether a glob pattern may list a virtual folder: patterns under /dev, /sys and
// /run/udev (relative patterns list the working folder, which is never one of them in
// practice).
bool glob_may_list_virtual(const char* pattern) {
  return pattern &&
         (std::strncmp(pattern, "/dev/", 5) == 0 || std::strncmp(pattern, "/sys/", 5) == 0 ||
          std::strncmp(pattern, "/run/udev/", 10) == 0);
}

void* glob_opendir(const char* path) { return open_directory(path); }
dirent* glob_readdir(void* dir) { return preload::read_directory(static_cast<DIR*>(dir)); }
void glob_closedir(void* dir) { close_directory(static_cast<DIR*>(dir)); }
// glob's stat and lstat: the interposed ones (which know the virtual nodes and the fake
// trees), found the way the program would find them.
int glob_stat(const char* path, struct stat* st) { return ::stat(path, st); }
int glob_lstat(const char* path, struct stat* st) { return ::lstat(path, st); }

}  // namespace

#pragma GCC visibility push(default)
extern "C" {

DIR* opendir(const char* path) { return open_directory(path); }

DIR* fdopendir(int fd) {
  DIR* dir = real().fdopendir(fd);
  if (dir) {
    const std::string path = preload::path_of_fd(fd);
    if (!path.empty()) preload::track_directory(dir, preload::extra_entries(path.c_str()));
  }
  return dir;
}

dirent* readdir(DIR* dir) { return preload::read_directory(dir); }
// struct dirent64 is struct dirent on 64-bit glibc.
dirent64* readdir64(DIR* dir) { return reinterpret_cast<dirent64*>(preload::read_directory(dir)); }

int readdir_r(DIR* dir, dirent* entry, dirent** result) { return read_into(dir, entry, result); }
int readdir64_r(DIR* dir, dirent64* entry, dirent64** result) {
  return read_into(dir, reinterpret_cast<dirent*>(entry), reinterpret_cast<dirent**>(result));
}

int closedir(DIR* dir) {
  preload::forget_directory(dir);
  return real().closedir(dir);
}

void rewinddir(DIR* dir) {
  preload::rewind_directory(dir);
  real().rewinddir(dir);
}

void seekdir(DIR* dir, long position) {
  // Back into the real entries: the extra ones come again after them.
  preload::rewind_directory(dir);
  real().seekdir(dir, position);
}

int scandir(const char* path, dirent*** names, Filter filter, Compare compare) {
  if (preload::listing_is_virtual(path)) return scan_directory(path, names, filter, compare);
  return real().scandir(path, names, filter, compare);
}
int scandir64(const char* path, dirent64*** names, int (*filter)(const dirent64*),
              int (*compare)(const dirent64**, const dirent64**)) {
  return scandir(path, reinterpret_cast<dirent***>(names), reinterpret_cast<Filter>(filter),
                 reinterpret_cast<Compare>(compare));
}

int scandirat(int dirfd, const char* path, dirent*** names, Filter filter, Compare compare) {
  const std::string folder = virtual_folder_at(dirfd, path);
  if (!folder.empty()) return scan_directory(folder.c_str(), names, filter, compare);
  return real().scandirat(dirfd, path, names, filter, compare);
}
int scandirat64(int dirfd, const char* path, dirent64*** names, int (*filter)(const dirent64*),
                int (*compare)(const dirent64**, const dirent64**)) {
  return scandirat(dirfd, path, reinterpret_cast<dirent***>(names),
                   reinterpret_cast<Filter>(filter), reinterpret_cast<Compare>(compare));
}

int glob(const char* pattern, int flags, int (*error_callback)(const char*, int), glob_t* found) {
  if ((flags & GLOB_ALTDIRFUNC) || !glob_may_list_virtual(pattern))
    return real().glob(pattern, flags, error_callback, found);
  // glibc's glob lists folders with the functions the caller gives: these.
  found->gl_opendir = glob_opendir;
  found->gl_readdir = glob_readdir;
  found->gl_closedir = glob_closedir;
  found->gl_stat = glob_stat;
  found->gl_lstat = glob_lstat;
  return real().glob(pattern, flags | GLOB_ALTDIRFUNC, error_callback, found);
}
// glob64_t is glob_t on 64-bit glibc (dirent64 and stat64 are dirent and stat).
int glob64(const char* pattern, int flags, int (*error_callback)(const char*, int),
           glob64_t* found) {
  if ((flags & GLOB_ALTDIRFUNC) || !glob_may_list_virtual(pattern))
    return real().glob64(pattern, flags, error_callback, found);
  found->gl_opendir = glob_opendir;
  found->gl_readdir = reinterpret_cast<dirent64* (*)(void*)>(glob_readdir);
  found->gl_closedir = glob_closedir;
  found->gl_stat = reinterpret_cast<int (*)(const char*, struct stat64*)>(glob_stat);
  found->gl_lstat = reinterpret_cast<int (*)(const char*, struct stat64*)>(glob_lstat);
  return real().glob64(pattern, flags | GLOB_ALTDIRFUNC, error_callback, found);
}

}  // extern "C"
#pragma GCC visibility pop
