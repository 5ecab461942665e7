#include "base/stack_thread.h"

#include <pthread.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <string>

namespace camlab {

namespace {

void* call_work(void* work) {
  (*static_cast<const std::function<void()>*>(work))();
  return nullptr;
}

}  // namespace

Status run_with_stack(size_t stack_bytes, const std::function<void()>& work) {
  const size_t page = static_cast<size_t>(sysconf(_SC_PAGESIZE));
  const size_t minimum = static_cast<size_t>(PTHREAD_STACK_MIN);
  const size_t bytes = (std::max(stack_bytes, minimum) + page - 1) / page * page;
  pthread_attr_t attr;
  pthread_attr_init(&attr);
  int rc = pthread_attr_setstacksize(&attr, bytes);
  pthread_t thread;
  if (rc == 0)
    rc = pthread_create(&thread, &attr, call_work, const_cast<std::function<void()>*>(&work));
  pthread_attr_destroy(&attr);
  if (rc != 0)
    return make_error("internal", "cannot start a thread with a " + std::to_string(bytes >> 20) +
                                      " MiB stack: " + std::strerror(rc));
  pthread_join(thread, nullptr);
  return {};
}

}  // namespace camlab
