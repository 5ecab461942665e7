// The capture folder: the one on-disk format shared by `camlab render`, camlabd's
// captures and every analysis (docs/capture-folder.md documents it).
//
//   DIR/manifest.json          what the folder holds (kind, source, parameters, files),
//                              and once the capture finished, "complete" and frame_count
//   DIR/frames.jsonl           the frames journal (version 3): one line per frame, appended
//                              once its files are on disk; the list of frames
//   DIR/frame_000000.png       the frame: 8-bit PNG for bit depth <= 8, else 16-bit PNG
//                              holding the raw sensor DN (not rescaled; black level in):
//                              one channel (mono, or the raw Bayer mosaic) or R, G, B
//   DIR/frame_000000.jpg       ... or the JPEG a camera sent, as it was sent
//   DIR/frame_000000.json      its sidecar: sequence, timestamp, settings in effect,
//                              discarded frames, and the truth for virtual frames
//
// Durability (the writer): a frame's image and sidecar are written under their final
// names, then listed in the journal by a commit: one filesystem sync for every frame
// written since the last commit, then their journal lines in one append, then one sync of
// the journal. So a frame listed is complete and on disk, a reader sees a consistent
// folder after a crash at any instant (the files of frames not yet listed are ignored, and
// removed by recover_capture_folder), and the cost per frame does not grow with the
// capture: nothing is rewritten. Version 1 and 2 folders (frames listed in the manifest,
// rewritten after each frame) are still read.
//
// CaptureFolderWriter is thread-bound (one writer per folder); reading is reentrant.
#pragma once

#include <chrono>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "base/transfer_function.h"
#include "base/unique_fd.h"
#include "image/pixel_format.h"
#include "image/png_encoder.h"

namespace camlab::image {

inline constexpr const char* kCaptureFormatName = "camlab-capture";
// Version 2 added colour: Bayer mosaics, RGB frames and JPEG frames (layout, cfa_pattern,
// white_level_dn, linear, delivered_format); version 1 folders read as mono. Version 3
// moved the list of frames from the manifest to the append-only frames journal.
inline constexpr int kCaptureFormatVersion = 3;

std::string_view name_of(FrameLayout layout);  // "mono", "mosaic", "rgb"

// Per-frame metadata. `settings` holds the values really in effect, with units in the
// keys (exposure_us, gain, f_number, focus_position, focus_distance_m, ...); an infinite
// distance is JSON null. `truth` is null for real cameras.
struct FrameSidecar {
  uint64_t sequence = 0;
  int64_t timestamp_ns = 0;
  std::string clock = "monotonic";  // what timestamp_ns counts: "monotonic" or "virtual"
  std::string pixel_format;      // what the stored DN are: "GREY", "Y12", "SRGGB10", "RGB3", "MJPG"
  std::string delivered_format;  // the V4L2 fourcc the camera sent ("pRAA"); "" if unknown
  FrameLayout layout = FrameLayout::kMono;
  std::string cfa_pattern;  // "RGGB", "BGGR", "GRBG", "GBRG" for a mosaic, else ""
  int bit_depth = 8;        // significant bits of the DN
  int black_level_dn = 0;
  // The largest DN the format carries; 0 means full scale, 2^bit_depth - 1 (what every
  // writer means unless the camera clips lower). Always set when read from a folder.
  int white_level_dn = 0;
  bool linear = true;  // false for JPEG frames (lossy) and frames with a curve (transfer)
  // How the DN relate to light above black, as the camera declared it (base/
  // transfer_function.h); frames written before camlab recorded it: linear when `linear`,
  // else other (not decoded).
  TransferFunction transfer = TransferFunction::kLinear;
  int frames_discarded = 0;  // frames dropped before this one while settings settled
  nlohmann::json settings = nlohmann::json::object();
  nlohmann::json labels = nlohmann::json::object();  // e.g. {"sweep_index": 2, "repeat": 1}
  nlohmann::json truth;                              // null, or the virtual camera's ground truth
};

nlohmann::json to_json(const FrameSidecar& sidecar);

// For measurements that read mono, light-linear frames: "not_linear" for JPEG frames and
// frames with a curve, "unsupported" for mosaics and RGB frames, naming `what` ("frame 3
// of DIR").
Status check_mono_linear(const FrameSidecar& sidecar, const std::string& what);
Result<FrameSidecar> frame_sidecar_from_json(const nlohmann::json& json);

struct CaptureFrameEntry {
  int index = 0;
  std::string image_file;    // relative to the folder
  std::string sidecar_file;  // relative to the folder
};

// A name a manifest or journal may give: a file inside the folder (no separators, no "..").
bool is_plain_file_name(const std::string& name);

// When written frames are committed (synced and listed in the journal): after this many
// frames, or once the oldest uncommitted frame is this old, whichever comes first. Both
// bound what a power cut can take (frames never listed) and amortise the two syncs of a
// commit over the frames it lists.
struct CommitPolicy {
  int max_frames = 16;
  std::chrono::milliseconds max_age{250};
};

class CaptureFolderWriter {
 public:
  using Clock = std::chrono::steady_clock;

