// Who this camlabd is in a fleet, beyond its --host-name: names are chosen by people and
// copied with disk images (every cloned lab PC or Raspberry Pi has the same system host
// name), so two processes with one name must be told apart, and a process restarted after
// a crash must be told from a clone. The identity is a random id kept in the data folder
// (DATA/host-id, made on the first start) joined with the kernel's boot id: a restart on
// the same machine and folder keeps it; another machine, or the same data folder copied to
// one, has another (its boot id differs even when the folder was cloned).
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>

#include "base/result.h"

namespace camlab::service {

// "ID@BOOT": the data folder's id (32 hex digits, created in `data_dir` when missing) and
// the boot id ("" where the kernel does not tell it). Error "io_error" when the id can be
// neither read nor written, "bad_manifest" when the file holds something else.
Result<std::string> load_host_identity(const std::filesystem::path& data_dir);

}  // namespace camlab::service
