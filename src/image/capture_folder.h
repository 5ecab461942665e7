// The capture folder: the one on-disk format shared by `camlab render`, camlabd's
// captures and every analysis (docs/capture-folder.md documents it).
//
//   DIR/manifest.json          what the folder holds (kind, source, parameters, frames)
//   DIR/frame_000000.png       the frame: 8-bit PNG for bit depth <= 8, else 16-bit PNG
//                              holding the raw sensor DN (not rescaled; black level in):
//                              one channel (mono, or the raw Bayer mosaic) or R, G, B
//   DIR/frame_000000.jpg       ... or the JPEG a camera sent, as it was sent
//   DIR/frame_000000.json      its sidecar: sequence, timestamp, settings in effect,
//                              discarded frames, and the truth for virtual frames
//
// Every file is written atomically (temporary file and rename), and the manifest is
// rewritten after each frame, so a capture cut short is still a readable folder whose
// manifest says "complete": false.
//
// CaptureFolderWriter is thread-bound (one writer per folder); reading is reentrant.
#pragma once

#include <cstdint>
#include <filesystem>
#include <span>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "base/result.h"
#include "image/pixel_format.h"

namespace camlab::image {

inline constexpr const char* kCaptureFormatName = "camlab-capture";
// Version 2 added colour: Bayer mosaics, RGB frames and JPEG frames (layout, cfa_pattern,
// white_level_dn, linear, delivered_format); version 1 folders read as mono.
inline constexpr int kCaptureFormatVersion = 2;

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
  bool linear = true;        // false for JPEG frames: gamma-encoded, lossy
  int frames_discarded = 0;  // frames dropped before this one while settings settled
  nlohmann::json settings = nlohmann::json::object();
  nlohmann::json labels = nlohmann::json::object();  // e.g. {"sweep_index": 2, "repeat": 1}
  nlohmann::json truth;                              // null, or the virtual camera's ground truth
};

nlohmann::json to_json(const FrameSidecar& sidecar);

// For measurements that read mono, light-linear frames: "not_linear" for JPEG frames,
// "unsupported" for mosaics and RGB frames, naming `what` ("frame 3 of DIR").
Status check_mono_linear(const FrameSidecar& sidecar, const std::string& what);
Result<FrameSidecar> frame_sidecar_from_json(const nlohmann::json& json);

struct CaptureFrameEntry {
  int index = 0;
  std::string image_file;    // relative to the folder
  std::string sidecar_file;  // relative to the folder
};

class CaptureFolderWriter {
 public:
  // Creates `dir` (which must not exist, or be empty) and writes an initial manifest.
  // `kind` says what made the capture ("render", "single", "bracket", "focus_stack",
  // "aperture_series"); `source` describes the camera; `parameters` the request.
  static Result<CaptureFolderWriter> create(const std::filesystem::path& dir,
                                            const std::string& kind, const nlohmann::json& source,
                                            const nlohmann::json& parameters);

  // Writes one frame and its sidecar: CV_8UC1 or CV_16UC1 (mono, mosaic) or CV_8UC3 /
  // CV_16UC3 in B, G, R order (rgb), 8 or 16 bits as sidecar.bit_depth says.
  Result<CaptureFrameEntry> add_frame(const cv::Mat& image, const FrameSidecar& sidecar);

  // Writes a camera's JPEG frame unchanged (frame_NNNNNN.jpg) and its sidecar, which must
  // say layout rgb and linear false.
  Result<CaptureFrameEntry> add_jpeg_frame(std::span<const uint8_t> jpeg,
                                           const FrameSidecar& sidecar);

  // Adds files outside the frame list (e.g. "truth.cameramodel") to the manifest.
  Status add_file(const std::string& name, std::string_view text);

  // Marks the capture complete.
  Status finish();

  const std::filesystem::path& dir() const { return dir_; }
  int frame_count() const { return static_cast<int>(frames_.size()); }

 private:
  CaptureFolderWriter() = default;
  Status write_manifest(bool complete);
  Result<CaptureFrameEntry> write_frame(std::span<const uint8_t> encoded, const char* extension,
                                        const FrameSidecar& sidecar, int width, int height);

  std::filesystem::path dir_;
  nlohmann::json manifest_;
  std::vector<CaptureFrameEntry> frames_;
  std::vector<std::string> extra_files_;
};

class CaptureFolder {
 public:
  // Reads and validates the manifest (format name and version, frame files named inside
  // the folder only).
  static Result<CaptureFolder> open(const std::filesystem::path& dir);

  const std::filesystem::path& dir() const { return dir_; }
  const nlohmann::json& manifest() const { return manifest_; }
  const std::vector<CaptureFrameEntry>& frames() const { return frames_; }
  bool complete() const { return manifest_.value("complete", false); }

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
};

}  // namespace camlab::image
