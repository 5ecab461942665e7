// The virtual camera's media controller node: the graph is consistent (every link's
// pads exist, ids are unique and match between the v1 and v2 APIs), the ioctls follow
// mc-device.c (G_TOPOLOGY's count protocol and ENOSPC, ENUM_ENTITIES' NEXT flag,
// immutable links), and the arrays a transport must marshal are described exactly.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <linux/media.h>
#include <sys/ioctl.h>
#include <unistd.h>

#include <cstring>
#include <map>
#include <set>
#include <vector>

#include "mock_device/v4l2/virtual_media_device.h"
#include "mock_device/v4l2/virtual_v4l2_io.h"
#include "test_specs.h"

namespace camlab::mock {
namespace {

class MediaDevice : public ::testing::Test {
 protected:
  MediaDevice()
      : media({.index = 0,
               .model = "test pinhole",
               .bus_info = "platform:camlab-vcam-0",
               .video_major = 81,
               .video_minor = 0}) {
    file = media.open_file(false);
  }
  ~MediaDevice() override { media.close_file(file); }

  // Both G_TOPOLOGY passes, as libcamera's MediaDevice::populate() makes them.
  void read_topology() {
    media_v2_topology counts{};
    ASSERT_EQ(media.ioctl(file, MEDIA_IOC_G_TOPOLOGY, &counts), 0);
    entities.resize(counts.num_entities);
    interfaces.resize(counts.num_interfaces);
    pads.resize(counts.num_pads);
    links.resize(counts.num_links);
    topology = counts;
    topology.ptr_entities = reinterpret_cast<uintptr_t>(entities.data());
    topology.ptr_interfaces = reinterpret_cast<uintptr_t>(interfaces.data());
    topology.ptr_pads = reinterpret_cast<uintptr_t>(pads.data());
    topology.ptr_links = reinterpret_cast<uintptr_t>(links.data());
    ASSERT_EQ(media.ioctl(file, MEDIA_IOC_G_TOPOLOGY, &topology), 0);
    EXPECT_EQ(topology.topology_version, counts.topology_version);
  }

  VirtualMediaDevice media;
  int file;
  media_v2_topology topology{};
  std::vector<media_v2_entity> entities;
  std::vector<media_v2_interface> interfaces;
  std::vector<media_v2_pad> pads;
  std::vector<media_v2_link> links;
};

TEST_F(MediaDevice, DeviceInfoIsUvcvideoWithAKernelMediaVersion) {
  media_device_info info;
  std::memset(&info, 0xff, sizeof info);
  ASSERT_EQ(media.ioctl(file, MEDIA_IOC_DEVICE_INFO, &info), 0);
  EXPECT_STREQ(info.driver, "uvcvideo");  // what libcamera's UVC pipeline handler matches
  EXPECT_STREQ(info.model, "test pinhole");
  EXPECT_STREQ(info.bus_info, "platform:camlab-vcam-0");
  EXPECT_GE(info.media_version, (4u << 16) | (19u << 8));  // entity flags, pad indices
  EXPECT_EQ(info.driver_version, info.media_version);
  for (uint32_t word : info.reserved) EXPECT_EQ(word, 0u);
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_DEVICE_INFO, nullptr), -EFAULT);
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_REQUEST_ALLOC, nullptr),
            -ENOTTY);  // checked before the argument
  EXPECT_EQ(media.ioctl(file + 100, MEDIA_IOC_DEVICE_INFO, &info), -EBADF);
}

