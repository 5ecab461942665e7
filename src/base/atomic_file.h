// Writing files so that a reader never sees half of one: the bytes go to a temporary
// file in the same directory, are flushed, and the file is renamed over the target
// (rename is atomic within a filesystem). A crash leaves either the old file or the new.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <span>
#include <string_view>

#include "base/result.h"

namespace camlab {

Status write_file_atomically(const std::filesystem::path& path,
                             std::span<const unsigned char> bytes);
Status write_file_atomically(const std::filesystem::path& path, std::string_view text);

// Reads a whole file, byte for byte (binary files too); errors name the path and the reason.
Result<std::string> read_text_file(const std::filesystem::path& path);

}  // namespace camlab
