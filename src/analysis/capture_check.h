// Whether a capture is one an analysis can measure, checked before it runs: an exposure
// analysis needs a bracket (two or more exposure x gain settings), a focus analysis a focus
// stack (two or more focus positions), a defocus analysis anything but a bracket (its blur
// is measured per frame, and fitted against the f-number or focus swept). The review ran
// each on the wrong capture and got "max linearity error 0.000% over 0 settings" or an
// empty report with exit status 0.
//
// Reentrant.
#pragma once

#include <string_view>

#include "base/result.h"
#include "image/capture_folder.h"

namespace camlab::analysis {

// Error "invalid_argument" naming the capture the analysis needs and what `folder` holds
// (its kind and the settings it sweeps); the errors of reading its sidecars.
Status check_capture_for(std::string_view analysis, const image::CaptureFolder& folder);

}  // namespace camlab::analysis
