// VirtualMediaDevice: the uvcvideo-like media graph and the media controller ioctls,
// after drivers/media/mc/mc-device.c and mc-entity.c (Linux 6.1).
#include "mock_device/v4l2/virtual_media_device.h"

#include <linux/videodev2.h>

#include <algorithm>
#include <cerrno>
#include <cstddef>
#include <cstring>

#include "mock_device/v4l2/fake_sysfs.h"
#include "mock_device/v4l2/virtual_v4l2_device.h"

namespace camlab::mock {

namespace {

// The kernel's graph object types (media_gobj_type): the top byte of every object id.
constexpr uint32_t kGraphEntity = 0;
constexpr uint32_t kGraphPad = 1;
constexpr uint32_t kGraphLink = 2;
constexpr uint32_t kGraphInterface = 3;

// The layouts a transport copies (the sizes user_buffers() documents).
static_assert(sizeof(media_v2_entity) == 96 && sizeof(media_v2_interface) == 112);
static_assert(sizeof(media_v2_pad) == 32 && sizeof(media_v2_link) == 40);
static_assert(sizeof(media_pad_desc) == 20 && sizeof(media_link_desc) == 52);
static_assert(sizeof(void*) == sizeof(uint64_t),
              "ENUM_LINKS' pointers are marshalled as 64-bit values");

template <size_t N>
void copy_name(char (&dst)[N], const std::string& src) {
  std::memset(dst, 0, N);
  std::memcpy(dst, src.data(), std::min(N - 1, src.size()));
}

uint64_t read_pointer(const void* arg, size_t offset) {
  uint64_t value;
  std::memcpy(&value, static_cast<const uint8_t*>(arg) + offset, sizeof value);
  return value;
}

void write_pointer(void* arg, size_t offset, uint64_t value) {
  std::memcpy(static_cast<uint8_t*>(arg) + offset, &value, sizeof value);
}

}  // namespace

VirtualMediaDevice::VirtualMediaDevice(VirtualMediaOptions options) : options_(std::move(options)) {
  if (options_.model.empty())
    options_.model = "camlab virtual camera " + std::to_string(options_.index);
  // The video entity is named after the camera, as uvcvideo names it after the card;
  // names must be unique in their first 31 characters (ENUM_ENTITIES' name is 32 bytes).
  std::string video_name = options_.model.substr(0, 31);
  if (video_name == "Camera 1" || video_name == "Processing 2") video_name += " video";

  // Creation order as in uvc_driver.c: the video node registers first, then the
  // chain's units; each pad link also takes an id for its (hidden) backlink.
  const uint32_t video = add_entity(video_name, MEDIA_ENT_F_IO_V4L, MEDIA_ENT_FL_DEFAULT);
  entities_.back().major = options_.video_major;
  entities_.back().minor = options_.video_minor;
  const uint32_t video_sink = add_pad(video, 0, MEDIA_PAD_FL_SINK);
  const uint32_t processing = add_entity("Processing 2", MEDIA_ENT_F_PROC_VIDEO_PIXEL_FORMATTER, 0);
  const uint32_t processing_sink = add_pad(processing, 0, MEDIA_PAD_FL_SINK);
  const uint32_t processing_source = add_pad(processing, 1, MEDIA_PAD_FL_SOURCE);
  const uint32_t camera = add_entity("Camera 1", MEDIA_ENT_F_CAM_SENSOR, 0);
  const uint32_t camera_source = add_pad(camera, 0, MEDIA_PAD_FL_SOURCE);
  add_data_link(camera_source, processing_sink);
  add_data_link(processing_source, video_sink);

  const uint32_t interface = next_id(kGraphInterface);
  interfaces_.push_back(
      {interface, MEDIA_INTF_T_V4L_VIDEO, options_.video_major, options_.video_minor});
  links_.push_back({next_id(kGraphLink), interface, video,
                    MEDIA_LNK_FL_INTERFACE_LINK | MEDIA_LNK_FL_ENABLED | MEDIA_LNK_FL_IMMUTABLE});
}

uint32_t VirtualMediaDevice::next_id(uint32_t type) {
  return (type << 24) | (++last_id_ & 0xffffff);
}

uint32_t VirtualMediaDevice::add_entity(const std::string& name, uint32_t function,
                                        uint32_t flags) {
  const uint32_t id = next_id(kGraphEntity);
  entities_.push_back({id, name, function, flags});
  return id;
}

uint32_t VirtualMediaDevice::add_pad(uint32_t entity_id, uint32_t index, uint32_t flags) {
  const uint32_t id = next_id(kGraphPad);
  pads_.push_back({id, entity_id, index, flags});
  return id;
}

void VirtualMediaDevice::add_data_link(uint32_t source_pad, uint32_t sink_pad) {
  links_.push_back(
      {next_id(kGraphLink), source_pad, sink_pad, MEDIA_LNK_FL_ENABLED | MEDIA_LNK_FL_IMMUTABLE});
  ++last_id_;  // the backlink's id: the kernel allocates one, and never shows it
}

int VirtualMediaDevice::open_file(bool nonblocking) {
  std::lock_guard lock(mutex_);
  if (unplugged_) return -ENODEV;
  const int id = next_file_++;
  files_[id] = nonblocking;
  return id;
}

void VirtualMediaDevice::close_file(int file) {
  std::lock_guard lock(mutex_);
  files_.erase(file);
  dead_files_.erase(file);
}

void VirtualMediaDevice::unplug() {
  std::lock_guard lock(mutex_);
  unplugged_ = true;
}

void VirtualMediaDevice::replug() {
  std::lock_guard lock(mutex_);
  if (!unplugged_) return;
  for (const auto& [file, nonblocking] : files_) dead_files_.insert(file);
  unplugged_ = false;
}

bool VirtualMediaDevice::is_supported_ioctl(unsigned long request) {
  switch (request) {
    case MEDIA_IOC_DEVICE_INFO:
    case MEDIA_IOC_ENUM_ENTITIES:
    case MEDIA_IOC_ENUM_LINKS:
    case MEDIA_IOC_SETUP_LINK:
    case MEDIA_IOC_G_TOPOLOGY:
      return true;
    default:
      return false;
  }
}

int VirtualMediaDevice::ioctl(int file, unsigned long request, void* arg) {
  std::lock_guard lock(mutex_);
  // An unregistered media node answers EIO (media_ioctl), not ENODEV.
  if (unplugged_ || dead_files_.contains(file)) return -EIO;
  if (files_.find(file) == files_.end()) return -EBADF;
  if (!is_supported_ioctl(request)) return -ENOTTY;
  if (arg == nullptr) return -EFAULT;
  switch (request) {
    case MEDIA_IOC_DEVICE_INFO:
      return device_info(static_cast<media_device_info*>(arg));
    case MEDIA_IOC_ENUM_ENTITIES:
      return enum_entities(static_cast<media_entity_desc*>(arg));
    case MEDIA_IOC_ENUM_LINKS:
      return enum_links(static_cast<media_links_enum*>(arg));
    case MEDIA_IOC_SETUP_LINK:
      return setup_link(static_cast<media_link_desc*>(arg));
    case MEDIA_IOC_G_TOPOLOGY:
      return topology(static_cast<media_v2_topology*>(arg));
    default:
      return -ENOTTY;
  }
}

const VirtualMediaDevice::Entity* VirtualMediaDevice::find_entity(uint32_t id_with_flag) const {
  // mc-device.c find_entity(): with MEDIA_ENT_ID_FLAG_NEXT, the first entity whose id is
  // above the given one (entities_ is in id order).
  const bool next = (id_with_flag & MEDIA_ENT_ID_FLAG_NEXT) != 0;
  const uint32_t id = id_with_flag & ~MEDIA_ENT_ID_FLAG_NEXT;
  for (const Entity& e : entities_)
    if ((!next && e.id == id) || (next && e.id > id)) return &e;
  return nullptr;
}

const VirtualMediaDevice::Pad* VirtualMediaDevice::find_pad(uint32_t entity_id,
                                                            uint32_t index) const {
  for (const Pad& p : pads_)
    if (p.entity_id == entity_id && p.index == index) return &p;
  return nullptr;
}

size_t VirtualMediaDevice::outbound_link_count(uint32_t entity_id) const {
  size_t count = 0;
  for (const Link& l : links_) {
    if ((l.flags & MEDIA_LNK_FL_LINK_TYPE) != MEDIA_LNK_FL_DATA_LINK) continue;
    for (const Pad& p : pads_) count += p.id == l.source_id && p.entity_id == entity_id;
  }
  return count;
}

int VirtualMediaDevice::device_info(media_device_info* info) const {
  std::memset(info, 0, sizeof *info);
  copy_name(info->driver, "uvcvideo");
  copy_name(info->model, options_.model);
  copy_name(info->bus_info, options_.bus_info);
  info->media_version = kMediaVersion;
  info->driver_version = kMediaVersion;
  info->hw_revision = 0x0100;  // the USB device's bcdDevice (fake_sysfs.h writes the same)
  return 0;
}

int VirtualMediaDevice::enum_entities(media_entity_desc* desc) const {
  const Entity* e = find_entity(desc->id);
  if (!e) return -EINVAL;
  std::memset(desc, 0, sizeof *desc);
  desc->id = e->id;
  copy_name(desc->name, e->name);
  desc->type = e->function;
  // mc-device.c's workaround for media-ctl <= 1.10: functions outside the old ranges
  // are reported as an unknown subdev (uvc's units) or an unknown device node.
  if (e->function < MEDIA_ENT_F_OLD_BASE || e->function > MEDIA_ENT_F_TUNER) {
    if (e->function != MEDIA_ENT_F_IO_V4L) desc->type = MEDIA_ENT_F_V4L2_SUBDEV_UNKNOWN;
  }
  desc->flags = e->flags;
  desc->pads = static_cast<uint16_t>(std::count_if(
      pads_.begin(), pads_.end(), [&](const Pad& p) { return p.entity_id == e->id; }));
  desc->links = static_cast<uint16_t>(outbound_link_count(e->id));
  desc->dev.major = e->major;
  desc->dev.minor = e->minor;
  return 0;
}

int VirtualMediaDevice::enum_links(media_links_enum* links) const {
  const Entity* e = find_entity(links->entity);
  if (!e) return -EINVAL;
  auto to_desc = [this](const Pad& pad) {
    media_pad_desc d{};
    d.entity = pad.entity_id;
    d.index = static_cast<uint16_t>(pad.index);
    d.flags = pad.flags;
    return d;
  };
  if (links->pads) {
    media_pad_desc* out = links->pads;
    for (uint32_t index = 0; const Pad* pad = find_pad(e->id, index); ++index)
      *out++ = to_desc(*pad);
  }
  if (links->links) {
    media_link_desc* out = links->links;
    for (const Link& l : links_) {
      if ((l.flags & MEDIA_LNK_FL_LINK_TYPE) != MEDIA_LNK_FL_DATA_LINK) continue;
      const auto source = std::find_if(pads_.begin(), pads_.end(),
                                       [&](const Pad& p) { return p.id == l.source_id; });
      const auto sink =
          std::find_if(pads_.begin(), pads_.end(), [&](const Pad& p) { return p.id == l.sink_id; });
      if (source == pads_.end() || sink == pads_.end() || source->entity_id != e->id)
        continue;  // backlinks too
      media_link_desc d{};
      d.source = to_desc(*source);
      d.sink = to_desc(*sink);
      d.flags = l.flags;
      *out++ = d;
    }
  }
  std::memset(links->reserved, 0, sizeof links->reserved);
  return 0;
}

int VirtualMediaDevice::setup_link(media_link_desc* desc) const {
  const Entity* source = find_entity(desc->source.entity);
  const Entity* sink = find_entity(desc->sink.entity);
  if (!source || !sink) return -EINVAL;
  const Pad* source_pad = find_pad(source->id, desc->source.index);
  const Pad* sink_pad = find_pad(sink->id, desc->sink.index);
  if (!source_pad || !sink_pad) return -EINVAL;
  const auto link = std::find_if(links_.begin(), links_.end(), [&](const Link& l) {
    return (l.flags & MEDIA_LNK_FL_LINK_TYPE) == MEDIA_LNK_FL_DATA_LINK &&
           l.source_id == source_pad->id && l.sink_id == sink_pad->id;
  });
  if (link == links_.end()) return -EINVAL;
  std::memset(desc->reserved, 0, sizeof desc->reserved);
  // __media_entity_setup_link(): only ENABLED may change, and not on an immutable link
  // (every link here is immutable, as uvcvideo's are).
  const uint32_t mutable_flags = MEDIA_LNK_FL_ENABLED;
  if ((link->flags & ~mutable_flags) != (desc->flags & ~mutable_flags)) return -EINVAL;
  if (link->flags & MEDIA_LNK_FL_IMMUTABLE) return link->flags == desc->flags ? 0 : -EINVAL;
  return 0;
}

int VirtualMediaDevice::topology(media_v2_topology* topology) const {
  // As media_device_get_topology(): every count is set to the device's, an array is
  // written when its pointer is set (ENOSPC when the client's count is too small, after
  // writing what fits), and the struct reaches the client only on success.
  media_v2_topology out = *topology;
  int result = 0;
  out.topology_version = last_id_;  // bumped by every graph object the device created

  auto* entities =
      reinterpret_cast<media_v2_entity*>(static_cast<uintptr_t>(topology->ptr_entities));
  for (size_t i = 0; i < entities_.size() && entities; ++i) {
    if (i >= topology->num_entities) {
      result = -ENOSPC;
      break;
    }
    media_v2_entity e{};
    e.id = entities_[i].id;
    copy_name(e.name, entities_[i].name);
    e.function = entities_[i].function;
    e.flags = entities_[i].flags;
    std::memcpy(&entities[i], &e, sizeof e);
  }
  out.num_entities = static_cast<uint32_t>(entities_.size());
  out.reserved1 = 0;

  auto* interfaces =
      reinterpret_cast<media_v2_interface*>(static_cast<uintptr_t>(topology->ptr_interfaces));
  for (size_t i = 0; i < interfaces_.size() && interfaces; ++i) {
    if (i >= topology->num_interfaces) {
      result = -ENOSPC;
      break;
    }
    media_v2_interface f{};
    f.id = interfaces_[i].id;
    f.intf_type = interfaces_[i].type;
    f.devnode.major = interfaces_[i].major;
    f.devnode.minor = interfaces_[i].minor;
    std::memcpy(&interfaces[i], &f, sizeof f);
  }
  out.num_interfaces = static_cast<uint32_t>(interfaces_.size());
  out.reserved2 = 0;

  auto* pads = reinterpret_cast<media_v2_pad*>(static_cast<uintptr_t>(topology->ptr_pads));
  for (size_t i = 0; i < pads_.size() && pads; ++i) {
    if (i >= topology->num_pads) {
      result = -ENOSPC;
      break;
    }
    media_v2_pad p{};
    p.id = pads_[i].id;
    p.entity_id = pads_[i].entity_id;
    p.flags = pads_[i].flags;
    p.index = pads_[i].index;
    std::memcpy(&pads[i], &p, sizeof p);
  }
  out.num_pads = static_cast<uint32_t>(pads_.size());
  out.reserved3 = 0;

  auto* links = reinterpret_cast<media_v2_link*>(static_cast<uintptr_t>(topology->ptr_links));
  for (size_t i = 0; i < links_.size() && links; ++i) {
    if (i >= topology->num_links) {
      result = -ENOSPC;
      break;
    }
    media_v2_link l{};
    l.id = links_[i].id;
    l.source_id = links_[i].source_id;
    l.sink_id = links_[i].sink_id;
    l.flags = links_[i].flags;
    std::memcpy(&links[i], &l, sizeof l);
  }
  out.num_links = static_cast<uint32_t>(links_.size());
  out.reserved4 = 0;

  if (result == 0) *topology = out;
  return result;
}

std::vector<UserBuffer> VirtualMediaDevice::user_buffers(unsigned long request,
                                                         const void* arg) const {
  std::vector<UserBuffer> buffers;
  if (arg == nullptr) return buffers;
  auto add = [&](size_t offset, size_t count, size_t element_size) {
    if (read_pointer(arg, offset) != 0 && count > 0)
      buffers.push_back({offset, count * element_size, false, true});
  };
  if (request == MEDIA_IOC_G_TOPOLOGY) {
    media_v2_topology t;
    std::memcpy(&t, arg, sizeof t);
    add(offsetof(media_v2_topology, ptr_entities),
        std::min<size_t>(t.num_entities, entities_.size()), sizeof(media_v2_entity));
    add(offsetof(media_v2_topology, ptr_interfaces),
        std::min<size_t>(t.num_interfaces, interfaces_.size()), sizeof(media_v2_interface));
    add(offsetof(media_v2_topology, ptr_pads), std::min<size_t>(t.num_pads, pads_.size()),
        sizeof(media_v2_pad));
    add(offsetof(media_v2_topology, ptr_links), std::min<size_t>(t.num_links, links_.size()),
        sizeof(media_v2_link));
  } else if (request == MEDIA_IOC_ENUM_LINKS) {
    media_links_enum l;
    std::memcpy(&l, arg, sizeof l);
    const Entity* e = find_entity(l.entity);
    if (!e) return buffers;
    const size_t pad_count = static_cast<size_t>(std::count_if(
        pads_.begin(), pads_.end(), [&](const Pad& p) { return p.entity_id == e->id; }));
    add(offsetof(media_links_enum, pads), pad_count, sizeof(media_pad_desc));
    add(offsetof(media_links_enum, links), outbound_link_count(e->id), sizeof(media_link_desc));
  }
  return buffers;
}

int VirtualMediaDevice::ioctl_marshalled(int file, unsigned long request, void* arg,
                                         const CopyIn& copy_in, const CopyOut& copy_out) {
  const std::vector<UserBuffer> buffers = user_buffers(request, arg);
  std::vector<std::vector<uint8_t>> staged(buffers.size());
  std::vector<uint64_t> remote(buffers.size());
  for (size_t i = 0; i < buffers.size(); ++i) {
    remote[i] = read_pointer(arg, buffers[i].pointer_offset);
    staged[i].assign(buffers[i].size_bytes, 0);
    if (buffers[i].copy_in)
      if (int error = copy_in(remote[i], staged[i].data(), staged[i].size()); error < 0)
        return error;
  }
  for (size_t i = 0; i < buffers.size(); ++i)
    write_pointer(arg, buffers[i].pointer_offset, reinterpret_cast<uintptr_t>(staged[i].data()));
  int result = ioctl(file, request, arg);
  for (size_t i = 0; i < buffers.size(); ++i)
    write_pointer(arg, buffers[i].pointer_offset, remote[i]);
  // Partial arrays reach the client on ENOSPC too, as the kernel's copy_to_user does.
  if (result != 0 && result != -ENOSPC) return result;
  for (size_t i = 0; i < buffers.size(); ++i) {
    if (!buffers[i].copy_out) continue;
    if (int error = copy_out(remote[i], staged[i].data(), staged[i].size()); error < 0)
      return error;
  }
  return result;
}

std::shared_ptr<VirtualMediaDevice> make_media_device_for(VirtualV4l2Device& video) {
  const int file = video.open_file(true);
  if (file < 0) return nullptr;
  v4l2_capability cap{};
  const int error = video.ioctl(file, VIDIOC_QUERYCAP, &cap);
  video.close_file(file);
  if (error < 0) return nullptr;
  VirtualMediaOptions options;
  options.index = video.index();
  options.model = reinterpret_cast<const char*>(cap.card);
  options.bus_info = reinterpret_cast<const char*>(cap.bus_info);
  options.video_major = kVideoMajor;
  options.video_minor = static_cast<uint32_t>(video.index());
  return std::make_shared<VirtualMediaDevice>(std::move(options));
}

}  // namespace camlab::mock
