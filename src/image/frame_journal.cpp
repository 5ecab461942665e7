#include "image/frame_journal.h"

#include <nlohmann/json.hpp>

namespace camlab::image {

std::string journal_line(const JournalEntry& entry) {
  const nlohmann::json line = {{"index", entry.frame.index},
                               {"image", entry.frame.image_file},
                               {"sidecar", entry.frame.sidecar_file},
                               {"image_bytes", entry.image_bytes},
                               {"sidecar_bytes", entry.sidecar_bytes}};
  return line.dump() + "\n";
}

namespace {

// The entry a line holds, or why it holds none.
std::string parse_line(std::string_view text, int expected_index, JournalEntry* entry) {
  const nlohmann::json line = nlohmann::json::parse(text, nullptr, /*allow_exceptions=*/false);
  if (!line.is_object()) return "not a JSON object";
  auto integer = [&](const char* key, int64_t* out) {
    auto it = line.find(key);
    if (it == line.end() || !it->is_number_integer()) return false;
    *out = it->get<int64_t>();
    return true;
  };
  auto name = [&](const char* key, std::string* out) {
    auto it = line.find(key);
    if (it == line.end() || !it->is_string()) return false;
    *out = it->get<std::string>();
    return is_plain_file_name(*out);
  };
  int64_t index = -1, image_bytes = 0, sidecar_bytes = 0;
  if (!integer("index", &index) || index != expected_index)
    return "its index is not " + std::to_string(expected_index);
  if (!name("image", &entry->frame.image_file) || !name("sidecar", &entry->frame.sidecar_file))
    return "it names a file outside the folder, or none";
  if (!integer("image_bytes", &image_bytes) || !integer("sidecar_bytes", &sidecar_bytes) ||
      image_bytes < 0 || sidecar_bytes < 0)
    return "its file sizes are missing or negative";
  entry->frame.index = static_cast<int>(index);
  entry->image_bytes = static_cast<uint64_t>(image_bytes);
  entry->sidecar_bytes = static_cast<uint64_t>(sidecar_bytes);
  return "";
}

}  // namespace

JournalContents parse_frame_journal(std::string_view text) {
  JournalContents contents;
  size_t at = 0;
  while (at < text.size()) {
    const size_t end = text.find('\n', at);
    const int index = static_cast<int>(contents.entries.size());
    if (end == std::string_view::npos) {
      contents.problem = "line " + std::to_string(index + 1) + " is cut short (no newline)";
      break;
    }
    JournalEntry entry;
    if (std::string why = parse_line(text.substr(at, end - at), index, &entry); !why.empty()) {
      contents.problem = "line " + std::to_string(index + 1) + ": " + why;
      break;
    }
    contents.entries.push_back(std::move(entry));
    at = end + 1;
    contents.line_ends.push_back(at);
  }
  contents.valid_bytes = at;
  contents.ignored_bytes = text.size() - at;
  return contents;
}

}  // namespace camlab::image
