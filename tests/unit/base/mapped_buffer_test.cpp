// MappedBuffer (base/mapped_buffer.h): a mapping is unmapped exactly once, by its last owner.
#include "base/mapped_buffer.h"

#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <cstring>
#include <utility>
#include <vector>

namespace camlab {
namespace {

struct RecordingUnmapper {
  std::vector<std::pair<void*, size_t>>* unmapped;
  void operator()(void* address, size_t length) const noexcept {
    unmapped->emplace_back(address, length);
    ::munmap(address, length);
  }
};

void* map_anonymous(size_t length) {
  return ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
}

// Whether the page at `address` is mapped: mincore fails with ENOMEM on unmapped memory.
bool is_mapped(void* address) {
  unsigned char resident = 0;
  return ::mincore(address, 1, &resident) == 0;
}

TEST(MappedBuffer, UnmapsWhenItGoes) {
  const size_t length = static_cast<size_t>(::sysconf(_SC_PAGESIZE));
  void* address = map_anonymous(length);
  ASSERT_NE(address, MAP_FAILED);
  {
    MappedBuffer buffer(address, length);
    ASSERT_TRUE(buffer);
    std::memset(buffer.data(), 7, buffer.size());
    EXPECT_EQ(buffer.bytes()[length - 1], 7);
    EXPECT_TRUE(is_mapped(address));
  }
  EXPECT_FALSE(is_mapped(address));
}

TEST(MappedBuffer, MovesOwnershipAndUnmapsExactlyOnce) {
  std::vector<std::pair<void*, size_t>> unmapped;
  using Buffer = BasicMappedBuffer<RecordingUnmapper>;
  const size_t length = 2 * static_cast<size_t>(::sysconf(_SC_PAGESIZE));
  void* address = map_anonymous(length);
  ASSERT_NE(address, MAP_FAILED);
  {
    Buffer first(address, length, RecordingUnmapper{&unmapped});
    Buffer second(std::move(first));
    EXPECT_FALSE(first);  // NOLINT(bugprone-use-after-move)
    Buffer third;
    third = std::move(second);
    EXPECT_EQ(third.data(), address);
    EXPECT_EQ(third.size(), length);
    EXPECT_TRUE(unmapped.empty());
  }
  ASSERT_EQ(unmapped.size(), 1u);
  EXPECT_EQ(unmapped[0].first, address);
  EXPECT_EQ(unmapped[0].second, length);
}

TEST(MappedBuffer, AFailedMapOwnsNothing) {
  std::vector<std::pair<void*, size_t>> unmapped;
  {
    BasicMappedBuffer<RecordingUnmapper> failed(MAP_FAILED, 4096, RecordingUnmapper{&unmapped});
    EXPECT_FALSE(failed);
    EXPECT_EQ(failed.size(), 0u);
  }
  EXPECT_TRUE(unmapped.empty());
}

}  // namespace
}  // namespace camlab
