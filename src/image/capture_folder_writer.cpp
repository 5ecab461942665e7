// CaptureFolderWriter: frames under their final names, listed in the journal by commits
// (capture_folder.h has the protocol; docs/capture-folder.md the format).
#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <system_error>

#include "base/atomic_file.h"
#include "base/file_mode.h"
#include "base/io_error.h"
#include "image/capture_folder.h"
#include "image/frame_journal.h"
#include "image/jpeg_codec.h"

namespace camlab::image {

namespace fs = std::filesystem;

namespace {

std::string utc_now_iso8601() {
  std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char text[32];
  std::strftime(text, sizeof text, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return text;
}

std::string frame_stem(int index) {
  char stem[32];
  std::snprintf(stem, sizeof stem, "frame_%06d", index);
  return stem;
}

Status write_all(int fd, std::span<const uint8_t> bytes, const fs::path& path) {
  size_t written = 0;
  while (written < bytes.size()) {
    const ssize_t n = ::write(fd, bytes.data() + written, bytes.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n < 0) return io_error(path, "cannot write", errno);
    written += static_cast<size_t>(n);
  }
  return {};
}

std::span<const uint8_t> bytes_of(std::string_view text) {
  return {reinterpret_cast<const uint8_t*>(text.data()), text.size()};
}

// Writes a file that must not exist yet, under its final name. Its write-back starts at
// once, so the commit's sync finds the data mostly on its way to the disk already. A
// partial file (an error here, or a crash) is never listed in the journal.
Status write_new_file(int dir_fd, const fs::path& dir, const std::string& name,
                      std::span<const uint8_t> bytes) {
  UniqueFd fd(::openat(dir_fd, name.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0600));
  // The mode exactly (base/file_mode.h): open's mode argument could only narrow it.
  if (!fd || ::fchmod(fd.get(), data_file_mode()) != 0) {
    const int err = errno;
    if (fd) ::unlinkat(dir_fd, name.c_str(), 0);
    return io_error(dir / name, "cannot create", err);
  }
  if (Status s = write_all(fd.get(), bytes, dir / name); !s) {
    ::unlinkat(dir_fd, name.c_str(), 0);
    return s;
  }
  (void)::sync_file_range(fd.get(), 0, 0, SYNC_FILE_RANGE_WRITE);  // a hint: errors mean none
  return {};
}

}  // namespace

Result<CaptureFolderWriter> CaptureFolderWriter::create(const fs::path& dir,
                                                        const std::string& kind,
                                                        const nlohmann::json& source,
                                                        const nlohmann::json& parameters,
                                                        CommitPolicy policy) {
  std::error_code ec;
  if (fs::exists(dir, ec) && !fs::is_empty(dir, ec))
    return make_error("exists", "output folder " + dir.string() +
                                    " already exists and is not empty; choose another, or "
                                    "remove it first (nothing was overwritten)");
  fs::create_directories(dir, ec);
  if (ec)
    return make_error("io_error", "cannot create folder " + dir.string() + ": " + ec.message());

  CaptureFolderWriter writer;
  writer.dir_ = dir;
  writer.policy_ = policy;
  writer.policy_.max_frames = std::max(policy.max_frames, 1);
  writer.dir_fd_.reset(::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC));
  if (!writer.dir_fd_) return io_error(dir, "cannot open folder", errno);
  writer.manifest_ = {
      {"format", kCaptureFormatName},
      {"version", kCaptureFormatVersion},
      {"kind", kind},
      {"created_utc", utc_now_iso8601()},
      {"source", source},
      {"parameters", parameters},
  };
  // The journal first: a reader takes the manifest as the folder's existence (camlabd lists
  // a running job's frames once it appears), so the journal must be there when it is.
  writer.journal_fd_.reset(::openat(writer.dir_fd_.get(), kFrameJournalName,
                                    O_WRONLY | O_CREAT | O_EXCL | O_APPEND | O_CLOEXEC, 0600));
  if (!writer.journal_fd_ || ::fchmod(writer.journal_fd_.get(), data_file_mode()) != 0)
    return io_error(dir / kFrameJournalName, "cannot create", errno);
  if (Status status = writer.write_manifest(false); !status) return status.error();
  // The manifest's and the journal's names are on disk before any frame is.
  if (::fsync(writer.dir_fd_.get()) != 0) return io_error(dir, "cannot flush folder", errno);
  return writer;
}

CaptureFolderWriter::~CaptureFolderWriter() {
  if (journal_fd_ && !waiting_.empty()) (void)commit();
}

CaptureFolderWriter::CaptureFolderWriter(CaptureFolderWriter&&) noexcept = default;

CaptureFolderWriter& CaptureFolderWriter::operator=(CaptureFolderWriter&& other) noexcept {
  if (this != &other) {
    if (journal_fd_ && !waiting_.empty()) (void)commit();
    dir_ = std::move(other.dir_);
    dir_fd_ = std::move(other.dir_fd_);
    journal_fd_ = std::move(other.journal_fd_);
    policy_ = other.policy_;
    png_ = std::move(other.png_);
    manifest_ = std::move(other.manifest_);
    listed_ = other.listed_;
    waiting_ = std::move(other.waiting_);
    other.waiting_.clear();
    oldest_waiting_ = other.oldest_waiting_;
    extra_files_ = std::move(other.extra_files_);
    failed_ = std::move(other.failed_);
  }
  return *this;
}

Status CaptureFolderWriter::fail(Error error) {
  if (!failed_) failed_ = error;
  return error;
}

Result<CaptureFrameEntry> CaptureFolderWriter::add_frame(const cv::Mat& image,
                                                         const FrameSidecar& sidecar) {
  const int expected_depth = sidecar.bit_depth <= 8 ? CV_8U : CV_16U;
  const int expected_channels = sidecar.layout == FrameLayout::kRgb ? 3 : 1;
  if (image.empty() || image.channels() != expected_channels || image.depth() != expected_depth)
    return make_error("bad_frame",
                      "a " + std::string(name_of(sidecar.layout)) + " frame must be a " +
                          std::to_string(expected_channels) + "-channel " +
                          std::string(expected_depth == CV_8U ? "8" : "16") +
                          "-bit image for bit depth " + std::to_string(sidecar.bit_depth));
  // libdeflate level 1 with the sub filter: the table in docs/BENCHMARKS.md ("Frame
  // writes") has it within 2% of zlib level 1's size in a fifth of the time; higher levels
  // cost 2-50x the time for 1-11% less.
  auto png = png_.encode(image);
  if (!png) return png.error();
  return write_frame(*png, ".png", sidecar, image.cols, image.rows);
}

Result<CaptureFrameEntry> CaptureFolderWriter::add_jpeg_frame(std::span<const uint8_t> jpeg,
                                                              const FrameSidecar& sidecar) {
  if (sidecar.layout != FrameLayout::kRgb || sidecar.linear)
    return make_error("invalid_argument",
                      "a JPEG frame's sidecar must say layout rgb, linear false");
  auto header = read_jpeg_header(jpeg);
  if (!header) return make_error("bad_frame", header.error().message);
  return write_frame(jpeg, ".jpg", sidecar, header->width, header->height);
}

Result<CaptureFrameEntry> CaptureFolderWriter::write_frame(std::span<const uint8_t> encoded,
                                                           const char* extension,
                                                           const FrameSidecar& sidecar, int width,
                                                           int height) {
  if (failed_) return *failed_;
  if (!journal_fd_) return make_error("invalid_argument", "the capture writer was moved from");
  Waiting waiting;
  CaptureFrameEntry& entry = waiting.entry;
  entry.index = frame_count();
  const std::string stem = frame_stem(entry.index);
  entry.image_file = stem + extension;
  entry.sidecar_file = stem + ".json";
  if (Status s = write_new_file(dir_fd_.get(), dir_, entry.image_file, encoded); !s)
    return fail(s.error()).error();

  nlohmann::json sidecar_json = to_json(sidecar);
  sidecar_json["index"] = entry.index;
  sidecar_json["image"] = entry.image_file;
  sidecar_json["width"] = width;
  sidecar_json["height"] = height;
  const std::string sidecar_text = sidecar_json.dump(2) + "\n";
  if (Status s = write_new_file(dir_fd_.get(), dir_, entry.sidecar_file, bytes_of(sidecar_text));
      !s)
    return fail(s.error()).error();
  waiting.image_bytes = encoded.size();
  waiting.sidecar_bytes = sidecar_text.size();

  const auto now = Clock::now();
  if (waiting_.empty()) oldest_waiting_ = now;
  waiting_.push_back(waiting);
  CaptureFrameEntry written = entry;
  if (static_cast<int>(waiting_.size()) >= policy_.max_frames ||
      now - oldest_waiting_ >= policy_.max_age)
    if (Status s = commit(); !s) return s.error();
  return written;
}

Status CaptureFolderWriter::commit() {
  if (failed_) return *failed_;
  if (waiting_.empty()) return {};
  // 1. The frames' files and names reach the disk: one sync of the filesystem for every
  //    frame since the last commit (a sync per file would cost one each).
  if (::syncfs(dir_fd_.get()) != 0)
    return fail(io_error(dir_, "cannot flush the frames of", errno));
  // 2. Then, and only then, they are listed: one append, then one sync of the journal. A
  //    crash in between leaves a line cut short, which readers ignore.
  std::string lines;
  for (const Waiting& w : waiting_)
    lines += journal_line({w.entry, w.image_bytes, w.sidecar_bytes});
  const fs::path journal = dir_ / kFrameJournalName;
  if (Status s = write_all(journal_fd_.get(), bytes_of(lines), journal); !s) return fail(s.error());
  if (::fdatasync(journal_fd_.get()) != 0) return fail(io_error(journal, "cannot flush", errno));
  listed_ += waiting_.size();
  waiting_.clear();
  return {};
}

std::optional<CaptureFolderWriter::Clock::time_point> CaptureFolderWriter::commit_due() const {
  if (waiting_.empty()) return std::nullopt;
  return oldest_waiting_ + policy_.max_age;
}

Status CaptureFolderWriter::add_file(const std::string& name, std::string_view text) {
  if (!is_plain_file_name(name) || name == "manifest.json" || name == kFrameJournalName ||
      name.rfind("frame_", 0) == 0)
    return make_error("invalid_argument", "file name '" + name + "' is not allowed");
  if (Status s = write_file_atomically(dir_ / name, text); !s) return s;
  extra_files_.push_back(name);
  return write_manifest(false);
}

Status CaptureFolderWriter::finish() {
  if (Status s = commit(); !s) return s;
  if (Status s = write_manifest(true); !s) return fail(s.error());
  // The manifest's rename is durable too.
  if (::fsync(dir_fd_.get()) != 0) return fail(io_error(dir_, "cannot flush folder", errno));
  return {};
}

Status CaptureFolderWriter::write_manifest(bool complete) {
  // Small and of fixed size whatever the number of frames: the frames are in the journal.
  manifest_["files"] = extra_files_;
  manifest_["complete"] = complete;
  if (complete) manifest_["frame_count"] = listed_;
  return write_file_atomically(dir_ / "manifest.json", manifest_.dump(2) + "\n");
}

}  // namespace camlab::image
