// One analysis of a capture folder, as `camlab analyze KIND DIR` and the daemon's
// POST /v1/analyses run it: the measurement (defocus_report.h, exposure_report.h,
// focus_report.h), its JSON report, a text summary, and optionally the plots as PNG:
//   defocus   <target>_coc_vs_n.png (C against N with the fit) or <target>_v_curve.png
//   exposure  photon_transfer.png, linearity.png
//   focus     depth_map.png, all_in_focus.png (display-mapped: 8 bits, 0.1-99.9% of the
//             values stretched, 1/2.2 power), all_in_focus_raw.png (raw DN), focus_curves.png
// The CLI only parses arguments and prints; the daemon calls the same functions.
//
// Reentrant.
#pragma once

#include <atomic>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/defocus/defocus_report.h"
#include "analysis/exposure/exposure_report.h"
#include "analysis/focus/focus_stack.h"
#include "analysis/lensmap/lens_map.h"
#include "analysis/sfr/sfr_image.h"
#include "base/result.h"

namespace camlab::analysis {

struct AnalyzeOptions {
  DefocusOptions defocus;
  ExposureOptions exposure;
  FocusStackOptions focus;
  SfrImageOptions sfr;  // sfr, and the SFR under lensmap
  LensMapOptions lensmap;
  std::filesystem::path plots_dir;  // empty: no plots (sfr and lensmap write none)
  // Set by another thread to stop between frames: analyze() then returns "cancelled".
  const std::atomic<bool>* cancel = nullptr;
};

struct AnalysisRun {
  nlohmann::json report;                     // the JSON report ("kind" says which)
  std::string text;                          // the text summary `camlab analyze` prints
  std::vector<std::filesystem::path> plots;  // written
};

// `kind`: "defocus", "exposure", "focus", "sfr" or "lensmap". Errors: "invalid_argument" (unknown
// kind), the measurement's own errors (e.g. "empty_capture", "no_edge_geometry",
// "too_few_samples"), "io_error" (plots).
Result<AnalysisRun> analyze(std::string_view kind, const std::filesystem::path& capture_dir,
                            const AnalyzeOptions& options);

// analyze() returning only the JSON report (with "plots": the files written, when any):
// the daemon's entry point for POST /v1/analyses.
Result<nlohmann::json> analyze_folder(std::string_view kind,
                                      const std::filesystem::path& capture_dir,
                                      const AnalyzeOptions& options);

// The plots of each report into `dir` (created when missing); returns the files written.
Result<std::vector<std::filesystem::path>> write_defocus_plots(const std::filesystem::path& dir,
                                                               const DefocusReport& report);
Result<std::vector<std::filesystem::path>> write_exposure_plots(const std::filesystem::path& dir,
                                                                const ExposureReport& report);
struct FocusReport;
Result<std::vector<std::filesystem::path>> write_focus_plots(const std::filesystem::path& dir,
                                                             const FocusReport& report);
// The lens map's (its JSON report), per f-number: lensmap_surface_fN.png, the best-focus
// surface over the imager as a heat map with the edges on it (used, and left out), and
// lensmap_through_focus_fN.png, every edge's MTF50 against focus, sagittal and meridional
// apart.
Result<std::vector<std::filesystem::path>> write_lens_map_plots(const std::filesystem::path& dir,
                                                                const nlohmann::json& report);

// The text summaries `camlab analyze` prints.
std::string to_text(const DefocusReport& report);
std::string to_text(const ExposureReport& report);
std::string to_text(const FocusReport& report, int region_px);

}  // namespace camlab::analysis
