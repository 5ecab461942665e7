// What a rig's calibration leaves uncertain in a range it triangulates: a point at a given
// distance on camera 0's optical axis, seen by camera 0 and another camera, is triangulated
// from its two pixels (held exact) through the solved lenses and poses; the range's
// 1-sigma is the calibration's covariance (rig_solver.h, parameter_covariance) carried
// through that triangulation by its numerical gradient, cross terms included. The parts
// from the intrinsics alone (what an uncertainty of the intrinsics, as mrcal 2.2 reports
// it, would give) and from the extrinsics alone are given too: the two are strongly
// correlated (a principal point trades with a rotation between the cameras), so they do
// not add up to the whole, and either alone misstates it (on the test pair at 3 m: 34 mm
// from the intrinsics alone, 3.8 mm in all, and 3.8 mm is what the errors show).
//
// Reentrant.
#pragma once

#include <array>

#include "base/result.h"
#include "calib/rig/rig_solver.h"

namespace camlab::calib {

struct RangeUncertainty {
  double range_m = 0;                     // the point's distance from camera 0
  double triangulated_range_m = 0;        // through the solution (= range_m but for rounding)
  double sigma_mm = 0;                    // 1-sigma from the whole calibration
  double sigma_intrinsics_alone_mm = 0;   // from the intrinsics' covariance alone
  double sigma_extrinsics_alone_mm = 0;   // from the extrinsics' covariance alone
  std::array<double, 2> pixel_camera0{};  // where camera 0 sees the point (px)
  std::array<double, 2> pixel_other{};    // where the other camera sees it (px)
};

// Errors: "out_of_range" (camera not in 1..N-1, range not in (0, 1e5] m, or the point
// outside the other camera's imager), "projection_failed", "no_covariance" (a solution
// without its parameter covariance).
Result<RangeUncertainty> triangulated_range_uncertainty(const RigSolution& solution, int camera,
                                                        double range_m);

// A point matched in camera 0 and another camera, triangulated with its uncertainty: the
// pixels' own noise (pixel_sigma_px per coordinate, carried through by the numerical
// gradient) and, when the solution carries its parameter covariance, the calibration's
// (every parameter of the two cameras, cross terms included, as above). A match whose two
// rays pass far apart (miss_mm, their closest distance) is a wrong match or a wrong
// calibration: the caller judges it against the sigmas.
struct TriangulatedPoint {
  std::array<double, 3> point_m{};  // in camera 0's frame
  double range_m = 0;               // from camera 0's centre
  double miss_mm = 0;               // the two rays' closest distance
  double range_sigma_mm = 0;        // from both parts below
  double range_sigma_pixels_mm = 0;
  double range_sigma_calibration_mm = -1;  // -1: the solution carries no covariance
  std::array<double, 3> point_sigma_mm{};  // per axis of camera 0's frame, both parts
};

// Errors: "out_of_range" (camera not in 1..N-1, a negative pixel sigma),
// "projection_failed" (parallel rays, or a point behind either camera).
Result<TriangulatedPoint> triangulate_point(const RigSolution& solution, int camera,
                                            const std::array<double, 2>& q0,
                                            const std::array<double, 2>& q_other,
                                            double pixel_sigma_px);

// The point where the rays of pixel q0 of camera 0 and pixel q of camera `camera` pass
// closest (their midpoint), in camera 0's frame, through the given lenses and pose.
Result<std::array<double, 3>> triangulate_midpoint(const LensModel& camera0, const LensModel& other,
                                                   const Rt& rt_other_ref,
                                                   const std::array<double, 2>& q0,
                                                   const std::array<double, 2>& q_other);

}  // namespace camlab::calib