TEST_F(MediaDevice, TopologyIsAConsistentUvcGraph) {
  read_topology();
  ASSERT_EQ(entities.size(), 3u);
  ASSERT_EQ(interfaces.size(), 1u);
  ASSERT_EQ(pads.size(), 4u);
  ASSERT_EQ(links.size(), 3u);  // two data links, one interface link

  std::set<uint32_t> ids;
  std::map<uint32_t, const media_v2_entity*> entity_by_id;
  std::map<uint32_t, const media_v2_pad*> pad_by_id;
  for (const auto& e : entities) {
    EXPECT_TRUE(ids.insert(e.id).second) << "duplicate id " << e.id;
    EXPECT_EQ(e.id >> 24, 0u) << "entity ids carry object type 0";
    entity_by_id[e.id] = &e;
  }
  for (const auto& p : pads) {
    EXPECT_TRUE(ids.insert(p.id).second);
    EXPECT_EQ(p.id >> 24, 1u);
    EXPECT_EQ(entity_by_id.count(p.entity_id), 1u) << "pad " << p.id << " names a missing entity";
    EXPECT_NE(p.flags & (MEDIA_PAD_FL_SINK | MEDIA_PAD_FL_SOURCE), 0u);
    pad_by_id[p.id] = &p;
  }
  const media_v2_entity* video = nullptr;
  for (const auto& e : entities)
    if (e.flags & MEDIA_ENT_FL_DEFAULT) video = &e;
  ASSERT_NE(video, nullptr) << "libcamera's UVC handler opens the DEFAULT entity";
  EXPECT_EQ(video->function, static_cast<uint32_t>(MEDIA_ENT_F_IO_V4L));
  EXPECT_STREQ(video->name, "test pinhole");

  int interface_links = 0;
  for (const auto& l : links) {
    EXPECT_TRUE(ids.insert(l.id).second);
    EXPECT_EQ(l.id >> 24, 2u);
    EXPECT_EQ(l.flags & (MEDIA_LNK_FL_ENABLED | MEDIA_LNK_FL_IMMUTABLE),
              static_cast<uint32_t>(MEDIA_LNK_FL_ENABLED | MEDIA_LNK_FL_IMMUTABLE));
    if ((l.flags & MEDIA_LNK_FL_LINK_TYPE) == MEDIA_LNK_FL_INTERFACE_LINK) {
      ++interface_links;
      EXPECT_EQ(l.source_id, interfaces[0].id);
      EXPECT_EQ(l.sink_id, video->id) << "the video node's interface links to the default entity";
      continue;
    }
    ASSERT_EQ(pad_by_id.count(l.source_id), 1u) << "link " << l.id << " from a missing pad";
    ASSERT_EQ(pad_by_id.count(l.sink_id), 1u) << "link " << l.id << " to a missing pad";
    EXPECT_NE(pad_by_id[l.source_id]->flags & MEDIA_PAD_FL_SOURCE, 0u);
    EXPECT_NE(pad_by_id[l.sink_id]->flags & MEDIA_PAD_FL_SINK, 0u);
    EXPECT_NE(pad_by_id[l.source_id]->entity_id, pad_by_id[l.sink_id]->entity_id);
  }
  EXPECT_EQ(interface_links, 1);
  EXPECT_EQ(interfaces[0].intf_type, static_cast<uint32_t>(MEDIA_INTF_T_V4L_VIDEO));
  EXPECT_EQ(interfaces[0].devnode.major, 81u);
  EXPECT_EQ(interfaces[0].devnode.minor, 0u);
}

TEST_F(MediaDevice, TopologyCountsProtocolAndTooSmallArrays) {
  // Null pointers: only the counts come back (the first pass of every client).
  media_v2_topology t;
  std::memset(&t, 0xff, sizeof t);
  t.ptr_entities = t.ptr_interfaces = t.ptr_pads = t.ptr_links = 0;
  ASSERT_EQ(media.ioctl(file, MEDIA_IOC_G_TOPOLOGY, &t), 0);
  EXPECT_EQ(t.num_entities, 3u);
  EXPECT_EQ(t.num_pads, 4u);
  EXPECT_EQ(t.reserved1 | t.reserved2 | t.reserved3 | t.reserved4, 0u);
  EXPECT_NE(t.topology_version, ~0ull);

  // An array too small for the graph: ENOSPC, what fits is written, the struct is not.
  std::vector<media_v2_entity> two(2);
  std::memset(two.data(), 0xaa, two.size() * sizeof two[0]);
  media_v2_topology small{};
  small.num_entities = 2;
  small.ptr_entities = reinterpret_cast<uintptr_t>(two.data());
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_G_TOPOLOGY, &small), -ENOSPC);
  EXPECT_EQ(small.num_entities, 2u) << "the kernel copies the struct back only on success";
  EXPECT_EQ(two[0].id, 1u);
  EXPECT_NE(two[1].id, 0xaaaaaaaau);

  // The transport description agrees: the bytes the device writes for this struct.
  auto buffers = media.user_buffers(MEDIA_IOC_G_TOPOLOGY, &small);
  ASSERT_EQ(buffers.size(), 1u);
  EXPECT_EQ(buffers[0].pointer_offset, offsetof(media_v2_topology, ptr_entities));
  EXPECT_EQ(buffers[0].size_bytes, 2 * sizeof(media_v2_entity));
  EXPECT_TRUE(buffers[0].copy_out);
  EXPECT_FALSE(buffers[0].copy_in);
  media_v2_topology large{};
  large.num_links = 100;
  large.ptr_links = 4096;  // never dereferenced by user_buffers
  buffers = media.user_buffers(MEDIA_IOC_G_TOPOLOGY, &large);
  ASSERT_EQ(buffers.size(), 1u);
  EXPECT_EQ(buffers[0].size_bytes, 3 * sizeof(media_v2_link))
      << "never more than the device writes";
}

