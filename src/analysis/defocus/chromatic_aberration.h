// Longitudinal chromatic aberration from the blur of each colour channel: where each
// channel forms its image of a target, and how far R and B focus from G, in mm at the
// sensor (docs/physics.md, "Longitudinal chromatic aberration").
//
//  - A focus sweep gives each channel's best lens-to-sensor distance directly (its V-curve
//    minimum): the shift is their difference.
//  - An aperture series gives each channel's C x N = k, hence |z_s - z_i| / z_i =
//    k pitch / f: z_i = z_s / (1 + s k pitch / f), with s = +1 when the image lies in front
//    of the sensor (object beyond the focus distance) and -1 behind it. The side s is not
//    in the blur; it comes from the object's distance, or is assumed (and said so).
//
// Reentrant: pure functions.
#pragma once

#include <vector>

#include "analysis/defocus/defocus_report.h"

namespace camlab::analysis {

// `channels`: the R, G and B reports of one capture (any order, by their `channel`).
// Targets fitted in all three channels get an entry; others are left out.
std::vector<ChromaticFocusShift> longitudinal_chromatic_aberration(
    const std::vector<DefocusReport>& channels);

}  // namespace camlab::analysis
