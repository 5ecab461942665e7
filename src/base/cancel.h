// A stop request for long library work (a calibration, an analysis): the caller owns an
// std::atomic<bool> and sets it from another thread; the work checks it between its steps
// (images, frames, solve stages) and returns the error "cancelled". Null: not cancellable.
//
// Reentrant.
#pragma once

#include <atomic>
#include <string>

#include "base/result.h"

namespace camlab {

inline bool is_cancelled(const std::atomic<bool>* cancel) {
  return cancel != nullptr && cancel->load(std::memory_order_relaxed);
}

// Error "cancelled" ("the WHAT was cancelled") once `cancel` is set.
inline Status check_not_cancelled(const std::atomic<bool>* cancel, const std::string& what) {
  if (is_cancelled(cancel)) return make_error("cancelled", "the " + what + " was cancelled");
  return {};
}

}  // namespace camlab
