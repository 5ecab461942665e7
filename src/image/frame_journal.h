// The frames journal of a capture folder (format version 3): `frames.jsonl`, one JSON
// object per line, appended only after the frame's files are on disk. It is the folder's
// list of frames and the one source of truth for it: a frame is in the capture once, and
// only once, its line is complete.
//
//   {"index":0,"image":"frame_000000.png","sidecar":"frame_000000.json","image_bytes":258848,"sidecar_bytes":612}
//
// A process killed mid-append leaves at most one line cut short at the end; readers use
// the complete lines before it and ignore the rest (docs/capture-folder.md).
//
// Reentrant (pure functions).
#pragma once

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "image/capture_folder.h"

namespace camlab::image {

inline constexpr const char* kFrameJournalName = "frames.jsonl";

struct JournalEntry {
  CaptureFrameEntry frame;
  uint64_t image_bytes = 0;    // the size of the image file when it was listed
  uint64_t sidecar_bytes = 0;  // and of its sidecar
};

// One line of the journal, with its newline.
std::string journal_line(const JournalEntry& entry);

struct JournalContents {
  std::vector<JournalEntry> entries;
  std::vector<size_t> line_ends;  // per entry: the offset just past its newline
  size_t valid_bytes = 0;         // the complete, valid lines at the start of the file
  size_t ignored_bytes = 0;       // after them: a line cut short by a crash, or damage
  std::string problem;            // why the ignored bytes were ignored; "" when none were
};

// Reads the lines in order up to the first that is not complete and valid: newline
// ended, a JSON object, its index the line's position, file names plain (inside the
// folder), sizes not negative.
JournalContents parse_frame_journal(std::string_view text);

}  // namespace camlab::image
