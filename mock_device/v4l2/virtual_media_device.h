// The media controller node (/dev/mediaN) of virtual camera N, shaped like the one the
// uvcvideo driver registers, so that media-controller clients (libcamera's MediaDevice
// and its UVC pipeline handler, media-ctl, `v4l2-compliance -m`) accept the virtual
// camera as a USB webcam:
//
//   "Camera 1" (CAM_SENSOR) [0 src] -> [0 sink] "Processing 2" (PROC_VIDEO_PIXEL_FORMATTER)
//   [1 src] -> [0 sink] <camera name> (IO_V4L, flags DEFAULT) <- interface V4L_VIDEO 81:N
//
// Every link is ENABLED|IMMUTABLE, as uvcvideo's are. Object ids follow the kernel's
// scheme (one counter for all graph objects, the object type in bits 24..31), so the
// numbers a client sees look like a real device's.
//
// The file interface is the same as VirtualV4l2Device's: open_file / close_file /
// ioctl(file, request, arg) returning 0 or -errno with the kernel's semantics
// (drivers/media/mc/mc-device.c). `arg` points to the ioctl's struct in the caller's
// memory, and the pointers inside it (G_TOPOLOGY's arrays, ENUM_LINKS' pads and links)
// are dereferenced directly. A transport that serves another process must therefore
// marshal those arrays: user_buffers() says where they are and how big, and
// ioctl_marshalled() does the whole dance given two copy functions.
//
// Thread-safe: every entry point takes the device mutex.
#pragma once

#include <linux/media.h>

#include <cstddef>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace camlab::mock {

struct VirtualMediaOptions {
  int index = 0;              // /dev/mediaN
  std::string model;          // MEDIA_IOC_DEVICE_INFO model (the camera's name)
  std::string bus_info;       // must equal the video node's VIDIOC_QUERYCAP bus_info
  uint32_t video_major = 81;  // the video node the default entity exposes
  uint32_t video_minor = 0;
};

// An array an ioctl's struct points to, in the client's memory.
struct UserBuffer {
  size_t pointer_offset;  // offset of the pointer field (a __u64 or a native pointer) in the struct
  size_t size_bytes;      // bytes the device reads or writes there (0: nothing to copy)
  bool copy_in;           // the device reads the client's array (never, for the media ioctls)
  bool copy_out;          // the device writes the client's array
};

class VirtualMediaDevice {
 public:
  explicit VirtualMediaDevice(VirtualMediaOptions options);

  int open_file(bool nonblocking);
  void close_file(int file);

  // Whether the media node implements an ioctl (others are ENOTTY, checked before the
  // argument, as the kernel does): DEVICE_INFO, ENUM_ENTITIES, ENUM_LINKS, SETUP_LINK,
  // G_TOPOLOGY. MEDIA_IOC_REQUEST_ALLOC is ENOTTY, as on uvcvideo (no request API).
  static bool is_supported_ioctl(unsigned long request);

  // A media ioctl on an open file: 0 or -errno. `arg` is the ioctl's struct; its
  // embedded pointers are written through directly (see ioctl_marshalled()).
  int ioctl(int file, unsigned long request, void* arg);

  // The arrays `request`'s struct `arg` points to, as the device would access them for
  // this very struct (sizes are what the device writes, never more than the client's
  // counts allow): for a transport that must copy them across processes.
  //   MEDIA_IOC_G_TOPOLOGY, each array only when its pointer is non-zero; all copy_out:
  //     ptr_entities   min(num_entities, E) entries of media_v2_entity (96 bytes)
  //     ptr_interfaces min(num_interfaces, I) entries of media_v2_interface (112 bytes)
  //     ptr_pads       min(num_pads, P) entries of media_v2_pad (32 bytes)
  //     ptr_links      min(num_links, L) entries of media_v2_link (40 bytes)
  //   MEDIA_IOC_ENUM_LINKS, each only when its pointer is non-null; copy_out:
  //     pads  the entity's pad count of media_pad_desc (20 bytes)
  //     links the entity's outbound data links of media_link_desc (52 bytes)
  //   others: none.
  std::vector<UserBuffer> user_buffers(unsigned long request, const void* arg) const;