  // Creates `dir` (which must not exist, or be empty), its manifest and an empty journal.
  // `kind` says what made the capture ("render", "single", "bracket", "focus_stack",
  // "aperture_series", "lens_map"); `source` describes the camera; `parameters` the request.
  static Result<CaptureFolderWriter> create(const std::filesystem::path& dir,
                                            const std::string& kind, const nlohmann::json& source,
                                            const nlohmann::json& parameters,
                                            CommitPolicy policy = {});
  // A writer dropped without finish() commits the frames it wrote (errors ignored): the
  // folder stays readable and says "complete": false.
  ~CaptureFolderWriter();
  CaptureFolderWriter(CaptureFolderWriter&&) noexcept;
  CaptureFolderWriter& operator=(CaptureFolderWriter&&) noexcept;

  // Writes one frame and its sidecar: CV_8UC1 or CV_16UC1 (mono, mosaic) or CV_8UC3 /
  // CV_16UC3 in B, G, R order (rgb), 8 or 16 bits as sidecar.bit_depth says. The frame is
  // listed at the next commit, which this call makes itself when the policy says one is
  // due (its cost then falls in this call).
  Result<CaptureFrameEntry> add_frame(const cv::Mat& image, const FrameSidecar& sidecar);

  // Writes a camera's JPEG frame unchanged (frame_NNNNNN.jpg) and its sidecar, which must
  // say layout rgb and linear false.
  Result<CaptureFrameEntry> add_jpeg_frame(std::span<const uint8_t> jpeg,
                                           const FrameSidecar& sidecar);

  // Makes every frame written so far durable and lists it in the journal (nothing to do
  // when none is waiting). After a failed commit the writer writes nothing more.
  Status commit();
  // When the frames waiting must be committed by the policy; nullopt when none waits.
  std::optional<Clock::time_point> commit_due() const;

  // Adds files outside the frame list (e.g. "truth.cameramodel") to the manifest.
  Status add_file(const std::string& name, std::string_view text);

  // Commits, then marks the capture complete (manifest "complete": true, frame_count).
  Status finish();

  const std::filesystem::path& dir() const { return dir_; }
  // Frames written, listed or not; committed_count() of them are listed.
  int frame_count() const { return static_cast<int>(listed_ + waiting_.size()); }
  int committed_count() const { return static_cast<int>(listed_); }

 private:
  struct Waiting {
    CaptureFrameEntry entry;
    uint64_t image_bytes = 0, sidecar_bytes = 0;
  };
  CaptureFolderWriter() = default;
  Status write_manifest(bool complete);
  Result<CaptureFrameEntry> write_frame(std::span<const uint8_t> encoded, const char* extension,
                                        const FrameSidecar& sidecar, int width, int height);
  Status fail(Error error);

  std::filesystem::path dir_;
  UniqueFd dir_fd_;      // for the commit's sync and the frame files' openat
  UniqueFd journal_fd_;  // frames.jsonl, O_APPEND
  CommitPolicy policy_;
  PngEncoder png_;
  nlohmann::json manifest_;
  size_t listed_ = 0;             // frames in the journal
  std::vector<Waiting> waiting_;  // written, not yet listed
  Clock::time_point oldest_waiting_{};
  std::vector<std::string> extra_files_;
  std::optional<Error> failed_;  // the first write error; nothing is written after it
};

class CaptureFolder {
 public:
  // Reads and validates the manifest (format name and version) and the list of frames:
  // the journal's complete lines (version 3; a line cut short by a crash is ignored, and
  // said in journal_problem()) or the manifest's "frames" (versions 1 and 2). File names
  // must stay inside the folder. A folder that says complete must list frame_count frames.
  static Result<CaptureFolder> open(const std::filesystem::path& dir);

  const std::filesystem::path& dir() const { return dir_; }
  const nlohmann::json& manifest() const { return manifest_; }
  // 0 when the manifest's version is not an integer in 1..999 (open() refuses those).
  int version() const;
  const std::vector<CaptureFrameEntry>& frames() const { return frames_; }
  // false unless the manifest says true (open() refuses a "complete" that is not a boolean).
  bool complete() const;
  // Why bytes at the end of the journal were not read ("" when none were): what a crash
  // mid-append leaves until recover_capture_folder cuts it.
  const std::string& journal_problem() const { return journal_problem_; }

  // The frame as stored: CV_8UC1/CV_16UC1 for mono and mosaic frames, CV_8UC3/CV_16UC3
  // (B, G, R) for rgb frames, JPEG decoded.
  Result<cv::Mat> load_stored_image(int index) const;

  // The frame's single-channel DN image, unchanged, for measurements that read mono
  // frames: refuses ("unsupported") a frame whose sidecar says mosaic or rgb, rather than
  // measure a colour filter pattern as if it were the scene.
  Result<cv::Mat> load_image(int index) const;
  Result<FrameSidecar> load_sidecar(int index) const;

 private:
  std::filesystem::path dir_;
  nlohmann::json manifest_;
  std::vector<CaptureFrameEntry> frames_;
  std::string journal_problem_;
};

// The pixel pitch (um) the folder's manifest records for its camera (the virtual camera's
// spec: source.camera_spec.sensor.pixel_pitch_um), else 0. camlab calibrate --job and
// camlabd's calibrations both take it when no pitch is given.
double manifest_pixel_pitch_um(const CaptureFolder& folder);

}  // namespace camlab::image
