// The libc entry points the preload library interposes, as the next definition in the
// lookup order (dlsym RTLD_NEXT): the library's own system calls go through these, never
// through its interposers, so they cannot loop back into it or take its locks twice.
//
// Thread-safe (resolved once).
#pragma once

#include <dirent.h>
#include <glob.h>
#include <poll.h>
#include <signal.h>
#include <stdio.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <sys/statfs.h>
#include <sys/types.h>

#include "base/unique_fd.h"

namespace camlab::mock::preload {

struct RealLibc {
  int (*open)(const char*, int, ...);
  int (*openat)(int, const char*, int, ...);
  int (*close)(int);
  int (*dup)(int);
  int (*dup2)(int, int);
  int (*dup3)(int, int, int);
  int (*fcntl)(int, int, ...);
  int (*ioctl)(int, unsigned long, ...);
  ssize_t (*read)(int, void*, size_t);
  ssize_t (*write)(int, const void*, size_t);
  void* (*mmap)(void*, size_t, int, int, int, off_t);
  int (*munmap)(void*, size_t);
  int (*poll)(pollfd*, nfds_t, int);
  int (*ppoll)(pollfd*, nfds_t, const timespec*, const sigset_t*);
  int (*select)(int, fd_set*, fd_set*, fd_set*, timeval*);
  int (*pselect)(int, fd_set*, fd_set*, fd_set*, const timespec*, const sigset_t*);
  int (*fstat)(int, struct stat*);
  int (*stat)(const char*, struct stat*);
  int (*lstat)(const char*, struct stat*);
  int (*fstatat)(int, const char*, struct stat*, int);
  int (*statx)(int, const char*, int, unsigned, struct statx*);
  int (*statfs)(const char*, struct statfs*);
  int (*fstatfs)(int, struct statfs*);
  int (*access)(const char*, int);
  int (*faccessat)(int, const char*, int, int);
  char* (*realpath)(const char*, char*);
  FILE* (*fopen)(const char*, const char*);
  DIR* (*opendir)(const char*);
  DIR* (*fdopendir)(int);
  dirent* (*readdir)(DIR*);
  int (*readdir_r)(DIR*, dirent*, dirent**);
  int (*closedir)(DIR*);
  void (*rewinddir)(DIR*);
  void (*seekdir)(DIR*, long);
  int (*scandir)(const char*, dirent***, int (*)(const dirent*),
                 int (*)(const dirent**, const dirent**));
  int (*scandirat)(int, const char*, dirent***, int (*)(const dirent*),
                   int (*)(const dirent**, const dirent**));
  int (*glob)(const char*, int, int (*)(const char*, int), glob_t*);
  int (*glob64)(const char*, int, int (*)(const char*, int), glob64_t*);
  ssize_t (*readlink)(const char*, char*, size_t);
  ssize_t (*getxattr)(const char*, const char*, void*, size_t);
  ssize_t (*lgetxattr)(const char*, const char*, void*, size_t);
  ssize_t (*listxattr)(const char*, char*, size_t);
  ssize_t (*llistxattr)(const char*, char*, size_t);
  ssize_t (*readlinkat)(int, const char*, char*, size_t);
  long (*syscall)(long, ...);
};

const RealLibc& real();

// Owners of the library's own fds (base/unique_fd.h): closed through the real close, so
// that releasing one never re-enters the interposed close (and its locks).
struct RealFdCloser {
  void operator()(int fd) const noexcept { real().close(fd); }
};
using RealFd = BasicUniqueFd<RealFdCloser>;

}  // namespace camlab::mock::preload
