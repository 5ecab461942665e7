// Result<T>: a value or an Error, returned by every library function that can fail on
// input (docs/architecture.md, "Errors": no exception crosses a library boundary).
//
// Reentrant: plain value types.
#pragma once

#include <cassert>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <variant>

#include "base/error_code.h"

namespace camlab {

// A failure a user can act on: `code` says what kind (a closed set, base/error_code.h);
// `message` says what exactly was wrong and what is allowed.
struct Error {
  Error(ErrorCode code, std::string message) : code(code), message(std::move(message)) {}

  // "code: message", for a report line that keeps the code.
  std::string text() const { return std::string(name_of(code)) + ": " + message; }

  // The same error with `context` put before its message ("setting gain = 5: ...").
  Error with_context(std::string_view context) const {
    return Error(code, std::string(context) + message);
  }

  ErrorCode code;
  std::string message;
};

// make_error("out_of_range", "gain = 900 is outside [0, 480]"): the name is checked when
// compiling (base/error_code.h).
inline Error make_error(ErrorCodeName code, std::string message) {
  return Error(code.code, std::move(message));
}
inline Error make_error(ErrorCode code, std::string message) {
  return Error(code, std::move(message));
}

template <class T>
class [[nodiscard]] Result {
 public:
  Result(T value) : storage_(std::move(value)) {}      // NOLINT: implicit by design
  Result(Error error) : storage_(std::move(error)) {}  // NOLINT: implicit by design

  bool ok() const { return std::holds_alternative<T>(storage_); }
  explicit operator bool() const { return ok(); }

  const T& value() const& {
    assert(ok());
    return std::get<T>(storage_);
  }
  T& value() & {
    assert(ok());
    return std::get<T>(storage_);
  }
  T&& value() && {
    assert(ok());
    return std::get<T>(std::move(storage_));
  }
  const T& operator*() const& { return value(); }
  T& operator*() & { return value(); }
  const T* operator->() const { return &value(); }
  T* operator->() { return &value(); }

  const Error& error() const {
    assert(!ok());
    return std::get<Error>(storage_);
  }

 private:
  std::variant<T, Error> storage_;
};

// Success-or-error for functions with nothing to return.
class [[nodiscard]] Status {
 public:
  Status() = default;
  Status(Error error) : error_(std::move(error)) {}  // NOLINT: implicit

  bool ok() const { return !error_.has_value(); }
  explicit operator bool() const { return ok(); }
  const Error& error() const {
    assert(error_);
    return *error_;
  }

 private:
  std::optional<Error> error_;
};

}  // namespace camlab

// Unwraps a Result into `target`, or returns its error from the enclosing function
// (which must return a Result or a Status).
#define CAMLAB_ASSIGN(target, expr)                     \
  do {                                                  \
    auto camlab_result_ = (expr);                       \
    if (!camlab_result_) return camlab_result_.error(); \
    target = std::move(*camlab_result_);                \
  } while (0)
