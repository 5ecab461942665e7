// Refocusing after capture by shift-and-add (docs/physics.md, "Light fields"; the
// geometry is light_field.h's).
//
// The image focused at S is the weighted mean of the views, each moved by
// +f_px o (q_r - q) (o its effective lens point) and magnified by alpha = z_r / z_s about
// the principal point, times 1 / alpha^2 (a sensor at z_r gets that much less light): what
// a thin lens with its sensor at z_r records. Each view sees through a cell of the
// aperture, not a point, so a point at S keeps the blur of one cell's spread there:
// f_px (cell side) |q_r - q| pixels, which is also how far it moves between neighbouring
// views (view_step_px). Refocusing is sharp where that is under a pixel (the exact refocus
// range); outside it the result is the thin-lens image blurred by that step, and a warning
// says so.
//
// Synthetic aperture. Weighting each view by the area of its cell inside a disk of
// radius a gives the aperture of radius a out of cells. A point at the distance the views
// were focused at is sharp in every view, so its refocused blur is the views' effective
// lens points, weighted: a is chosen to give them the second moment of a uniform disk of
// the f-number asked for, and effective_f_number reports what they give (f/2.017 for
// all 9 x 9 views of an f/2 capture: the points lack each cell's own spread, which a
// point away from that distance adds back, blurred in each view).
//
// Reentrant.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "analysis/lightfield/light_field.h"
#include "base/result.h"
#include "image/lightfield_folder.h"

namespace camlab::analysis::lightfield {

struct SyntheticAperture {
  std::vector<float> weights;     // per view, summing to 1 (0: not used)
  double f_number = 0;            // asked for (the captured one when none is)
  double effective_f_number = 0;  // of the weighted lens points: f / (2 x 2 sqrt(moment))
  double mask_radius_m = 0;       // the disk the weights are cut from, on the lens
  int views_used = 0;
};

// The views' weights for `f_number` (0: the whole captured aperture). Errors:
// "out_of_range" for an f-number below the captured one (a wider aperture than was
// recorded) or above what the central cells can give, naming both limits.
Result<SyntheticAperture> synthetic_aperture(const image::LightFieldDescription& description,
                                             double f_number);

struct RefocusResult {
  cv::Mat image;  // CV_32F, DN above black, square pixels over the views' lattice
  double focus_m = 0;
  double lens_to_sensor_mm = 0;  // z_r
  double magnification = 1;      // alpha = z_r / z_s
  // How far a point at focus_m moves between neighbouring views: the blur the refocused
  // image keeps there (px).
  double view_step_px = 0;
  // The distances (m) where view_step_px <= 1 (the far one may be infinite).
  std::array<double, 2> sharp_range_m{0, 0};
  double border_px = 0;  // the largest shift: pixels this near the border repeat the edge
  SyntheticAperture aperture;
  std::vector<std::string> warnings;
};

// Errors: those of refocus_lens_to_sensor_mm and synthetic_aperture; "unsupported" for a
// light field of one view (no parallax to refocus with).
Result<RefocusResult> refocus(const LightField& light_field, double focus_m, double f_number = 0);

// The distances at which a light field refocuses sharply (view_step_px <= 1), as
// RefocusResult::sharp_range_m.
std::array<double, 2> sharp_refocus_range_m(const ViewGeometry& geometry);

}  // namespace camlab::analysis::lightfield
