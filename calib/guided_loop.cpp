#include "calib/guided_loop.h"

#include <chrono>
#include <cmath>

#include "calib/lens_model.h"
#include "calib/library_stderr.h"

namespace camlab::calib {

namespace {

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

bool guided_loop_solves(const std::string& requested_model) {
  return requested_model != "auto" && requested_model.find("SPLINED") == std::string::npos;
}

Result<std::string> guided_loop_model(const std::string& requested_model, int imager_width_px,
                                      int imager_height_px) {
  return configured_lensmodel(
      guided_loop_solves(requested_model) ? requested_model : "LENSMODEL_OPENCV8", imager_width_px,
      imager_height_px, 90);
}

GuidedStep GuidedLoop::step(const CalibrationData& data) {
  GuidedStep out = resolve(data);
  const auto suggest_start = std::chrono::steady_clock::now();
  auto next = suggest_next_view(data, solution(), options_.suggestion);
  if (next)
    out.suggestion = std::move(*next);
  else
    out.suggestion_error = next.error();
  out.suggest_s = seconds_since(suggest_start);
  return out;
}

GuidedStep GuidedLoop::resolve(const CalibrationData& data) {
  GuidedStep out;
  const auto solve_start = std::chrono::steady_clock::now();
  if (data.views.size() < 2) {
    out.solve_error =
        make_error("too_few_views", "a solve needs 2 or more views with the board; " +
                                        std::to_string(data.views.size()) + " so far");
  } else {
    const LibraryStderrCapture quiet_mrcal;
    SolveOptions o;
    o.lensmodel = options_.lensmodel;
    o.focal_guess_px = options_.focal_guess_px;
    o.board_warp = options_.board_warp;
    // Warm: the last solution's poses for the views it had, PnP for the new ones.
    if (solution_) o.warm_start = session_warm_start(*solution_);
    auto solved = solve(data, o);
    if (!solved && solution_) {  // a warm start from a poor early solution: start afresh
      o.warm_start.reset();
      solved = solve(data, o);
    }
    if (!solved) {
      out.solve_error = solved.error();
    } else if (!solved->covariance) {
      out.solve_error = make_error("solve_failed",
                                   "the solve has no covariance, so no "
                                   "uncertainty: " +
                                       solved->covariance_error);
    } else {
      solution_ = std::move(*solved);
      out.solved = true;
      coverage_.reset();
      if (auto c = uncertainty_coverage(*solution_, options_.suggestion); c)
        coverage_ = std::move(*c);
      else
        out.solve_error = c.error();
    }
  }
  out.solve_s = seconds_since(solve_start);
  return out;
}

bool GuidedLoop::target_reached(double target_px) const {
  return coverage_ && std::isfinite(coverage_->worst_of_grid_px) &&
         coverage_->worst_of_grid_px <= target_px;
}

}  // namespace camlab::calib
