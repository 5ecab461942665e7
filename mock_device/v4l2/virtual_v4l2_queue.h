// The virtual camera's buffer queue, with videobuf2's rules: REQBUFS gives one file (the
// queue's owner; others are EBUSY) 2 to VB2_MAX_FRAME buffers, MMAP buffers live in memfds
// the device maps once and clients map by offset or export (EXPBUF), DMABUF buffers are
// imported at QBUF by mapping the fd the client brings, and buffers go queued -> filling
// -> done -> dequeued, each step in FIFO order. USERPTR buffers (as uvcvideo offers, whose
// frames are copied into the buffer anyway) are filled in memfds of the device's own, and
// the frame is copied to the application's pointer at DQBUF by whoever serves the client
// (userptr_source: VirtualV4l2Io in process, the broker's client across processes).
//
// Every memfd and mapping is owned (UniqueFd, MappedBuffer): freeing the buffers closes and
// unmaps them. The generation changes whenever they are freed, so a frame rendered without
// the device mutex never writes into freed memory.
//
// The checks the device makes between two of the queue's (priorities) split some
// ioctls in two: check_* first, then the ioctl itself, in the kernel's order.
//
// Thread-compatible: the device's mutex serialises every call.
#pragma once

#include <linux/videodev2.h>
#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <vector>

#include "base/mapped_buffer.h"
#include "base/unique_fd.h"

namespace camlab::mock {

class VirtualV4l2Queue {
 public:
  // What an mmap of an MMAP buffer maps: the memfd (borrowed) and the device's mapping.
  struct BufferMemory {
    int memfd;
    uint8_t* address;  // the device's own mapping
    size_t length;
  };

  // The file that allocated the buffers (0: none).
  int owner() const { return owner_; }
  bool streaming() const { return streaming_; }
  // -EBUSY when another file owns the queue (vb2_queue_is_busy), else 0.
  int check_busy(int file) const;
  // For the ioctls that need the buffers: -EINVAL when there are none, -EBUSY when
  // another file owns them.
  int check_owner(int file) const;
  // Whether the format is fixed by allocated buffers (S_FMT is EBUSY).
  bool holds_format() const { return !buffers_.empty() && owner_ != 0; }

  // REQBUFS: check_reqbufs (type, the capabilities reported, memory, owner), then reqbufs
  // (those checks again, streaming, mappings; then frees and allocates buffers of
  // `sizeimage` bytes).
  int check_reqbufs(int file, v4l2_requestbuffers* request) const;
  int reqbufs(int file, v4l2_requestbuffers* request, uint32_t sizeimage);
  int querybuf(v4l2_buffer* buffer, uint32_t sizeimage) const;
  // `dmabuf_fd`: this process's fd for the DMABUF named in m.fd (-1: m.fd is ours).
  int qbuf(int file, v4l2_buffer* buffer, int dmabuf_fd, uint32_t sizeimage);
  // DQBUF: check_dqbuf, then (once a buffer is done: has_done) dqbuf.
  int check_dqbuf(int file, const v4l2_buffer& buffer) const;
  bool has_done() const { return !done_order_.empty(); }
  void dqbuf(v4l2_buffer* buffer);
  // A new fd of this process for an MMAP buffer's memory, in exported->fd; the caller owns it.
  int expbuf(v4l2_exportbuffer* exported) const;
  // Where the frame of dequeued USERPTR buffer `index` is (its memfd, borrowed), for the
  // copy to the application's pointer; -EINVAL for other memory or indices.
  int userptr_source(uint32_t index, BufferMemory* out) const;
  // -EINVAL without buffers; already streaming is no error.
  int streamon();
  // vb2 returns every buffer to the application, done or not.
  void streamoff();
  // The device is gone: no more frames (the buffers stay as they are).
  void stop() { streaming_ = false; }
  // `file` closes: the queue's owner closing stops the stream and frees the buffers
  // unless some are still mapped, as videobuf2's release does.
  void release(int file);

  int buffer_for_mmap(off_t offset, size_t length, BufferMemory* out) const;
  void note_mapping(off_t offset, int delta);  // mmap (+1) / munmap (-1) bookkeeping

  // The producer's side: a buffer is taken to be filled, and returned done.
  bool has_queued() const { return !queued_order_.empty(); }
  int start_filling();  // the oldest queued buffer's index
  uint64_t generation() const { return generation_; }
  // The memory of buffer `index` if it is still being filled in `generation` while
  // streaming, else null (the stream stopped, or the buffers changed meanwhile).
  uint8_t* filling_memory(int index, uint64_t generation) const;
  // `done` has everything but the memory fields, which the queue adds.
  void complete(int index, v4l2_buffer done, uint32_t sizeimage);

 private:
  struct Buffer {
    UniqueFd memfd;        // MMAP: the device's memory; DMABUF: none
    MappedBuffer mapping;  // the device's mapping (of the memfd, or of the import)
    // DMABUF: the client's fd number (reported back), the imported file (to map it once
    // however often it is queued) and the plane length vb2 reports.
    int user_fd = 0;
    dev_t import_device = 0;
    ino_t import_inode = 0;
    uint32_t dmabuf_length = 0;
    // USERPTR: the application's pointer and length, as QBUF gave them (reported back).
    unsigned long user_pointer = 0;
    uint32_t user_length = 0;
    enum class State { kDequeued, kQueued, kFilling, kDone } state = State::kDequeued;
    v4l2_buffer done{};  // filled when State::kDone
    int mappings = 0;    // client mappings (VirtualV4l2Io, the broker)
  };

  int import_dmabuf(Buffer& buffer, int fd, uint32_t asked_length, uint32_t sizeimage);
  void free_buffers();

  std::vector<Buffer> buffers_;
  v4l2_memory memory_ = V4L2_MEMORY_MMAP;  // of the allocated buffers
  size_t stride_bytes_ = 0;                // mmap offset of buffer i is i * stride_bytes_
  uint64_t generation_ = 0;
  std::deque<int> queued_order_;  // buffers waiting to be filled, oldest first
  std::deque<int> done_order_;    // filled buffers waiting for DQBUF, oldest first
  int owner_ = 0;
  bool streaming_ = false;
};

}  // namespace camlab::mock