  // ioctl() for a struct whose embedded pointers are addresses in another address space
  // (or untrusted ones in this one). `arg` is the caller's local copy of the struct; the
  // arrays are staged in local buffers around the call and written back with
  // `copy_out(remote_address, local, bytes)` (0 or -EFAULT); `copy_in` likewise reads.
  // On return the pointer fields of `arg` hold the client's values again.
  using CopyIn = std::function<int(uint64_t remote_address, void* local, size_t bytes)>;
  using CopyOut = std::function<int(uint64_t remote_address, const void* local, size_t bytes)>;
  int ioctl_marshalled(int file, unsigned long request, void* arg, const CopyIn& copy_in,
                       const CopyOut& copy_out);

  // From now on every call fails with ENODEV (the camera was unplugged).
  void unplug();
  // The camera is plugged in again: new opens work; files opened before stay dead.
  void replug();

  int index() const { return options_.index; }

  // The graph, for tests and for clients that want to check what they enumerated.
  struct Entity {
    uint32_t id;
    std::string name;
    uint32_t function;
    uint32_t flags;
    uint32_t major = 0;  // the device node of its interface (0: none)
    uint32_t minor = 0;
  };
  struct Pad {
    uint32_t id;
    uint32_t entity_id;
    uint32_t index;
    uint32_t flags;
  };
  struct Link {
    uint32_t id;
    uint32_t source_id;  // a pad id, or an interface id for an interface link
    uint32_t sink_id;    // a pad id, or an entity id for an interface link
    uint32_t flags;
  };
  struct Interface {
    uint32_t id;
    uint32_t type;
    uint32_t major;
    uint32_t minor;
  };
  const std::vector<Entity>& entities() const { return entities_; }
  const std::vector<Pad>& pads() const { return pads_; }
  const std::vector<Link>& links() const { return links_; }
  const std::vector<Interface>& interfaces() const { return interfaces_; }

  // The media API version reported by DEVICE_INFO (a kernel version, 6.1.0, as the
  // video node's VIDIOC_QUERYCAP version): >= 4.19, so entities carry flags and pads
  // carry their index.
  static constexpr uint32_t kMediaVersion = (6u << 16) | (1u << 8);

 private:
  uint32_t next_id(uint32_t type);
  uint32_t add_entity(const std::string& name, uint32_t function, uint32_t flags);
  uint32_t add_pad(uint32_t entity_id, uint32_t index, uint32_t flags);
  void add_data_link(uint32_t source_pad, uint32_t sink_pad);
  const Entity* find_entity(uint32_t id_with_flag) const;
  const Pad* find_pad(uint32_t entity_id, uint32_t index) const;
  size_t outbound_link_count(uint32_t entity_id) const;

  int device_info(media_device_info* info) const;
  int enum_entities(media_entity_desc* desc) const;
  int enum_links(media_links_enum* links) const;
  int setup_link(media_link_desc* link) const;
  int topology(media_v2_topology* topology) const;

  VirtualMediaOptions options_;
  uint32_t last_id_ = 0;
  std::vector<Entity> entities_;
  std::vector<Pad> pads_;
  std::vector<Link> links_;  // data links first, then interface links (kernel order)
  std::vector<Interface> interfaces_;

  mutable std::mutex mutex_;
  std::map<int, bool> files_;  // open file -> nonblocking
  int next_file_ = 1;
  bool unplugged_ = false;
  std::set<int> dead_files_;  // opened before an unplug that a replug ended
};

class VirtualV4l2Device;

// The media node of a virtual camera: index, model and bus_info taken from the video
// node's VIDIOC_QUERYCAP (card, bus_info), so the two agree as on a real uvcvideo
// device; the default entity exposes /dev/video<index> (81:index). Null if the video
// device cannot be queried (unplugged).
std::shared_ptr<VirtualMediaDevice> make_media_device_for(VirtualV4l2Device& video);

}  // namespace camlab::mock
