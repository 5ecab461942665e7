// How every camlab subcommand ends on an error (docs/errors.md): one line on stderr,
//
//   camlab calibrate: cannot read '/nonexistent.vnl' [not_found]
//
// and, when the command was asked for --json, the same error as JSON on stdout, which is
// what a script reads,
//
//   {"error": {"code": "not_found", "message": "cannot read '/nonexistent.vnl'"}}
//
// then exit status 2. The codes are the library's and camlabd's (base/error_code.h).
//
// Thread-compatible (the command's own thread).
#pragma once

#include <string>
#include <utility>

#include "base/result.h"

namespace camlab::cli {

class CommandErrors {
 public:
  // `command`: as the user typed it, e.g. "camlab optics dof". `json`: its --json flag.
  CommandErrors(std::string command, bool json) : command_(std::move(command)), json_(json) {}

  // Prints the error (stderr, and stdout with --json) ...
  void report(const Error& error) const;
  // ... and ends the command: CLI::RuntimeError(2), which cli/main.cpp returns as the exit
  // status once the subcommand's callback is left.
  [[noreturn]] void fail(const Error& error) const;
  [[noreturn]] void fail(ErrorCodeName code, const std::string& message) const {
    fail(make_error(code, message));
  }
  [[noreturn]] void fail(ErrorCode code, const std::string& message) const {
    fail(make_error(code, message));
  }

  // The value, or the command ends with the error.
  template <class T>
  T take(Result<T> result) const {
    if (!result) fail(result.error());
    return std::move(*result);
  }
  void check(const Status& status) const {
    if (!status) fail(status.error());
  }

 private:
  std::string command_;
  bool json_;
};

}  // namespace camlab::cli
