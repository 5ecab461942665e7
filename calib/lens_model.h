// A fitted lens: mrcal lens model name + intrinsics + imager, and the geometry computed
// from it by projection (FOV by unprojecting the image edges, projection differences).
// Models are compared by what they project, never by coefficients: rational OpenCV
// coefficients are not unique.
//
// Reentrant.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "base/result.h"

namespace camlab::calib {

struct LensModel {
  std::string lensmodel;           // configured mrcal name, e.g. "LENSMODEL_OPENCV8"
  std::vector<double> intrinsics;  // fx, fy, cx, cy (px), then the distortion parameters
  int width_px = 0;
  int height_px = 0;
};

// What a lens model may ask of a solve. A splined model's knots set the size of the
// solve's state (2 parameters a knot): 30 x 20 knots, mrcal's own fisheye example, solves
// 40 views in seconds; 60 x 45 took over 4 minutes and 2000 x 2000 overflowed mrcal's
// stack. The field of view of a stereographic spline stays defined past 180 degrees.
inline constexpr size_t kLensmodelNameMaxChars = 200;
inline constexpr int kSplineOrderMin = 2, kSplineOrderMax = 3;   // quadratic or cubic
inline constexpr int kSplineKnotsMin = 4, kSplineKnotsMax = 40;  // each of Nx, Ny
inline constexpr int kSplineKnotsTotalMax = 900;                 // Nx x Ny
inline constexpr int kSplineFovXDegMin = 10, kSplineFovXDegMax = 300;

// The mrcal parameter count of a (configured) model name; error "bad_lensmodel" for names
// mrcal does not know, CAHVORE, or models without an intrinsics core, and "out_of_range"
// for a splined model beyond the limits above (the message names the limit). Every use of
// a model name in calib/ goes through this check, so no request reaches a solve with one.
Result<int> lensmodel_param_count(const std::string& lensmodel);

// Normalises a user's model name: adds "LENSMODEL_" when missing and, for a bare
// "LENSMODEL_SPLINED_STEREOGRAPHIC", a default configuration (order 3, a 16-knot-wide
// grid with the imager's aspect, fov_x_deg from `fov_x_deg_hint` plus a margin).
Result<std::string> configured_lensmodel(const std::string& name, int width_px, int height_px,
                                         double fov_x_deg_hint);

struct FieldOfView {
  double horizontal_deg = 0;  // between the left and right image edges, through the centre row
  double vertical_deg = 0;
  double diagonal_deg = 0;  // between opposite image corners
};

// FOV by unprojecting the image edges (pixel edges at -0.5 and W - 0.5) through the model.
// Past 180 deg (a fisheye that sees behind its own plane) each FOV is the sum of its two
// edge points' angles off the optical axis.
// Error "unproject_failed" when the model cannot unproject the edges (a polynomial model
// fitted far beyond its data may fold over).
Result<FieldOfView> field_of_view(const LensModel& model);

// Each FOV on its own, where field_of_view() needs all eight edge points: the horizontal
// one needs only the left and right edge midpoints to unproject and project back (within
// 0.01 px), the vertical one the top and bottom midpoints, the diagonal one the four
// corners. A polynomial model fitted to boards that never reached the image corners may
// fold over there while its horizontal and vertical FOV are well defined.
struct FieldOfViewParts {
  std::optional<double> horizontal_deg, vertical_deg, diagonal_deg;
  bool any() const { return horizontal_deg || vertical_deg || diagonal_deg; }
  bool all() const { return horizontal_deg && vertical_deg && diagonal_deg; }
};
Result<FieldOfViewParts> field_of_view_parts(const LensModel& model);

// Projects camera-frame points p (3 per point) to pixels q (2 per point).
Result<std::vector<double>> project(const LensModel& model, const std::vector<double>& p_cam);
// Unprojects pixels q to unit direction vectors (3 per point).
Result<std::vector<double>> unproject(const LensModel& model, const std::vector<double>& q_px);

// Like unproject, but a pixel the model cannot unproject (mrcal's iteration fails near a
// polynomial model's fold) gets a zero vector and valid[i] = 0 instead of failing all.
Result<std::vector<double>> unproject_each(const LensModel& model, const std::vector<double>& q_px,
                                           std::vector<char>* valid);

struct ProjectionDifference {
  double rms_px = 0;
  double max_px = 0;
  int samples = 0;
};

// Pixel difference between two models of one imager over the central `fraction` of it
// (0.8: the central 80% of width and height): each grid pixel is unprojected through `a`
// and projected through `b`. With `fit_rotation` (mrcal's projection_diff does the same),
// the directions are first turned by the rotation that best aligns the two models: two
// calibrations of one camera may place its frame differently by a small rotation, which
// trades with the principal point and is not an error of the lens. Without it, the camera
// frames are taken as identical.
Result<ProjectionDifference> projection_difference(const LensModel& a, const LensModel& b,
                                                   double fraction, int grid = 40,
                                                   bool fit_rotation = true);

}  // namespace camlab::calib
