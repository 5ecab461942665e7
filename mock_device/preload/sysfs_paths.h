// Paths of the fake sysfs and udev database: clients such as v4l2-ctl read
// /sys/dev/char/81:N/uevent to learn that a character device is a video node,
// enumerators walk /sys/class/video4linux, libcamera's sysfs enumerator walks
// /sys/bus/media, the media and video nodes' /sys/dev/char links and the USB device
// folders above them (camlab::mock::is_fake_sysfs_path says which paths), and udev's
// enumerator (libudev, under GStreamer's device monitor) reads each video node's
// properties from /run/udev/data/c81:N. The trees are real files in folders `camlab vcam
// run` writes (CAMLAB_VCAM_SYSFS and CAMLAB_VCAM_UDEV, mock_device/v4l2/fake_sysfs.h);
// paths under those roots are redirected into them, and paths resolved inside the sysfs
// tree are reported back under /sys. /dev/v4l (udev's persistent names) is a third such
// tree (CAMLAB_VCAM_DEV_V4L).
//
// Thread-safe (configuration read once).
#pragma once

#include <string>

namespace camlab::mock::preload {

// CAMLAB_VCAM_COUNT: how many virtual cameras the run has (1 when unset).
int vcam_count();
// Whether the run has a fake sysfs (CAMLAB_VCAM_SYSFS) and udev database
// (CAMLAB_VCAM_UDEV).
bool has_fake_sysfs();
bool has_fake_udev_database();

// Whether the run has the /dev/v4l links (CAMLAB_VCAM_DEV_V4L: a folder standing for
// /dev/v4l, with by-id/ and by-path/ links to ../../videoN, fake_sysfs.h).
bool has_fake_dev_v4l();

// The video node a /dev/v4l link names ("/dev/videoN", in `storage`), for the calls that
// follow links (open, stat, realpath): the link's target is relative to /dev/v4l/by-*,
// not to the folder it really lies in. nullptr for any other path.
const char* device_behind_v4l_link(const char* path, std::string* storage);

// The redirected path, or nullptr when `path` is not one of the fake trees'. The
// returned pointer lives in `storage`.
const char* redirect_sysfs_path(const char* path, std::string* storage);

// The same for a path relative to the folder `dirfd` names (the *at() calls; AT_FDCWD:
// the working folder): libudev walks /sys one name at a time (openat(fd, "video4linux",
// O_PATH)), so a relative name can step from a real folder into a fake tree. Only names
// that start a fake tree cost a look at /proc/self/fd.
const char* redirect_sysfs_path_at(int dirfd, const char* path, std::string* storage);

// Rewrites a resolved path inside the fake tree back to its /sys form, in place (the
// result is never longer).
void unredirect_sysfs_path(char* resolved);

// Whether a real path (an fd's, as /proc/self/fd names it) is inside the fake sysfs.
bool is_inside_fake_sysfs(const std::string& real_path);

}  // namespace camlab::mock::preload
