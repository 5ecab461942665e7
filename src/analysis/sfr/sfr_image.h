// `camlab analyze sfr`: the slanted-edge SFR of every straight edge found in a photograph,
// or in each frame of a capture folder (slanted_edge_sfr.h), with each edge's place in the field:
// its orientation relative to the optical centre (taken as the image's centre) and MTF50/30/10 in
// cycles/px and, given the pixel pitch, line pairs/mm.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "analysis/sfr/slanted_edge_sfr.h"
#include "base/result.h"

namespace camlab::analysis {

// The most edges measured in a frame: the longest, when a frame has more.
inline constexpr int kSfrMaxEdges = 1000;

// How a plain image's values relate to light (ISO 12233 measures on linear values: an
// encoded ESF is bent, and MTF50 comes out 10% or more off). auto: 8-bit files are taken
// as sRGB-encoded (what cameras and editors write), 16-bit as linear (raw developers,
// camlab's own frames).
enum class ImageTransfer { kAuto, kLinear, kSrgb };

struct SfrImageOptions {
  SfrOptions sfr;
  ImageTransfer transfer = ImageTransfer::kAuto;  // plain images only (not capture folders)
  double pixel_pitch_um = 0;                      // 0: MTF in cycles/px only
  double min_edge_length_px = 40;                 // edges found shorter than this are not measured
};

struct SfrImageReport {
  nlohmann::json report;  // {"image", "edges": [...], "summary": {...}}
  std::string text;       // the table a person reads
};

// Reads `path` (PNG, JPEG, TIFF...: 8 or 16 bits, grey or colour; colour as its
// luminance), decodes its values to linear by `options.transfer` (the report's
// "transfer" says which, and whether assumed) and measures every edge found. Errors: "bad_image"
// (unreadable, or a depth other than 8/16 bits), "no_edge_geometry" (no straight edge found), and
// slanted_edge_sfr()'s.
Result<SfrImageReport> analyze_sfr_image(const std::string& path, const SfrImageOptions& options);

// Every frame of a capture folder (docs/capture-folder.md), each read as its luminance in
// stored DN: the edges found on the frame where most are found, measured on every frame,
// each frame with its settings (f-number, focus, exposure): MTF50 through focus and
// aperture. Pixels at a frame's white level count as clipped; the pixel pitch, when not
// given, is the capture's camera spec's. Errors: the folder's ("not_a_capture"...),
// "no_frames", "no_edge_geometry".
Result<SfrImageReport> analyze_sfr_folder(const std::filesystem::path& dir,
                                          const SfrImageOptions& options);

// The same on an image already in memory (single channel); `name` labels the report.
Result<SfrImageReport> analyze_sfr(const cv::Mat& image, const std::string& name,
                                   const SfrImageOptions& options);

}  // namespace camlab::analysis
