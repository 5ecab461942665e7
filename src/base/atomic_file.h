// Writing files so that a reader never sees half of one: the bytes go to a temporary
// file in the same directory, are flushed, and the file is renamed over the target
// (rename is atomic within a filesystem). A crash leaves either the old file or the new.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "base/result.h"

namespace camlab {

Status write_file_atomically(const std::filesystem::path& path,
                             std::span<const unsigned char> bytes);
Status write_file_atomically(const std::filesystem::path& path, std::string_view text);

// Reads a whole file, byte for byte (binary files too); errors name the path and the reason.
Result<std::string> read_text_file(const std::filesystem::path& path);

// Whether `name` is a temporary file write_file_atomically makes (".TARGET.XXXXXX"): what a
// process killed mid-write leaves behind.
bool is_atomic_write_temporary(const std::string& name);

// Removes those temporaries from `dir` (not from its subfolders); returns their names.
// For a folder no writer has open: after a crash, before anything else writes to it.
Result<std::vector<std::string>> remove_atomic_write_temporaries(const std::filesystem::path& dir);

}  // namespace camlab
