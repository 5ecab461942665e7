// LibraryStderrCapture (calib/library_stderr.h): what a library prints on fd 2 during a
// capture never reaches the real stderr, fd 2 is the same file afterwards (nested and
// overlapping captures included), and camlab's own log still reaches the real stderr.
// The real stderr is a temporary file here, so the test can read what reached it.
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include <gtest/gtest.h>

#include "base/log.h"
#include "calib/library_stderr.h"

namespace camlab::calib {
namespace {

// fd 2 pointed at a temporary file for the test's duration, then put back.
class StderrToFile : public ::testing::Test {
 protected:
  void SetUp() override {
    std::fflush(stderr);
    saved_ = ::dup(STDERR_FILENO);
    ASSERT_GE(saved_, 0);
    char path[] = "/tmp/camlab_stderr_test_XXXXXX";
    const int fd = ::mkstemp(path);
    ASSERT_GE(fd, 0);
    path_ = path;
    ASSERT_GE(::dup2(fd, STDERR_FILENO), 0);
    ::close(fd);
  }
  void TearDown() override {
    std::fflush(stderr);
    ::dup2(saved_, STDERR_FILENO);
    ::close(saved_);
    ::unlink(path_.c_str());
  }
  std::string written() const {
    std::fflush(stderr);
    std::ifstream in(path_);
    std::stringstream ss;
    ss << in.rdbuf();
    return ss.str();
  }
  static ino_t fd2_inode() {
    struct stat st {};
    ::fstat(STDERR_FILENO, &st);
    return st.st_ino;
  }
  int saved_ = -1;
  std::string path_;
};

TEST_F(StderrToFile, ALibrarysLinesAreCapturedAndFd2IsRestored) {
  const ino_t before = fd2_inode();
  {
    const LibraryStderrCapture capture;
    EXPECT_NE(fd2_inode(), before) << "fd 2 is not redirected during the capture";
    std::fprintf(stderr, "mrcal.c(5351): Threw out some outliers; going again\n");
    const char raw[] = "written with write(2)\n";
    ASSERT_EQ(::write(STDERR_FILENO, raw, sizeof raw - 1), static_cast<ssize_t>(sizeof raw - 1));
    {
      const LibraryStderrCapture nested;  // nested: still captured, not restored early
      std::fprintf(stderr, "from a nested capture\n");
    }
    EXPECT_NE(fd2_inode(), before) << "a nested capture's end restored fd 2 too early";
    // Another thread's capture overlapping this one.
    std::thread other([] {
      const LibraryStderrCapture capture;
      std::fprintf(stderr, "from another thread\n");
    });
    other.join();
    // camlab's own log still reaches the real stderr during the capture.
    log_warning(log::Category::kCalib, "camlab's own line");
  }
  EXPECT_EQ(fd2_inode(), before) << "fd 2 was not restored";
  const std::string out = written();
  EXPECT_EQ(out.find("Threw out"), std::string::npos) << out;
  EXPECT_EQ(out.find("write(2)"), std::string::npos) << out;
  EXPECT_EQ(out.find("nested"), std::string::npos) << out;
  EXPECT_EQ(out.find("another thread"), std::string::npos) << out;
  EXPECT_NE(out.find("camlab's own line"), std::string::npos) << out;
  // After the capture, stderr is stderr again.
  std::fprintf(stderr, "after the capture\n");
  EXPECT_NE(written().find("after the capture"), std::string::npos);
}

TEST_F(StderrToFile, ACallerThatMovedFd2IsFollowed) {
  { const LibraryStderrCapture capture; }
  // The caller points fd 2 at another file; the next capture must restore that one, and
  // camlab's log must write there, not to the file fd 2 was at the first capture.
  char path[] = "/tmp/camlab_stderr_test2_XXXXXX";
  const int fd = ::mkstemp(path);
  ASSERT_GE(fd, 0);
  std::fflush(stderr);
  ASSERT_GE(::dup2(fd, STDERR_FILENO), 0);
  const ino_t moved = fd2_inode();
  {
    const LibraryStderrCapture capture;
    log_warning(log::Category::kCalib, "to the moved stderr");
  }
  EXPECT_EQ(fd2_inode(), moved);
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  EXPECT_NE(ss.str().find("to the moved stderr"), std::string::npos) << ss.str();
  ::close(fd);
  ::unlink(path);
}

}  // namespace
}  // namespace camlab::calib
