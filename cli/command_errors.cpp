#include "command_errors.h"

#include <cstdio>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

namespace camlab::cli {

void CommandErrors::report(const Error& error) const {
  const std::string line =
      command_ + ": " + error.message + " [" + std::string(name_of(error.code)) + "]\n";
  std::fputs(line.c_str(), stderr);
  if (json_) {
    const nlohmann::json body = {{"error", {{"code", error.code}, {"message", error.message}}}};
    // Invalid UTF-8 (a device name, a path) is replaced rather than thrown on.
    std::puts(body.dump(2, ' ', false, nlohmann::json::error_handler_t::replace).c_str());
  }
}

void CommandErrors::fail(const Error& error) const {
  report(error);
  throw CLI::RuntimeError(2);
}

}  // namespace camlab::cli
