#include "mock_device/preload/real_libc.h"

#include <dlfcn.h>

namespace camlab::mock::preload {

namespace {

template <class F>
void resolve(F& function, const char* name) {
  function = reinterpret_cast<F>(dlsym(RTLD_NEXT, name));
}

RealLibc resolve_all() {
  RealLibc r{};
  resolve(r.open, "open");
  resolve(r.openat, "openat");
  resolve(r.close, "close");
  resolve(r.dup, "dup");
  resolve(r.dup2, "dup2");
  resolve(r.dup3, "dup3");
  resolve(r.fcntl, "fcntl");
  resolve(r.ioctl, "ioctl");
  resolve(r.read, "read");
  resolve(r.write, "write");
  resolve(r.mmap, "mmap");
  resolve(r.munmap, "munmap");
  resolve(r.poll, "poll");
  resolve(r.ppoll, "ppoll");
  resolve(r.select, "select");
  resolve(r.pselect, "pselect");
  resolve(r.fstat, "fstat");
  resolve(r.stat, "stat");
  resolve(r.lstat, "lstat");
  resolve(r.fstatat, "fstatat");
  resolve(r.statx, "statx");
  resolve(r.statfs, "statfs");
  resolve(r.fstatfs, "fstatfs");
  resolve(r.access, "access");
  resolve(r.faccessat, "faccessat");
  resolve(r.realpath, "realpath");
  resolve(r.fopen, "fopen");
  resolve(r.opendir, "opendir");
  resolve(r.fdopendir, "fdopendir");
  resolve(r.readdir, "readdir");
  resolve(r.readdir_r, "readdir_r");
  resolve(r.closedir, "closedir");
  resolve(r.rewinddir, "rewinddir");
  resolve(r.seekdir, "seekdir");
  resolve(r.scandir, "scandir");
  resolve(r.scandirat, "scandirat");
  resolve(r.glob, "glob");
  resolve(r.glob64, "glob64");
  resolve(r.readlink, "readlink");
  resolve(r.getxattr, "getxattr");
  resolve(r.lgetxattr, "lgetxattr");
  resolve(r.listxattr, "listxattr");
  resolve(r.llistxattr, "llistxattr");
  resolve(r.readlinkat, "readlinkat");
  resolve(r.syscall, "syscall");
  return r;
}

}  // namespace

const RealLibc& real() {
  static const RealLibc r = resolve_all();
  return r;
}

}  // namespace camlab::mock::preload
