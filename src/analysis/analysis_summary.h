// The summary every analysis ends with, in camlab's text and in its JSON ("summary"), the
// same from the CLI and camlabd: what it measured, what it left out and why.
//
//   defocus   edge fits measured of all (frames x edges, over colour channels), those left
//             out counted by status (edge/edge_measure.h: clipped, neighbour_overlap, ...), targets
//             with a C = k/N fit and with a V-curve fit;
//   exposure  settings, those in the linearity and the photon transfer fits, and each
//             setting left out with its reason (exposure_report.h's left_out);
//   focus     regions, counted by status (ok, flat, peak at an end), and the share of the
//             depth map that is valid;
//   sfr       edge fits measured of all, those left out counted by status (sfr_image.h);
//   lensmap   f-stops with a best-focus surface, edges used of all through focus, those
//             left out counted by status (lens_map.h).
// Every analysis's summary also carries its text ("text"), for pages that show it as is.
//
// Reentrant: pure functions.
#pragma once

#include <string>

#include <nlohmann/json.hpp>

#include "analysis/defocus/defocus_report.h"
#include "analysis/exposure/exposure_report.h"
#include "analysis/focus/focus_report.h"

namespace camlab::analysis {

nlohmann::json summary_json(const DefocusReport& report);
nlohmann::json summary_json(const ExposureReport& report);
nlohmann::json summary_json(const FocusReport& report);

// One or two lines, "summary: ...", from summary_json's object.
std::string summary_text(const nlohmann::json& summary);

}  // namespace camlab::analysis
