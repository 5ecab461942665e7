// The guided calibration loop against random poses, on synthetic views (synthetic_views.h):
// views are added one at a time, each observed through the TRUE lens with Gaussian corner
// noise, the data re-solved by camlab's own loop (calib/guided_loop.h: warm-started from
// the previous solution), and the worst projection uncertainty over the imager's grid at
// a fixed distance compared with a target. The guided loop places the board at each suggestion (the
// suggested pose is the true pose); the random loop takes poses as ViewSetSpec draws them. Shared
// by the view-suggestion test and the guided-calibration benchmark.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <random>
#include <string>
#include <vector>

#include "calib/guided_loop.h"
#include "calib/solver.h"
#include "calib/uncertainty.h"
#include "calib/view_suggestion.h"
#include "synthetic_views.h"

namespace camlab::calib::testing {

struct LoopSpec {
  LensModel truth = wide_opencv8_truth();
  BoardSpec board{10, 7, 0.05};
  double noise_px = 0.08;   // Gaussian sigma per coordinate
  double target_px = 0.5;   // worst-of-grid worst-direction stdev to reach
  double distance_m = 0.7;  // where the uncertainty is evaluated and guided boards are put
  int max_views = 60;       // a run that has not reached the target by then stops
  uint32_t seed = 1;
  // Random poses keep boards partly off the imager (as a ChArUco detector sees them)
  // instead of drawing whole boards only (as a chessboard detector needs).
  bool random_partial = false;
};

struct LoopResult {
  int views = 0;  // views when the target was reached (or max_views)
  bool reached = false;
  double worst_px = 0;            // the last worst-of-grid value
  std::vector<double> suggest_s;  // wall time of each suggestion with a solution (s)
  std::vector<double> worst_history_px;
  std::optional<Solution> solution;  // the last solve with a covariance
};

inline SuggestionOptions loop_suggestion_options(const LoopSpec& spec) {
  SuggestionOptions o;
  o.distance_m = spec.distance_m;
  o.opening_distance_m = spec.distance_m;
  return o;
}

// Solves `data` from scratch the first time, warm-started from `previous` afterwards.
inline Result<Solution> session_solve(const CalibrationData& data, const Solution* previous) {
  SolveOptions o;
  o.lensmodel = "LENSMODEL_OPENCV8";
  if (previous) o.warm_start = session_warm_start(*previous);
  auto s = solve(data, o);
  if (!s && previous) {  // a warm start from a poor early solution: start afresh
    o.warm_start.reset();
    s = solve(data, o);
  }
  return s;
}

inline GuidedLoop make_loop(const LoopSpec& spec) {
  GuidedLoopOptions o;
  o.lensmodel = "LENSMODEL_OPENCV8";
  o.suggestion = loop_suggestion_options(spec);
  return GuidedLoop(std::move(o));
}

// After a view was added (and the loop stepped): the worst of the grid when the loop has a
// solution with a covariance.
inline void record(const CalibrationData& data, const LoopSpec& spec, const GuidedLoop& loop,
                   bool solved, LoopResult* r) {
  r->views = static_cast<int>(data.views.size());
  if (!solved || !loop.coverage()) return;
  r->worst_px = loop.coverage()->worst_of_grid_px;
  r->worst_history_px.push_back(r->worst_px);
  r->reached = r->worst_px < spec.target_px;
}

// camlab's guided loop (calib/guided_loop.h), the board put at each suggestion.
inline LoopResult run_guided(const LoopSpec& spec) {
  std::mt19937 rng(spec.seed);
  CalibrationData data;
  data.board = spec.board;
  data.imager_width_px = spec.truth.width_px;
  data.imager_height_px = spec.truth.height_px;
  GuidedLoop loop = make_loop(spec);
  LoopResult r;
  GuidedStep step = loop.step(data);  // no views: the opening sequence's first
  while (static_cast<int>(data.views.size()) < spec.max_views && !r.reached) {
    if (loop.solution()) r.suggest_s.push_back(step.suggest_s);
    if (!step.suggestion) break;
    data.views.push_back(observe(spec.truth, spec.board, step.suggestion->rt_cam_board,
                                 spec.noise_px, 0, rng,
                                 "guided" + std::to_string(data.views.size())));
    step = loop.step(data);
    record(data, spec, loop, step.solved, &r);
  }
  r.views = static_cast<int>(data.views.size());
  if (loop.solution()) r.solution = *loop.solution();
  return r;
}

inline LoopResult run_random(const LoopSpec& spec) {
  ViewSetSpec draw;
  draw.views = spec.max_views;
  draw.noise_px = spec.noise_px;
  // A chessboard detector needs the whole board: partial views are drawn again.
  draw.keep_partial = spec.random_partial;
  draw.seed = spec.seed;
  const CalibrationData all = make_views(spec.truth, spec.board, draw);
  CalibrationData data = all;
  data.views.clear();
  GuidedLoop loop = make_loop(spec);
  LoopResult r;
  for (const auto& v : all.views) {
    data.views.push_back(v);
    record(data, spec, loop, loop.resolve(data).solved, &r);
    if (r.reached) break;
  }
  r.views = static_cast<int>(data.views.size());
  if (loop.solution()) r.solution = *loop.solution();
  return r;
}

}  // namespace camlab::calib::testing
