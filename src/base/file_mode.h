// The permissions of the files camlab writes for people and programs to read (frames,
// sidecars, manifests, journals, reports, models): what open(2) would give a new file,
// 0666 less the process umask, unless the process chose a mode (`camlabd --file-mode`).
// Secrets (the API token) keep their own 0600.
//
// Thread-safe.
#pragma once

#include <sys/types.h>

#include <string>

#include "base/result.h"

namespace camlab {

// The mode for new data files (permission bits only).
mode_t data_file_mode();

// Sets it for the rest of the process; call before any file is written.
void set_data_file_mode(mode_t mode);

// Parses an octal mode such as "0640" or "640": permission bits within 0666 that keep
// the owner's read and write (camlab reads its own files back). "invalid_argument"
// otherwise, naming the rule.
Result<mode_t> parse_data_file_mode(const std::string& text);

}  // namespace camlab
