// Depth from a light field's disparities (docs/physics.md, "Light fields"; the geometry is
// light_field.h's).
//
// A point at depth z appears in the view through lens point o shifted by
// -f_px o (1/z - q) from where the central view has it (light_field.h). For each
// candidate inverse depth the views are shifted back by that much (the refocusing shift,
// without the magnification) and compared: where the candidate is the point's depth they agree, and
// their weighted variance across the views, averaged over a window, is least. The
// candidates step the disparity between neighbouring views by at most 1/4 px at the
// outermost view, the least variance is refined by a parabola through it and its two
// neighbours, and the inverse depth is linear in the disparity:
//
//   1/z = q + d / (f_px c),   d the disparity between neighbouring views (px), c the
//                             cell side on the lens (m).
//
// Depth is not defined where the variance does not single out one candidate: a flat,
// untextured window (the central view's variance over it below the noise's), or one
// whose only texture is an edge that the larger shifts bring in (status kDepthFlat,
// depth 0); and a least at either end of the searched range, or one still half the
// window's texture variance (no candidate aligns the views), means the point lies beyond
// the range (kDepthOutOfRange, depth 0): neither is extrapolated. The confidence is how much the
// pixel's own variance (over 3 x 3 px) rises, from the depth found, wherever the outermost view is
// half a pixel or more out of place, against that variance plus what the views' noise alone gives
// (Immerkaer's estimate on the central view): where it hardly rises the pixel's own texture does
// not pin the depth (a window that an edge reaches only at its rim agrees at a wrong depth too),
// and a rival least elsewhere leaves it undecided.
//
// Reentrant.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "analysis/lightfield/light_field.h"
#include "base/result.h"

namespace camlab::analysis::lightfield {

inline constexpr uint8_t kDepthOk = 0;
inline constexpr uint8_t kDepthFlat = 1;
inline constexpr uint8_t kDepthOutOfRange = 2;

struct DepthOptions {
  // The searched depths (m); 0: the range where neighbouring views differ by at most
  // max_view_step_px.
  double near_m = 0, far_m = 0;
  double max_view_step_px = 2.0;
  int window_px = 7;            // box over which the views' variance is averaged (odd)
  double min_confidence = 1.0;  // below it a pixel is flat (confidence below)
};

struct DepthResult {
  cv::Mat depth_m;               // CV_32F, 0 where not kDepthOk
  cv::Mat view_step_px;          // CV_32F: disparity between neighbouring views, 0 where not ok
  cv::Mat confidence;            // CV_32F: (own variance half a pixel off - at the depth) /
                                 // (at the depth + noise)
  cv::Mat status;                // CV_8U: kDepthOk, kDepthFlat, kDepthOutOfRange
  double near_m = 0, far_m = 0;  // searched (far may be infinite)
  int candidates = 0;
  double candidate_step_px = 0;  // between neighbouring views
  double noise_dn = 0;           // the views' noise (Immerkaer), DN
  double ok_share = 0, flat_share = 0, out_of_range_share = 0;
  std::vector<std::string> warnings;
};

// Errors: "unsupported" (one view); "invalid_argument" (window not odd in 3..63, near_m
// not below far_m, max_view_step_px not in (0, 16]); those of refocus_lens_to_sensor_mm
// for near_m and far_m.
Result<DepthResult> estimate_depth(const LightField& light_field, const DepthOptions& options);

}  // namespace camlab::analysis::lightfield
