// A capture folder's frames journal, frames.jsonl (src/image/frame_journal.h): the lines a
// crashed or damaged capture leaves are outside input to every reader of the folder.
#include <cstddef>
#include <cstdint>
#include <string>
#include <string_view>

#include "image/frame_journal.h"
#include "tests/fuzz/fuzz_check.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using camlab::fuzz::check;
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  const auto journal = camlab::image::parse_frame_journal(text);
  check(journal.valid_bytes + journal.ignored_bytes == size, "journal bytes not all accounted");
  check(journal.line_ends.size() == journal.entries.size(), "a line end per entry");
  check(journal.ignored_bytes == 0 || !journal.problem.empty(), "bytes ignored without a reason");
  size_t previous = 0;
  for (size_t i = 0; i < journal.entries.size(); ++i) {
    const auto& frame = journal.entries[i].frame;
    check(frame.index == static_cast<int>(i), "an entry out of order");
    check(camlab::image::is_plain_file_name(frame.image_file), "an image outside the folder");
    check(camlab::image::is_plain_file_name(frame.sidecar_file), "a sidecar outside the folder");
    check(journal.line_ends[i] > previous && journal.line_ends[i] <= journal.valid_bytes,
          "line ends out of order");
    previous = journal.line_ends[i];
  }
  // What was read writes back to lines that read the same.
  std::string written;
  for (const auto& entry : journal.entries) written += camlab::image::journal_line(entry);
  const auto again = camlab::image::parse_frame_journal(written);
  check(again.entries.size() == journal.entries.size() && again.ignored_bytes == 0,
        "the journal does not round-trip");
  for (size_t i = 0; i < again.entries.size(); ++i)
    check(again.entries[i].frame.image_file == journal.entries[i].frame.image_file &&
              again.entries[i].image_bytes == journal.entries[i].image_bytes,
          "a journal line does not round-trip");
  return 0;
}
