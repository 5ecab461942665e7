// Bringing a capture folder left by a crash (kill -9, power cut) back to what it lists, so
// that what is on disk and what is listed agree again: the frames journal (version 3) or
// the manifest's frames (versions 1 and 2) is the truth, and the rest is what a writer was
// in the middle of.
//
// Thread-compatible; for a folder no writer has open (camlabd runs it at start for the
// captures its last run left unfinished, before anything writes to them).
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "base/result.h"

namespace camlab::image {

struct FolderRecovery {
  int frames = 0;                    // frames the folder lists afterwards
  std::vector<std::string> removed;  // temporaries, and frame files never listed
  uint64_t journal_bytes_cut = 0;    // a line cut short (or damage) cut from the journal
  std::string journal_problem;       // why, when bytes were cut
};

// 1. Removes write_file_atomically's temporaries (".manifest.json.Ab12Cd").
// 2. Version 3: cuts the journal after its last complete line, and before the first line
//    whose files are missing or shorter than it says (only a filesystem that lost
//    synced data can do that); the cut is synced.
// 3. Removes frame files (frame_NNNNNN.png, .jpg, .json) the folder does not list: a frame
//    written but never listed. Files of any other name are left alone.
// A folder without a manifest (a capture killed before its first write) gets step 1 only
// and reports 0 frames. Idempotent.
Result<FolderRecovery> recover_capture_folder(const std::filesystem::path& dir);

}  // namespace camlab::image
