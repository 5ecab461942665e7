// Result<T>: a value or an Error, returned by every library function that can fail on
// input (ARCHITECTURE.md: no exception crosses a library boundary).
//
// Reentrant: plain value types.
#pragma once

#include <cassert>
#include <string>
#include <utility>
#include <variant>

namespace camlab {

// A failure a user can act on. `code` is stable and machine-readable (snake_case, e.g.
// "out_of_range", "no_real_image"); `message` says what was wrong and what is allowed.
struct Error {
  std::string code;
  std::string message;
};

inline Error make_error(std::string code, std::string message) {
  return Error{std::move(code), std::move(message)};
}

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : storage_(std::move(value)) {}          // NOLINT: implicit by design
  Result(Error error) : storage_(std::move(error)) {}      // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(storage_); }
  explicit operator bool() const { return ok(); }

  const T& value() const& { assert(ok()); return std::get<T>(storage_); }
  T& value() & { assert(ok()); return std::get<T>(storage_); }
  T&& value() && { assert(ok()); return std::get<T>(std::move(storage_)); }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

  const Error& error() const { assert(!ok()); return std::get<Error>(storage_); }

 private:
  std::variant<T, Error> storage_;
};

// Success-or-error for functions with nothing to return.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)), failed_(true) {}  // NOLINT: implicit

  bool ok() const { return !failed_; }
  explicit operator bool() const { return ok(); }
  const Error& error() const { assert(failed_); return error_; }

 private:
  Error error_;
  bool failed_ = false;
};

}  // namespace camlab

// Unwraps a Result into `target`, or returns its error from the enclosing function
// (which must return a Result or a Status).
#define CAMLAB_ASSIGN(target, expr)                       \
  do {                                                    \
    auto camlab_result_ = (expr);                         \
    if (!camlab_result_) return camlab_result_.error();   \
    target = std::move(*camlab_result_);                  \
  } while (0)
