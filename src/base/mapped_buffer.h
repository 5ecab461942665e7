// Owners of memory mappings: a mapping is unmapped exactly once, when its owner goes or is
// reset. Every mmap camlab makes has one (docs/architecture.md, "Ownership").
//
//   MappedBuffer buffer(::mmap(nullptr, size, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0), size);
//   if (!buffer) return errno;                  // MAP_FAILED owns nothing
//   std::memcpy(buffer.data(), pixels, size);
//   // unmapped here
//
// The mapping goes back through an Unmapper: the system call by default, or the seam it
// came from (device::V4l2Io; the real libc inside the preload library).
//
// Thread-compatible: one owner; the bytes may be lent, never the ownership.
// Header-only, so that the preload library can use it without linking camlab_base.
#pragma once

#include <sys/mman.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <span>
#include <utility>

namespace camlab {

struct SystemUnmapper {
  void operator()(void* address, size_t length) const noexcept { ::munmap(address, length); }
};

template <class Unmapper = SystemUnmapper>
class BasicMappedBuffer {
 public:
  BasicMappedBuffer() = default;
  // Takes ownership of `length` bytes mapped at `address`, as mmap returned it
  // (MAP_FAILED or nullptr: owns nothing).
  BasicMappedBuffer(void* address, size_t length, Unmapper unmapper = Unmapper()) noexcept
      : address_(address == MAP_FAILED ? nullptr : static_cast<uint8_t*>(address)),
        length_(address_ ? length : 0),
        unmapper_(std::move(unmapper)) {}
  BasicMappedBuffer(BasicMappedBuffer&& other) noexcept
      : address_(std::exchange(other.address_, nullptr)),
        length_(std::exchange(other.length_, 0)),
        unmapper_(std::move(other.unmapper_)) {}
  BasicMappedBuffer& operator=(BasicMappedBuffer&& other) noexcept {
    if (this != &other) {
      reset();
      address_ = std::exchange(other.address_, nullptr);
      length_ = std::exchange(other.length_, 0);
      unmapper_ = std::move(other.unmapper_);
    }
    return *this;
  }
  BasicMappedBuffer(const BasicMappedBuffer&) = delete;
  BasicMappedBuffer& operator=(const BasicMappedBuffer&) = delete;
  ~BasicMappedBuffer() { reset(); }

  uint8_t* data() const noexcept { return address_; }
  size_t size() const noexcept { return length_; }
  std::span<uint8_t> bytes() const noexcept { return {address_, length_}; }
  bool is_mapped() const noexcept { return address_ != nullptr; }
  explicit operator bool() const noexcept { return is_mapped(); }

  // Unmaps now (no-op when nothing is mapped). errno is kept, as by UniqueFd::reset.
  void reset() noexcept {
    if (address_) {
      const int saved_errno = errno;
      unmapper_(address_, length_);
      errno = saved_errno;
    }
    address_ = nullptr;
    length_ = 0;
  }

 private:
  uint8_t* address_ = nullptr;
  size_t length_ = 0;
  [[no_unique_address]] Unmapper unmapper_;
};

using MappedBuffer = BasicMappedBuffer<>;

}  // namespace camlab
