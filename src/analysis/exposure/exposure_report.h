// Exposure analysis of a capture folder (an exposure or gain sweep with repeats >= 2):
// frames grouped by (exposure_us, gain); the first two of a group form the pair for
// photon transfer; the groups' means give the linearity; one frame per group feeds the
// HDR merge (exposure.h). The expected K (spec K x gain) comes from the manifest's camera
// spec when present (conversion_gain_dn_per_e, or its default (2^bits - 1 - black) /
// full well).
//
// Colour captures (Bayer mosaics, linear RGB) are analysed per channel on that channel's
// samples (a mosaic's sites of one colour); JPEG captures are refused ("not_linear").
//
// Reentrant.
#pragma once

#include <atomic>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/exposure/exposure.h"
#include "base/result.h"

namespace camlab::analysis {

struct ExposureOptions {
  double roi_fraction = 0.5;                  // central part of the frame used for statistics
  const std::atomic<bool>* cancel = nullptr;  // set: stop between frames (base/cancel.h)
};

struct ExposureReport {
  int frame_count = 0;
  std::string channel;  // "" for mono captures; "R", "G", "B" for one channel of colour
  std::vector<LinearityPoint> linearity;
  double linearity_slope_dn_per_us = 0;
  double max_linearity_error_pct = 0;
  int linearity_used = 0;
  std::string linearity_error;
  std::optional<PhotonTransfer> photon_transfer;
  std::string photon_transfer_error;
  std::optional<HdrResult> hdr;
  std::string hdr_error;
  std::optional<double> hdr_median_relative_error;  // set by callers that know the truth
  // The lowest clip level found in the frames' histograms (raw DN), when frames clip below
  // their white level (a full well under the ADC's top code; clip_level.h).
  std::optional<double> clip_level_dn;
  // What the fits left out and why, one line per setting ("16000 us x gain 1: saturated,
  // 22.8% of the ROI at the clip level"; "1000 us x gain 1: dark, below 5% of saturation
  // (linearity)"), for the report's summary.
  std::vector<std::string> left_out;
  // Colour captures: one report per channel, on that channel's samples only.
  std::vector<ExposureReport> channels;
};

Result<ExposureReport> analyze_exposure(const std::filesystem::path& capture_dir,
                                        const ExposureOptions& options);

nlohmann::json to_json(const ExposureReport& report);

}  // namespace camlab::analysis
