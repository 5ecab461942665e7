// A V4L2 client that reaches the virtual device through every libc entry point the
// preload library interposes, including syscall() (as libv4l2 and libcamera do), the dup
// family, read, ppoll/pselect/select, the stat family, and the directory listings that
// show the cameras (readdir, scandir, glob, libudev's walk into /sys). Run under `camlab vcam run`;
// prints one line per failed check and exits with the number of failures.
#include <dirent.h>
#include <dlfcn.h>
#include <fcntl.h>
#include <glob.h>
#include <linux/magic.h>
#include <linux/media.h>
#include <linux/videodev2.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <sys/select.h>
#include <sys/stat.h>
#include <sys/statfs.h>
#include <sys/syscall.h>
#include <sys/sysmacros.h>
#include <sys/xattr.h>
#include <unistd.h>

#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <set>
#include <string>

namespace {

int failures = 0;

void check(bool ok, const char* what) {
  if (ok) return;
  ++failures;
  std::printf("FAIL: %s (errno %d: %s)\n", what, errno, std::strerror(errno));
}

bool querycap(int fd) {
  v4l2_capability cap{};
  return ioctl(fd, VIDIOC_QUERYCAP, &cap) == 0 && cap.driver[0] != '\0';
}

// The media controller node /dev/media0 (libcamera's way to the camera): its device
// number, the ioctls whose arrays the broker sizes, mmap and lockf.
void check_media_node() {
  const int fd = open("/dev/media0", O_RDWR | O_CLOEXEC);
  check(fd >= 0, "open /dev/media0");
  if (fd < 0) return;
  struct stat st {};
  check(fstat(fd, &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) == 236 &&
            minor(st.st_rdev) == 0,
        "fstat of the media fd is 236:0");
  check(stat("/dev/media0", &st) == 0 && major(st.st_rdev) == 236, "stat /dev/media0");
  check(stat("/sys/dev/char/236:0", &st) == 0, "the media node's sysfs folder");
  char resolved[PATH_MAX];
  check(realpath("/sys/dev/char/81:0/device", resolved) &&
            std::strncmp(resolved, "/sys/devices/", 13) == 0,
        "realpath of the video node's device");
  media_device_info info{};
  check(ioctl(fd, MEDIA_IOC_DEVICE_INFO, &info) == 0 && std::strcmp(info.driver, "uvcvideo") == 0,
        "DEVICE_INFO");
  // G_TOPOLOGY with room for one entity of three: ENOSPC, the first entity written.
  media_v2_topology topology{};
  check(ioctl(fd, MEDIA_IOC_G_TOPOLOGY, &topology) == 0 && topology.num_entities == 3,
        "G_TOPOLOGY counts");
  media_v2_entity entities[3]{};
  media_v2_topology small{};
  small.num_entities = 1;
  small.ptr_entities = reinterpret_cast<uintptr_t>(entities);
  errno = 0;
  check(ioctl(fd, MEDIA_IOC_G_TOPOLOGY, &small) == -1 && errno == ENOSPC && entities[0].id != 0 &&
            small.num_entities == 1,
        "G_TOPOLOGY too small: ENOSPC, partial array, struct not written back");
  topology.ptr_entities = reinterpret_cast<uintptr_t>(entities);
  topology.num_interfaces = topology.num_pads = topology.num_links = 0;
  check(ioctl(fd, MEDIA_IOC_G_TOPOLOGY, &topology) == 0 && entities[2].name[0] != '\0',
        "G_TOPOLOGY entities");
  // ENUM_LINKS carries no counts: the broker sizes the arrays (the sensor: one source
  // pad, one link).
  uint32_t sensor = 0;
  for (const auto& e : entities)
    if (e.function == MEDIA_ENT_F_CAM_SENSOR) sensor = e.id;
  check(sensor != 0, "G_TOPOLOGY lists the sensor entity");
  media_pad_desc pads[4]{};
  media_link_desc links[4]{};
  media_links_enum enum_links{};
  enum_links.entity = sensor;
  enum_links.pads = pads;
  enum_links.links = links;
  check(ioctl(fd, MEDIA_IOC_ENUM_LINKS, &enum_links) == 0 && links[0].source.entity == sensor &&
            links[0].sink.entity != 0 && pads[1].entity == 0,
        "ENUM_LINKS fills exactly the entity's pads and links");
  enum_links.pads = reinterpret_cast<media_pad_desc*>(16);
  errno = 0;
  check(ioctl(fd, MEDIA_IOC_ENUM_LINKS, &enum_links) == -1 && errno == EFAULT,
        "ENUM_LINKS to a bad pointer: EFAULT");
  errno = 0;
  check(mmap(nullptr, 4096, PROT_READ, MAP_SHARED, fd, 0) == MAP_FAILED && errno == ENODEV,
        "mmap of media: ENODEV");
  check(lockf(fd, F_TLOCK, 0) == 0 && lockf(fd, F_ULOCK, 0) == 0, "lockf on the media fd");
  check(close(fd) == 0, "close /dev/media0");
}

bool names_in(DIR* dir, std::set<std::string>* names) {
  if (!dir) return false;
  while (dirent* e = readdir(dir)) names->insert(e->d_name);
  return true;
}

// Listings show the virtual nodes and the fake sysfs's folders, through every way of
// listing a folder; and libudev's walk into /sys, one name at a time, lands in the fake
// tree and reports sysfs paths and a sysfs filesystem there.
void check_listings() {
  std::set<std::string> dev;
  DIR* dir = opendir("/dev");
  check(names_in(dir, &dev) && dev.count("video0") && dev.count("media0") && !dev.count("video1"),
        "readdir of /dev lists video0 and media0, and no more cameras");
  check(dev.count("null") == 1, "readdir of /dev still lists the real nodes");
  rewinddir(dir);
  std::set<std::string> again;
  check(names_in(dir, &again) && again == dev, "rewinddir lists the same again");
  closedir(dir);

  dir = opendir("/dev/");
  bool typed = false;
  while (dirent64* e = readdir64(dir))
    if (std::strcmp(e->d_name, "video0") == 0) typed = e->d_type == DT_CHR;
  closedir(dir);
  check(typed, "readdir64 of /dev/ gives video0 as a character device");

  dir = opendir("/sys/class");
  std::set<std::string> classes;
  check(names_in(dir, &classes) && classes.count("video4linux") && classes.count("media"),
        "readdir of /sys/class lists video4linux and media");
  closedir(dir);

  const int dev_fd = open("/dev", O_RDONLY | O_DIRECTORY);
  dir = fdopendir(dev_fd);
  bool found = false;
  dirent entry{};
  // readdir_r is deprecated, and still called by programs built long ago.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wdeprecated-declarations"
  for (dirent* e = nullptr; readdir_r(dir, &entry, &e) == 0 && e;)
    found |= std::strcmp(e->d_name, "video0") == 0;
#pragma GCC diagnostic pop
  closedir(dir);
  check(found, "fdopendir and readdir_r of /dev list video0");

  dirent** list = nullptr;
  const int n = scandir(
      "/dev", &list,
      [](const dirent* e) { return std::strncmp(e->d_name, "video", 5) == 0 ? 1 : 0; }, alphasort);
  check(n == 1 && std::strcmp(list[0]->d_name, "video0") == 0, "scandir of /dev with a filter");
  for (int i = 0; i < n; ++i) std::free(list[i]);
  std::free(list);
  const int v4l_count = scandirat(AT_FDCWD, "/sys/class/video4linux", &list, nullptr, alphasort);
  bool video0 = false;
  for (int i = 0; i < v4l_count; ++i) {
    video0 |= std::strcmp(list[i]->d_name, "video0") == 0;
    std::free(list[i]);
  }
  std::free(list);
  check(video0, "scandirat of the fake /sys/class/video4linux");

  glob_t found_nodes{};
  check(glob("/dev/video*", 0, nullptr, &found_nodes) == 0 && found_nodes.gl_pathc == 1 &&
            std::strcmp(found_nodes.gl_pathv[0], "/dev/video0") == 0,
        "glob /dev/video*");
  globfree(&found_nodes);

  // libudev's chase: "/" then "sys", "class", "video4linux", each relative to the last.
  const int root = open("/", O_PATH | O_DIRECTORY);
  const int sys = openat(root, "sys", O_PATH | O_NOFOLLOW);
  const int sys_class = openat(sys, "class", O_PATH | O_NOFOLLOW);
  const int v4l = openat(sys_class, "video4linux", O_PATH | O_NOFOLLOW);
  check(v4l >= 0, "openat(/sys/class fd, \"video4linux\") steps into the fake tree");
  char link[PATH_MAX] = {};
  const std::string self = "/proc/self/fd/" + std::to_string(v4l);
  const ssize_t length = readlink(self.c_str(), link, sizeof link - 1);
  check(length > 0 && std::string(link, static_cast<size_t>(length)) == "/sys/class/video4linux",
        "/proc/self/fd of a fake sysfs folder reads under /sys");
  struct statfs fs {};
  check(fstatfs(v4l, &fs) == 0 && fs.f_type == SYSFS_MAGIC, "fstatfs in the fake sysfs is sysfs");
  check(statfs("/sys/class/video4linux", &fs) == 0 && fs.f_type == SYSFS_MAGIC, "statfs too");
  struct stat st {};
  check(fstatat(sys_class, "video4linux", &st, 0) == 0 && S_ISDIR(st.st_mode),
        "fstatat relative to /sys/class");
  for (int fd : {v4l, sys_class, sys, root}) close(fd);
  char subsystem[PATH_MAX] = {};
  const ssize_t sub_length =
      readlink("/sys/class/video4linux/video0/subsystem", subsystem, sizeof subsystem - 1);
  check(sub_length > 0 && std::strstr(subsystem, "video4linux") != nullptr,
        "the video node's subsystem link");
  errno = 0;
  char label[64];
  check(lgetxattr("/dev/video0", "security.selinux", label, sizeof label) == -1 && errno == ENODATA,
        "a virtual node has no extended attributes");

  // The udev database entry GStreamer's device monitor reads.
  std::FILE* db = std::fopen("/run/udev/data/c81:0", "r");
  char line[256];
  bool v4l2 = false;
  while (db && std::fgets(line, sizeof line, db))
    v4l2 |= std::strcmp(line, "E:ID_V4L_VERSION=2\n") == 0;
  if (db) std::fclose(db);
  check(v4l2, "the udev database says the node is V4L2");
}

}  // namespace

