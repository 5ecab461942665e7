// The damping loop of Levenberg-Marquardt, shared by the edge fits (edge_spread.cpp,
// edge_pair.cpp), which differ only in their model, their step test and what counts as
// running off. Each iteration solves the damped normal equations for a step; a step that
// lowers the cost is taken and the damping relaxed (/10, down to 1e-12), one that does
// not is refused and the damping raised (x10). Stops when the damping passes 1e12 (no
// short, gradient-like step lowers the cost: the minimum to rounding), when a taken step
// lowers the cost by less than 1e-13 of it or `step_is_small` says so, when `runs_off`
// says the state left the region the model holds in, or after `max_iterations`.
//
//   solve_step(normals, lambda, &step) -> bool    false: no step at this damping
//   evaluate(params) -> Normals                   Normals has a `cost` (sum of squares)
//   step_is_small(step, params) -> bool           after a taken step
//   runs_off(params) -> bool                      after a taken step
//
// Header-only; reentrant.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace camlab::analysis {

struct LmOutcome {
  int iterations = 0;
  bool converged = false;
  bool runaway = false;  // runs_off() stopped it; `converged` may also be set
};

template <class Params, class Normals, class SolveStep, class Evaluate, class StepIsSmall,
          class RunsOff>
LmOutcome levenberg_marquardt_loop(Params* p, Normals* ne, int max_iterations, SolveStep solve_step,
                                   Evaluate evaluate, StepIsSmall step_is_small, RunsOff runs_off) {
  LmOutcome out;
  double lambda = 1e-3;
  while (out.iterations < max_iterations && !out.converged && !out.runaway) {
    ++out.iterations;
    Params step{};
    Normals trial_ne;
    trial_ne.cost = std::numeric_limits<double>::infinity();
    Params trial = *p;
    if (solve_step(*ne, lambda, &step)) {
      for (size_t i = 0; i < trial.size(); ++i) trial[i] += step[i];
      trial_ne = evaluate(trial);
    }
    if (!(trial_ne.cost < ne->cost)) {
      lambda *= 10.0;
      out.converged = lambda > 1e12;
      continue;
    }
    const double decrease = ne->cost - trial_ne.cost;
    *p = trial;
    *ne = trial_ne;
    lambda = std::max(lambda / 10.0, 1e-12);
    out.converged = decrease <= 1e-13 * ne->cost || step_is_small(step, *p);
    out.runaway = runs_off(*p);
  }
  return out;
}

}  // namespace camlab::analysis