TEST_F(MediaDevice, EnumEntitiesAndLinksAgreeWithTheTopology) {
  read_topology();
  std::map<uint32_t, media_entity_desc> by_id;
  media_entity_desc desc{};
  desc.id = 0;
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_ENUM_ENTITIES, &desc), -EINVAL)
      << "entity id 0 never exists";
  uint32_t last = 0;
  for (;;) {
    std::memset(&desc, 0xff, sizeof desc);
    desc.id = last | MEDIA_ENT_ID_FLAG_NEXT;
    if (media.ioctl(file, MEDIA_IOC_ENUM_ENTITIES, &desc) != 0) break;
    EXPECT_GT(desc.id, last);
    last = desc.id;
    EXPECT_EQ(desc.revision | desc.group_id, 0u);
    by_id[desc.id] = desc;
  }
  ASSERT_EQ(by_id.size(), entities.size());
  size_t data_links = 0;
  for (const auto& [id, e] : by_id) {
    size_t pad_count = 0;
    for (const auto& p : pads) pad_count += p.entity_id == id;
    EXPECT_EQ(e.pads, pad_count);
    data_links += e.links;

    media_links_enum links_enum{};
    links_enum.entity = id;
    std::vector<media_pad_desc> pad_descs(e.pads);
    std::vector<media_link_desc> link_descs(e.links);
    links_enum.pads = pad_descs.data();
    links_enum.links = link_descs.data();
    auto buffers = media.user_buffers(MEDIA_IOC_ENUM_LINKS, &links_enum);
    size_t described = 0;
    for (const auto& b : buffers) described += b.size_bytes;
    EXPECT_EQ(described, e.pads * sizeof(media_pad_desc) + e.links * sizeof(media_link_desc));
    ASSERT_EQ(media.ioctl(file, MEDIA_IOC_ENUM_LINKS, &links_enum), 0);
    for (uint16_t i = 0; i < e.pads; ++i) {
      EXPECT_EQ(pad_descs[i].entity, id);
      EXPECT_EQ(pad_descs[i].index, i);
    }
    for (const auto& l : link_descs) {
      EXPECT_EQ(l.source.entity, id) << "ENUM_LINKS lists an entity's outbound links";
      EXPECT_EQ(by_id.count(l.sink.entity), 1u);
      EXPECT_LT(l.sink.index, by_id[l.sink.entity].pads);
      // SETUP_LINK keeps an immutable link as it is and refuses any change.
      media_link_desc same = l;
      EXPECT_EQ(media.ioctl(file, MEDIA_IOC_SETUP_LINK, &same), 0);
      media_link_desc disable = l;
      disable.flags &= ~MEDIA_LNK_FL_ENABLED;
      EXPECT_EQ(media.ioctl(file, MEDIA_IOC_SETUP_LINK, &disable), -EINVAL);
      media_link_desc interface = l;
      interface.flags |= MEDIA_LNK_FL_INTERFACE_LINK;
      EXPECT_EQ(media.ioctl(file, MEDIA_IOC_SETUP_LINK, &interface), -EINVAL);
    }
  }
  EXPECT_EQ(data_links, 2u);
  media_links_enum none{};
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_ENUM_LINKS, &none), -EINVAL);
  media_link_desc unknown{};
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_SETUP_LINK, &unknown), -EINVAL);
}