int main() {
  check_listings();
  check_media_node();
  // syscall() directly, as libv4l2 and libcamera call it.
  const int fd = static_cast<int>(syscall(SYS_openat, AT_FDCWD, "/dev/video0", O_RDWR));
  check(fd >= 0, "syscall(SYS_openat) opens /dev/video0");
  if (fd < 0) return failures;
  v4l2_capability cap{};
  check(syscall(SYS_ioctl, fd, VIDIOC_QUERYCAP, &cap) == 0 && cap.driver[0],
        "syscall(SYS_ioctl) QUERYCAP");
  errno = 0;
  check(ioctl(fd, VIDIOC_QUERYCAP, reinterpret_cast<void*>(16)) == -1 && errno == EFAULT,
        "bad pointer is EFAULT");
  errno = 0;
  check(ioctl(fd, _IOR('V', 250, int), reinterpret_cast<void*>(16)) == -1 && errno == ENOTTY,
        "unknown ioctl is ENOTTY before the pointer is looked at");
  // ustreamer and motion pass the request as an int: VIDIOC_QUERYCAP (0x80685600) then
  // arrives sign-extended to 64 bits, and the kernel looks at its low 32 bits only.
  const unsigned long sign_extended = static_cast<unsigned long>(static_cast<int>(VIDIOC_QUERYCAP));
  check(sign_extended != VIDIOC_QUERYCAP, "the request is sign-extended on this host");
  v4l2_capability as_int{};
  check(ioctl(fd, sign_extended, &as_int) == 0 && as_int.driver[0], "ioctl with an int request");
  as_int = {};
  check(syscall(SYS_ioctl, fd, sign_extended, &as_int) == 0 && as_int.driver[0],
        "syscall(SYS_ioctl) with an int request");

  // The dup family: more names for one open file, which lives until the last is closed.
  const int d1 = dup(fd);
  check(d1 >= 0 && querycap(d1), "dup");
  check(close(fd) == 0, "close the original");
  check(querycap(d1), "the file outlives the closed original");
  const int d2 = fcntl(d1, F_DUPFD_CLOEXEC, 100);
  check(d2 >= 100 && querycap(d2), "fcntl(F_DUPFD_CLOEXEC)");
  check(dup2(d1, 200) == 200 && querycap(200), "dup2");
  check(dup3(d1, 201, O_CLOEXEC) == 201 && querycap(201), "dup3");
  const int d3 = static_cast<int>(syscall(SYS_dup, d1));
  check(d3 >= 0 && querycap(d3), "syscall(SYS_dup)");
  close(d3);
  close(d2);
  close(200);
  syscall(SYS_close, 201);

  // No read() I/O on this device; a read must not touch the readiness signal.
  char byte[8];
  errno = 0;
  check(read(d1, byte, sizeof byte) == -1 && errno == EINVAL, "read is EINVAL");
  errno = 0;
  check(syscall(SYS_read, d1, byte, sizeof byte) == -1 && errno == EINVAL,
        "syscall(SYS_read) is EINVAL");

  // The stat family reports a character device 81:0.
  struct stat st {};
  check(fstat(d1, &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) == 81, "fstat");
  check(stat("/dev/video0", &st) == 0 && S_ISCHR(st.st_mode) && minor(st.st_rdev) == 0, "stat");
  check(syscall(SYS_newfstatat, AT_FDCWD, "/dev/video0", &st, 0) == 0 && S_ISCHR(st.st_mode),
        "syscall(SYS_newfstatat)");
  struct statx sx {};
  check(statx(AT_FDCWD, "/dev/video0", 0, STATX_BASIC_STATS, &sx) == 0 && S_ISCHR(sx.stx_mode) &&
            sx.stx_rdev_major == 81,
        "statx");
  // glibc's old stat entry points, which programs built before glibc 2.33 (fswebcam)
  // call; the headers no longer declare them.
  using XStat = int (*)(int, const char*, struct stat*);
  using FXStat = int (*)(int, int, struct stat*);
  using FXStatAt = int (*)(int, int, const char*, struct stat*, int);
  for (const char* name : {"__xstat", "__xstat64", "__lxstat", "__lxstat64"}) {
    auto fn = reinterpret_cast<XStat>(dlsym(RTLD_DEFAULT, name));
    st = {};
    check(fn && fn(1, "/dev/video0", &st) == 0 && S_ISCHR(st.st_mode) && major(st.st_rdev) == 81,
          name);
  }
  for (const char* name : {"__fxstat", "__fxstat64"}) {
    auto fn = reinterpret_cast<FXStat>(dlsym(RTLD_DEFAULT, name));
    st = {};
    check(fn && fn(1, d1, &st) == 0 && major(st.st_rdev) == 81, name);
  }
  for (const char* name : {"__fxstatat", "__fxstatat64"}) {
    auto fn = reinterpret_cast<FXStatAt>(dlsym(RTLD_DEFAULT, name));
    st = {};
    check(fn && fn(1, AT_FDCWD, "/dev/video0", &st, 0) == 0 && major(st.st_rdev) == 81, name);
  }
  check(access("/dev/video0", R_OK | W_OK) == 0, "access");
  char resolved[PATH_MAX];
  check(realpath("/dev/video0", resolved) && std::string(resolved) == "/dev/video0",
        "realpath of the node");
  check(realpath("/sys/class/video4linux/video0", resolved) &&
            std::strncmp(resolved, "/sys/", 5) == 0,
        "realpath in the fake sysfs stays under /sys");
  errno = 0;
  check(stat("/dev/video7", &st) == -1 && errno == ENOENT,
        "a node beyond the count does not exist");

  // Stream on the dup'ed fd: mmap through syscall(), wait with ppoll, pselect and
  // select, and a blocking DQBUF.
  v4l2_format format{};
  format.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  format.fmt.pix.pixelformat = V4L2_PIX_FMT_GREY;
  format.fmt.pix.width = 160;
  format.fmt.pix.height = 120;
  check(ioctl(d1, VIDIOC_S_FMT, &format) == 0, "S_FMT");
  v4l2_requestbuffers request{};
  request.count = 2;
  request.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  request.memory = V4L2_MEMORY_MMAP;
  check(ioctl(d1, VIDIOC_REQBUFS, &request) == 0 && request.count >= 2, "REQBUFS");
  void* mapped[2] = {};
  size_t lengths[2] = {};
  for (unsigned i = 0; i < 2; ++i) {
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    buffer.index = i;
    check(ioctl(d1, VIDIOC_QUERYBUF, &buffer) == 0, "QUERYBUF");
    lengths[i] = buffer.length;
    mapped[i] =
        reinterpret_cast<void*>(syscall(SYS_mmap, nullptr, buffer.length, PROT_READ, MAP_SHARED, d1,
                                        static_cast<long>(buffer.m.offset)));
    check(mapped[i] != MAP_FAILED, "syscall(SYS_mmap)");
    check(ioctl(d1, VIDIOC_QBUF, &buffer) == 0, "QBUF");
  }
  int type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
  check(ioctl(d1, VIDIOC_STREAMON, &type) == 0, "STREAMON");
  pollfd p{d1, POLLIN, 0};
  // Generous: the first frame waits for the renderer, on a machine that may be loaded.
  const timespec wait_limit{10, 0};
  check(ppoll(&p, 1, &wait_limit, nullptr) == 1 && (p.revents & POLLIN),
        "ppoll sees a done buffer");
  fd_set readable;
  FD_ZERO(&readable);
  FD_SET(d1, &readable);
  check(pselect(d1 + 1, &readable, nullptr, nullptr, &wait_limit, nullptr) == 1 &&
            FD_ISSET(d1, &readable),
        "pselect");
  FD_ZERO(&readable);
  FD_SET(d1, &readable);
  timeval wait_limit_tv{10, 0};
  check(select(d1 + 1, &readable, nullptr, nullptr, &wait_limit_tv) == 1, "select");
  for (int frame = 0; frame < 4; ++frame) {
    // The fd is blocking: DQBUF waits for the next frame.
    v4l2_buffer buffer{};
    buffer.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    buffer.memory = V4L2_MEMORY_MMAP;
    check(ioctl(d1, VIDIOC_DQBUF, &buffer) == 0 && buffer.bytesused == format.fmt.pix.sizeimage,
          "blocking DQBUF");
    if (buffer.index < 2 && mapped[buffer.index] != MAP_FAILED) {
      const auto* pixels = static_cast<const unsigned char*>(mapped[buffer.index]);
      unsigned long sum = 0;
      for (size_t i = 0; i < buffer.bytesused; ++i) sum += pixels[i];
      check(sum > 0, "the mapped frame has an image");
    }
    check(ioctl(d1, VIDIOC_QBUF, &buffer) == 0, "requeue");
  }
  check(ioctl(d1, VIDIOC_STREAMOFF, &type) == 0, "STREAMOFF");
  for (unsigned i = 0; i < 2; ++i)
    if (mapped[i] != MAP_FAILED)
      check(syscall(SYS_munmap, mapped[i], lengths[i]) == 0, "syscall(SYS_munmap)");
  request.count = 0;
  check(ioctl(d1, VIDIOC_REQBUFS, &request) == 0, "REQBUFS 0 frees the buffers once unmapped");
  check(close(d1) == 0, "close");
  errno = 0;
  check(ioctl(d1, VIDIOC_QUERYCAP, &cap) == -1 && errno == EBADF, "a closed fd is EBADF");
  if (failures == 0) std::printf("all entry points ok\n");
  return failures;
}
