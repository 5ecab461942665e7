#include "image/capture_folder_recovery.h"

#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <set>
#include <system_error>

#include "base/atomic_file.h"
#include "base/io_error.h"
#include "base/unique_fd.h"
#include "image/capture_folder.h"
#include "image/frame_journal.h"

namespace camlab::image {

namespace fs = std::filesystem;

namespace {

// "frame_" + six or more digits + ".png", ".jpg" or ".json": the names a writer gives.
bool is_frame_file_name(const std::string& name) {
  if (name.rfind("frame_", 0) != 0) return false;
  const size_t dot = name.find('.', 6);
  if (dot == std::string::npos || dot < 6 + 6) return false;
  for (size_t i = 6; i < dot; ++i)
    if (!std::isdigit(static_cast<unsigned char>(name[i]))) return false;
  const std::string extension = name.substr(dot);
  return extension == ".png" || extension == ".jpg" || extension == ".json";
}

bool has_at_least(const fs::path& path, uint64_t bytes) {
  std::error_code ec;
  const uintmax_t size = fs::file_size(path, ec);
  return !ec && size >= bytes;
}

// Cuts the journal to `keep_bytes` and syncs the cut.
Status cut_journal(const fs::path& path, uint64_t keep_bytes) {
  UniqueFd fd(::open(path.c_str(), O_WRONLY | O_CLOEXEC));
  if (!fd) return io_error(path, "cannot open", errno);
  if (::ftruncate(fd.get(), static_cast<off_t>(keep_bytes)) != 0 || ::fsync(fd.get()) != 0)
    return io_error(path, "cannot cut", errno);
  return {};
}

Result<std::set<std::string>> listed_files_v3(const fs::path& dir, FolderRecovery* recovery) {
  const fs::path path = dir / kFrameJournalName;
  auto text = read_text_file(path);
  if (!text) return text.error();
  JournalContents journal = parse_frame_journal(*text);
  // Every frame listed must be whole: the journal ends before the first that is not.
  size_t kept = 0;
  std::string problem = journal.problem;
  for (const JournalEntry& entry : journal.entries) {
    if (!has_at_least(dir / entry.frame.image_file, entry.image_bytes) ||
        !has_at_least(dir / entry.frame.sidecar_file, entry.sidecar_bytes)) {
      problem = "frame " + std::to_string(entry.frame.index) + "'s files are missing or short";
      break;
    }
    ++kept;
  }
  const uint64_t keep_bytes = kept == 0 ? 0 : journal.line_ends[kept - 1];
  if (keep_bytes < text->size()) {
    if (Status s = cut_journal(path, keep_bytes); !s) return s.error();
    recovery->journal_bytes_cut = text->size() - keep_bytes;
    recovery->journal_problem = problem;
  }
  std::set<std::string> listed;
  for (size_t i = 0; i < kept; ++i) {
    listed.insert(journal.entries[i].frame.image_file);
    listed.insert(journal.entries[i].frame.sidecar_file);
  }
  recovery->frames = static_cast<int>(kept);
  return listed;
}

}  // namespace

Result<FolderRecovery> recover_capture_folder(const fs::path& dir) {
  FolderRecovery recovery;
  auto temporaries = remove_atomic_write_temporaries(dir);
  if (!temporaries) return temporaries.error();
  recovery.removed = std::move(*temporaries);
  std::error_code ec;
  if (!fs::exists(dir / "manifest.json", ec)) return recovery;

  auto folder = CaptureFolder::open(dir);
  if (!folder) return folder.error();
  std::set<std::string> listed;
  if (folder->version() >= 3) {
    auto files = listed_files_v3(dir, &recovery);
    if (!files) return files.error();
    listed = std::move(*files);
  } else {
    for (const auto& f : folder->frames()) {
      listed.insert(f.image_file);
      listed.insert(f.sidecar_file);
    }
    recovery.frames = static_cast<int>(folder->frames().size());
  }

  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!is_frame_file_name(name) || listed.count(name)) continue;
    if (::unlink(it->path().c_str()) != 0) return io_error(it->path(), "cannot remove", errno);
    recovery.removed.push_back(name);
  }
  if (ec) return make_error("io_error", "cannot list " + dir.string() + ": " + ec.message());
  if (!recovery.removed.empty()) {
    UniqueFd dir_fd(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
    if (!dir_fd || ::fsync(dir_fd.get()) != 0) return io_error(dir, "cannot flush folder", errno);
  }
  return recovery;
}

}  // namespace camlab::image
