// The sysfs files a V4L2 client reads about video nodes, written as a real folder tree
// for the virtual devices (the kernel has no media support on camlab's test machines):
//   ROOT/dev/char/81:N/{uevent,dev,name,index}       (v4l2-ctl learns the node type here)
//   ROOT/class/video4linux/videoN/{uevent,dev,name,index}
// ROOT stands for /sys. The preload library redirects those sysfs paths into ROOT.
#pragma once

#include <string>

namespace camlab::mock {

// Writes the tree for `count` devices under `root` (which must exist). Returns false
// when a file cannot be written.
bool write_sysfs_tree(const std::string& root, int count);

}  // namespace camlab::mock
