// UniqueFd (base/unique_fd.h): a descriptor is closed exactly once, by its last owner.
#include "base/unique_fd.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <unistd.h>

#include <cerrno>
#include <vector>

namespace camlab {
namespace {

bool is_open(int fd) { return ::fcntl(fd, F_GETFD) != -1 || errno != EBADF; }

// A closer that records what it closes (and closes it), to count closes.
struct RecordingCloser {
  std::vector<int>* closed;
  void operator()(int fd) const noexcept {
    closed->push_back(fd);
    ::close(fd);
  }
};

TEST(UniqueFd, ClosesWhenItGoes) {
  int raw = -1;
  {
    UniqueFd fd(::open("/dev/null", O_RDONLY | O_CLOEXEC));
    ASSERT_TRUE(fd);
    raw = fd.get();
    EXPECT_TRUE(is_open(raw));
  }
  EXPECT_FALSE(is_open(raw));
}

TEST(UniqueFd, MovesOwnershipAndClosesExactlyOnce) {
  std::vector<int> closed;
  using Fd = BasicUniqueFd<RecordingCloser>;
  const int raw = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  ASSERT_GE(raw, 0);
  {
    Fd first(raw, RecordingCloser{&closed});
    Fd second(std::move(first));
    EXPECT_FALSE(first);  // NOLINT(bugprone-use-after-move): moved-from owns nothing
    EXPECT_EQ(second.get(), raw);
    Fd third(-1, RecordingCloser{&closed});
    third = std::move(second);
    EXPECT_EQ(third.get(), raw);
    EXPECT_TRUE(closed.empty());
  }
  EXPECT_EQ(closed, std::vector<int>{raw});
}

TEST(UniqueFd, ResetClosesTheOldAndReleaseGivesUp) {
  std::vector<int> closed;
  using Fd = BasicUniqueFd<RecordingCloser>;
  const int a = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  const int b = ::open("/dev/null", O_RDONLY | O_CLOEXEC);
  Fd fd(a, RecordingCloser{&closed});
  fd.reset(b);
  EXPECT_EQ(closed, std::vector<int>{a});
  const int released = fd.release();
  EXPECT_EQ(released, b);
  EXPECT_FALSE(fd);
  fd.reset();
  EXPECT_EQ(closed.size(), 1u) << "a released descriptor is not the owner's to close";
  EXPECT_TRUE(is_open(b));
  ::close(b);
}

TEST(UniqueFd, AnInvalidDescriptorOwnsNothing) {
  std::vector<int> closed;
  { BasicUniqueFd<RecordingCloser> fd(-1, RecordingCloser{&closed}); }
  EXPECT_TRUE(closed.empty());
}

TEST(UniqueFd, ClosingKeepsTheCallersErrno) {
  {
    UniqueFd fd(::open("/dev/null", O_RDONLY | O_CLOEXEC));
    ASSERT_TRUE(fd);
    errno = ENODEV;  // what a failed call before the owner's end left
  }
  EXPECT_EQ(errno, ENODEV);
}

}  // namespace
}  // namespace camlab
