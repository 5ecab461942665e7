// run_with_stack: the call runs on a thread whose stack holds what it asks for (a call that
// would overflow an ordinary 8 MiB thread stack returns normally), and runs exactly once.
#include "base/stack_thread.h"

#include <alloca.h>
#include <pthread.h>

#include <cstring>

#include <gtest/gtest.h>

namespace camlab {
namespace {

// Touches `bytes` of this thread's stack, as mrcal's variable-length arrays do; returns a
// value that depends on all of it so the compiler keeps the writes.
size_t touch_stack(size_t bytes) {
  auto* block = static_cast<volatile unsigned char*>(alloca(bytes));
  for (size_t i = 0; i < bytes; i += 4096) block[i] = static_cast<unsigned char>(i >> 12);
  size_t sum = 0;
  for (size_t i = 0; i < bytes; i += 4096) sum += block[i];
  return sum;
}

TEST(StackThread, ACallNeedingMoreThanAnOrdinaryThreadsStackRuns) {
  constexpr size_t kNeeded = size_t{48} << 20;  // 6 x the usual 8 MiB
  size_t sum = 0;
  int calls = 0;
  const Status ran = run_with_stack(kNeeded + (size_t{8} << 20), [&] {
    ++calls;
    sum = touch_stack(kNeeded);
  });
  ASSERT_TRUE(ran.ok()) << ran.error().message;
  EXPECT_EQ(calls, 1);
  size_t expected = 0;
  for (size_t i = 0; i < kNeeded; i += 4096) expected += static_cast<unsigned char>(i >> 12);
  EXPECT_EQ(sum, expected);
}

TEST(StackThread, TheThreadHasTheStackAskedFor) {
  size_t stack_bytes = 0;
  const Status ran = run_with_stack(size_t{100} << 20, [&] {
    pthread_attr_t attr;
    ASSERT_EQ(pthread_getattr_np(pthread_self(), &attr), 0);
    ASSERT_EQ(pthread_attr_getstacksize(&attr, &stack_bytes), 0);
    pthread_attr_destroy(&attr);
  });
  ASSERT_TRUE(ran.ok());
  EXPECT_GE(stack_bytes, size_t{100} << 20);
  // A tiny request still gets a working stack (the system's minimum).
  int calls = 0;
  ASSERT_TRUE(run_with_stack(1, [&] { ++calls; }).ok());
  EXPECT_EQ(calls, 1);
}

TEST(StackThread, AnImpossibleStackIsAnErrorNotACrash) {
  int calls = 0;
  const Status ran = run_with_stack(~size_t{0} / 2, [&] { ++calls; });
  ASSERT_FALSE(ran.ok());
  EXPECT_EQ(ran.error().code, "internal");
  EXPECT_NE(ran.error().message.find("MiB stack"), std::string::npos) << ran.error().message;
  EXPECT_EQ(calls, 0);
}

}  // namespace
}  // namespace camlab
