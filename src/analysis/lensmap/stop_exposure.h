// How evenly a lens map's stops were exposed. Each stop's best foci scatter with its edges'
// noise against their contrast; a sweep taken at one exposure time over f/1.4-5.6 leaves
// f/5.6 four stops under f/1.4 and its surface several times looser than it need be
// (docs/analysis.md, "Lens map"). The lens map says so rather than leave the user to wonder.
//
// Reentrant.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace camlab::analysis {

// Per f-number, the frames' median exposure H ~ exposure_us x gain / N^2 relative to the
// best-exposed f-number's, from an SFR report's frames ("settings": exposure_us, gain,
// f_number): {"f/5.6": 0.0625, ...}. Empty when the frames do not say.
nlohmann::json relative_exposure_by_f_number(const nlohmann::json& sfr_report);

// A warning when the f-numbers' exposures differ by more than half a stop (a factor
// sqrt 2), naming the least exposed one and how to hold the exposure; none otherwise.
std::optional<std::string> unequal_exposure_warning(const nlohmann::json& relative_exposure);

}  // namespace camlab::analysis
