// Directory listings that show the virtual cameras. Programs find cameras by listing
// folders, not by opening names they already know: `v4l2-ctl --list-devices` and ffmpeg
// read /dev, a shell expands /dev/video*, and udev's enumerator (GStreamer's device
// monitor, through libgudev) lists /sys/class and /sys/bus for a "video4linux" folder
// before it looks inside. So a listing of
//   /dev                   gains videoN and mediaN (character devices),
//   /sys/class             gains video4linux and media (folders of the fake sysfs),
//   /sys/bus               gains media,
//   /sys/dev/char          gains 81:N and 236:N (links),
//   /sys/devices/platform  gains camlab_vcam_hcd.0 (the virtual host controller),
//   /run/udev/data         gains c81:N (the udev database entries of the video nodes),
// for N below CAMLAB_VCAM_COUNT, after the real entries and only where the real folder
// does not list the name already. The folders inside the fake trees are real folders
// (their paths are redirected, sysfs_paths.h), so they list without help.
//
// A DirectoryStreams entry follows each open DIR* whose folder gains entries, from
// opendir/fdopendir to closedir: readdir hands out the real entries, then the extra ones.
// scandir and glob are rebuilt on these (glibc's own call its internal opendir, which no
// preload reaches).
//
// Thread-safe (one mutex; each DIR* is used by one thread at a time, as POSIX requires).
#pragma once

#include <dirent.h>

#include <string>
#include <vector>

namespace camlab::mock::preload {

struct ExtraEntry {
  std::string name;
  unsigned char type;  // DT_CHR, DT_DIR, DT_LNK, DT_REG
};

// The entries a listing of `path` (as the client named it; trailing slashes allowed)
// gains; empty for every other folder.
std::vector<ExtraEntry> extra_entries(const char* path);

// Whether a listing of `path` gains entries or is redirected into a fake tree: the
// folders scandir and glob must list through the interposed opendir.
bool listing_is_virtual(const char* path);

// Starts following `dir` (just opened on a folder that gains `extras`).
void track_directory(DIR* dir, std::vector<ExtraEntry> extras);
// readdir(3) for a followed stream (the real entries, then the extras), or the real
// readdir for any other.
dirent* read_directory(DIR* dir);
// closedir, rewinddir and seekdir: the extras start over (seekdir) or are dropped.
void forget_directory(DIR* dir);
void rewind_directory(DIR* dir);

// The folder an open fd names (/proc/self/fd; AT_FDCWD: the working folder), for
// fdopendir and for *at() calls with a relative path; empty when it cannot be read.
std::string path_of_fd(int fd);

}  // namespace camlab::mock::preload
