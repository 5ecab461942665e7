// Paths of the fake sysfs: clients such as v4l2-ctl read /sys/dev/char/81:N/uevent to
// learn that a character device is a video node, enumerators walk
// /sys/class/video4linux, and libcamera's sysfs enumerator walks /sys/bus/media, the
// media and video nodes' /sys/dev/char links and the USB device folders above them
// (camlab::mock::is_fake_sysfs_path says which paths). The tree is real files in a folder `camlab
// vcam run` writes (CAMLAB_VCAM_SYSFS, mock_device/v4l2/fake_sysfs.h); paths under those sysfs
// roots are redirected into it, and paths resolved inside it are reported back under /sys.
//
// Thread-safe (configuration read once).
#pragma once

#include <string>

namespace camlab::mock::preload {

// CAMLAB_VCAM_COUNT: how many virtual cameras the run has (1 when unset).
int vcam_count();

// The redirected path, or nullptr when `path` is not one of the fake tree's. The
// returned pointer lives in `storage`.
const char* redirect_sysfs_path(const char* path, std::string* storage);

// Rewrites a resolved path inside the fake tree back to its /sys form, in place (the
// result is never longer).
void unredirect_sysfs_path(char* resolved);

}  // namespace camlab::mock::preload
