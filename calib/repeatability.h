// How repeatable a calibration is where no truth exists, as mrcal recommends checking it:
//
//   odd/even       the chosen model solved on the odd and on the even views alone, their
//                  projections compared over the central 80% of the imager (the rotation
//                  between the two camera frames fitted out, as mrcal's projection diff
//                  does). Two calibrations of one camera from half the data each: their
//                  difference is what a second session would see, noise and the views'
//                  placement included.
//   leave-one-out  each view predicted by the model solved without it (its pose refitted
//                  with the lens fixed): the RMS of its corners, per view and over all.
//                  A view much worse than the rest is one the others do not explain (a
//                  mislabelled or moved board, a corner detector's slip, a region of the
//                  lens no other view reaches).
//
// Each subset solve starts from the full solution (warm start, one stage), so the pair
// and the n leave-one-out solves cost a fraction of the full solve each; leave-one-out runs
// on up to 4 threads and over at most kMaxLeaveOneOutViews views spread evenly over the
// set.
//
// Reentrant.
#pragma once

#include <array>
#include <atomic>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "base/result.h"
#include "calib/calibration_data.h"
#include "calib/solver.h"

namespace camlab::calib {

inline constexpr int kMaxLeaveOneOutViews = 24;

struct ViewPrediction {
  std::string view;   // its name (the image file)
  double rms_px = 0;  // its corners, predicted by the model fitted without it
};

struct Repeatability {
  // Odd/even; odd_even_ran false (with the reason) under 8 views or when a half failed.
  bool odd_even_ran = false;
  std::string odd_even_reason;
  int odd_views = 0, even_views = 0;
  double odd_even_rms_px = 0, odd_even_max_px = 0;  // projection difference, central 80%
  // Each half's fx and board warp (x2, y2 in m): where the halves differ, these say why
  // (a warp and a focal length that trade on views of too little tilt variety).
  std::array<double, 2> halves_focal_px{};
  std::array<std::array<double, 2>, 2> halves_warp_m{};
  // Leave-one-out; empty under 4 views.
  std::vector<ViewPrediction> left_out;
  double left_out_rms_px = 0;  // over all left-out corners
  double seconds = 0;
};

// {"odd_even": {"ran", "reason"?, "views": [odd, even], "projection_diff_rms_px",
// "projection_diff_max_px", "fx_px": [odd, even], "calobject_warp_m": [[x2, y2] odd,
// even], "region"}, "leave_one_out": {"views",
// "rms_px", "worst": {"view", "rms_px"}, "per_view": [{"view", "rms_px"}]}, "seconds"}
nlohmann::json to_json(const Repeatability& r);
// Two lines for the text report.
std::string to_text(const Repeatability& r);

// Measures both for `full`, a solution on `data` (its model is the one solved again;
// options.lensmodel is ignored). Errors: "cancelled" when options.cancel is set.
Result<Repeatability> measure_repeatability(const CalibrationData& data,
                                            const SolveOptions& options, const Solution& full);

}  // namespace camlab::calib
