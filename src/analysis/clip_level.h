// Where a frame clips, from its own pixels: the pile-up at the top of its histogram.
//
// A sensor whose full well is reached before the ADC's top code clips below the white
// level a format can carry (white_level_dn), and its clipped pixels pile up in a narrow
// spike at the top of the histogram: their spread is the read noise added after the
// clip, where unclipped pixels at that level would spread by their shot noise as well. A
// bright but unclipped flat area puts only its noise tail near the frame's maximum.
//
// The rule: with M the frame's robust maximum (the value below which all but 0.01% of
// pixels lie) and a band of width w = max(2 DN, 0.5% of M - black, 3 sigma_read) below it,
// the frame clips at M - w when at least 1% of its pixels lie in the band, the band is at
// least 5 times denser than the 4w below it, and the values in the band spread by less
// than half the frame's noise. sigma_read is the frame's noise (Immerkaer's estimator), an
// upper bound of the read noise. Data whose noise is the same at every level (Gaussian
// noise alone, no shot noise) cannot show a clip this way: its flat areas spread as much. A frame
// with under 1 DN of noise (a noise-free render) has no tell-tale spread and is never declared
// clipped from its histogram; clipping at the white level is still seen there.
//
// Reentrant: pure functions.
#pragma once

#include <opencv2/core.hpp>
#include <optional>

namespace camlab::analysis {

struct ClipPlateau {
  double level_dn = 0;  // raw DN (black included) from which pixels count as clipped
  double top_dn = 0;    // the robust maximum M
  double mean_dn = 0;   // the plateau's mean: where the sensor clips, read noise aside
  double fraction = 0;  // of the frame's pixels in the plateau
};

// `image` CV_8UC1 or CV_16UC1 raw DN; `black_level_dn` the frame's black.
std::optional<ClipPlateau> detect_clip_plateau(const cv::Mat& image, double black_level_dn);

}  // namespace camlab::analysis
