// `camlab analyze sfr`: the slanted-edge SFR of every straight edge found in a photograph
// or a frame (slanted_edge_sfr.h), with each edge's place in the field: its orientation
// relative to the optical centre (taken as the image's centre) and MTF50/30/10 in
// cycles/px and, given the pixel pitch, line pairs/mm.
//
// Reentrant.
#pragma once

#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "analysis/sfr/slanted_edge_sfr.h"
#include "base/result.h"

namespace camlab::analysis {

struct SfrImageOptions {
  SfrOptions sfr;
  double pixel_pitch_um = 0;       // 0: MTF in cycles/px only
  double min_edge_length_px = 40;  // edges found shorter than this are not measured
};

struct SfrImageReport {
  nlohmann::json report;  // {"image", "edges": [...], "summary": {...}}
  std::string text;       // the table a person reads
};

// Reads `path` (PNG, JPEG, TIFF...: 8 or 16 bits, grey or colour; colour as its
// luminance) and measures every edge found. Errors: "bad_image" (unreadable, or a depth
// other than 8/16 bits), "no_edge_geometry" (no straight edge found), and
// slanted_edge_sfr()'s.
Result<SfrImageReport> analyze_sfr_image(const std::string& path, const SfrImageOptions& options);

// The same on an image already in memory (single channel); `name` labels the report.
Result<SfrImageReport> analyze_sfr(const cv::Mat& image, const std::string& name,
                                   const SfrImageOptions& options);

}  // namespace camlab::analysis
