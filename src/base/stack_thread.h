// Runs a call on a thread of its own with a stack of a given size, and waits for it.
//
// For library calls that keep arrays of the problem's size on the stack: mrcal's solver
// keeps its state vector and per-parameter arrays there, so a large problem overflows the
// 8 MiB of an ordinary thread (or less of a pool worker) and the process dies of SIGSEGV.
// A thread's stack is reserved address space, committed only as it is touched, so a
// generous size costs nothing until it is used.
//
// Reentrant.
#pragma once

#include <cstddef>
#include <functional>

#include "base/result.h"

namespace camlab {

// Calls `work` on a new thread whose stack holds `stack_bytes` (rounded up to the page
// size; at least the system's minimum) and returns once it has returned. Error "internal"
// when no such thread can be made (the message gives the size and the reason).
Status run_with_stack(size_t stack_bytes, const std::function<void()>& work);

}  // namespace camlab
