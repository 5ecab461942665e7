// The error a failed system call on a file gives: code "io_error", what was being done,
// the path, and the C library's text for errno.
#pragma once

#include <cstring>
#include <filesystem>
#include <string>
#include <string_view>

#include "base/result.h"

namespace camlab {

// e.g. io_error(path, "cannot write", errno): "cannot write /data/x.png: No space left on
// device".
inline Error io_error(const std::filesystem::path& path, std::string_view what, int errno_value) {
  return make_error("io_error",
                    std::string(what) + " " + path.string() + ": " + std::strerror(errno_value));
}

}  // namespace camlab