TEST_F(MediaDevice, UnpluggedNodeAnswersEio) {
  media.unplug();
  media_device_info info{};
  EXPECT_EQ(media.ioctl(file, MEDIA_IOC_DEVICE_INFO, &info), -EIO);
  EXPECT_EQ(media.open_file(false), -ENODEV);
}

// Through the in-process transport: /dev/media0 opens next to /dev/video0, embedded
// pointers are marshalled (a bad one is EFAULT, not a crash), and lockf works.
TEST(MediaDeviceIo, DevMediaOpensAndBadPointersAreEfault) {
  auto camera = parse_camera_spec(testing::pinhole_camera_json(64, 48));
  auto scene = parse_scene_spec(testing::uniform_scene_json());
  ASSERT_TRUE(camera.ok() && scene.ok());
  auto device = VirtualV4l2Device::create(std::move(*camera), std::move(*scene), {});
  ASSERT_TRUE(device.ok());
  VirtualV4l2Io io({std::shared_ptr<VirtualV4l2Device>(std::move(*device))});
  const int fd = io.open("/dev/media0", O_RDWR);
  ASSERT_GE(fd, 0) << std::strerror(errno);
  EXPECT_TRUE(io.owns(fd));
  EXPECT_EQ(io.device_index_of(fd), -1) << "a media fd is not a video fd";
  EXPECT_LT(io.open("/dev/media1", O_RDWR), 0);

  media_device_info info{};
  ASSERT_EQ(io.ioctl(fd, MEDIA_IOC_DEVICE_INFO, &info), 0);
  EXPECT_STREQ(info.model, "test pinhole");
  EXPECT_STREQ(info.bus_info, "platform:camlab-vcam-0") << "the video node's bus_info";
  EXPECT_EQ(io.ioctl(fd, MEDIA_IOC_DEVICE_INFO, reinterpret_cast<void*>(8)), -1);
  EXPECT_EQ(errno, EFAULT);

  media_v2_topology t{};
  ASSERT_EQ(io.ioctl(fd, MEDIA_IOC_G_TOPOLOGY, &t), 0);
  std::vector<media_v2_pad> pads(t.num_pads);
  t.ptr_pads = reinterpret_cast<uintptr_t>(pads.data());
  ASSERT_EQ(io.ioctl(fd, MEDIA_IOC_G_TOPOLOGY, &t), 0);
  EXPECT_EQ(t.ptr_pads, reinterpret_cast<uintptr_t>(pads.data()))
      << "the caller's pointer comes back";
  EXPECT_NE(pads[0].id, 0u);
  t.ptr_entities = 4;  // v4l2-compliance's bad pointer
  EXPECT_EQ(io.ioctl(fd, MEDIA_IOC_G_TOPOLOGY, &t), -1);
  EXPECT_EQ(errno, EFAULT);

  media_links_enum links{};
  links.entity = 1;
  links.pads = reinterpret_cast<media_pad_desc*>(4);
  EXPECT_EQ(io.ioctl(fd, MEDIA_IOC_ENUM_LINKS, &links), -1);
  EXPECT_EQ(errno, EFAULT);
  EXPECT_EQ(io.ioctl(fd, _IOWR('|', 0x7f, int), &links), -1);
  EXPECT_EQ(errno, ENOTTY);

  // libcamera's MediaDevice::lock(): lockf(F_TLOCK) on the media fd.
  EXPECT_EQ(lockf(fd, F_TLOCK, 0), 0) << std::strerror(errno);
  EXPECT_EQ(lockf(fd, F_ULOCK, 0), 0);
  EXPECT_EQ(io.close(fd), 0);
  EXPECT_EQ(io.open_fd_count(), 0u);
}

}  // namespace
}  // namespace camlab::mock
