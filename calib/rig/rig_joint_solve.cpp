// A lens model per camera (rig_joint_solve.h): one mrcal problem a camera, stacked, solved
// by Levenberg-Marquardt on mrcal's residuals and Jacobians.
#include "calib/rig/rig_joint_solve.h"

#include <algorithm>
#include <cmath>

#include "base/cancel.h"
#include "base/format.h"
#include "base/stack_thread.h"
#include "calib/cholmod_sparse.h"

namespace camlab::calib {

namespace {

constexpr int kMaxIterations = 200;
constexpr int kMaxRejectionRounds = 5;
constexpr double kOutlierSigmas = 5;

// One camera's mrcal problem: its observations (in the rig's frame order), its selections,
// and where each of its states sits in the stacked state.
struct CameraProblem {
  int camera = 0;
  bool has_extrinsics = false;  // camera 0 is the reference
  std::vector<mrcal_observation_board_t> observations;
  std::vector<int> rig_observation;  // per observation: its index in the rig problem
  mrcal_problem_selections_t sel{};
  int nstate = 0, nmeasurements = 0, nmeasurements_boards = 0, nonzeros = 0;
  int intrinsics_state_at = 0, intrinsics_states = 0;
  std::vector<int> stacked_index;  // per state of this problem
  std::vector<double> unpack_scale;
};

class StackedRig {
 public:
  explicit StackedRig(const BoardSpec& board) : board_(board) {}

  // Places every camera's problem of `p` in the stacked state.
  Status set_up(const RigProblem& p);
  int nstate() const { return nstate_; }
  const RigStateLayout& layout() const { return layout_; }
  const std::vector<double>& unpack_scale() const { return unpack_scale_; }

  // The stacked packed state of `p`'s arrays, and back into a problem's arrays.
  std::vector<double> packed_state(const RigProblem& p) const;
  void write_state(const std::vector<double>& packed, RigProblem* p) const;

  // Evaluates `p` at its arrays: the cost (sum of squared measurements), the board
  // residuals into p->x, J^T x, J^T J (every row) and J_obs^T J_obs (board rows), in
  // packed units.
  struct Evaluation {
    double cost = 0;
    cv::Mat jtx, jtj, jobs;
  };
  Result<Evaluation> evaluate(RigProblem* p) const;

 private:
  BoardSpec board_;
  std::vector<CameraProblem> cameras_;
  int nstate_ = 0, extrinsics_at_ = 0, frames_at_ = 0, warp_at_ = 0;
  RigStateLayout layout_;
  std::vector<double> unpack_scale_;
};

Status StackedRig::set_up(const RigProblem& p) {
  const int n = p.ncameras;
  const int nframes = static_cast<int>(p.frames.size());
  cameras_.resize(n);
  int at = 0;
  layout_.intrinsics_state_at.assign(n, -1);
  layout_.intrinsics_solved.assign(n, 0);
  layout_.extrinsics_state_at.assign(n, -1);
  for (int c = 0; c < n; ++c) {
    CameraProblem& cp = cameras_[c];
    cp.camera = c;
    cp.has_extrinsics = c > 0;
    for (size_t o = 0; o < p.observations.size(); ++o) {
      if (p.observations[o].icam.intrinsics != c) continue;
      mrcal_observation_board_t ob = p.observations[o];
      ob.icam.intrinsics = 0;
      ob.icam.extrinsics = cp.has_extrinsics ? 0 : -1;
      cp.observations.push_back(ob);
      cp.rig_observation.push_back(static_cast<int>(o));
    }
    const mrcal_lensmodel_t* model = &p.lensmodels[c];
    // Outliers are this solve's to reject (the callback never does).
    cp.sel = rig_selections(p.nparams[c], cp.has_extrinsics, p.board_warp, false);
    const int nobs = static_cast<int>(cp.observations.size());
    const int next = cp.has_extrinsics ? 1 : 0;
    cp.nstate = mrcal_num_states(1, next, nframes, 0, 0, nobs, cp.sel, model);
    cp.nmeasurements = mrcal_num_measurements(nobs, 0, board_.cols, board_.rows, 1, next, nframes,
                                              0, 0, cp.sel, model);
    cp.nmeasurements_boards = mrcal_num_measurements_boards(nobs, board_.cols, board_.rows);
    cp.nonzeros = _mrcal_num_j_nonzero(nobs, 0, board_.cols, board_.rows, 1, next, nframes, 0, 0,
                                       cp.observations.data(), nullptr, cp.sel, model);
    cp.intrinsics_state_at =
        mrcal_state_index_intrinsics(0, 1, next, nframes, 0, 0, nobs, cp.sel, model);
    cp.intrinsics_states = mrcal_num_states_intrinsics(1, cp.sel, model);
    layout_.intrinsics_state_at[c] = at;
    layout_.intrinsics_solved[c] = cp.intrinsics_states;
    at += cp.intrinsics_states;
  }
  extrinsics_at_ = at;
  frames_at_ = extrinsics_at_ + 6 * (n - 1);
  warp_at_ = frames_at_ + 6 * nframes;
  nstate_ = warp_at_ + (p.board_warp ? 2 : 0);
  for (int c = 1; c < n; ++c) layout_.extrinsics_state_at[c] = extrinsics_at_ + 6 * (c - 1);
  unpack_scale_.assign(nstate_, 0.0);
  for (CameraProblem& cp : cameras_) {
    const mrcal_lensmodel_t* model = &p.lensmodels[cp.camera];
    const int nobs = static_cast<int>(cp.observations.size());
    const int next = cp.has_extrinsics ? 1 : 0;
    cp.stacked_index.assign(cp.nstate, -1);
    for (int k = 0; k < cp.intrinsics_states; ++k)
      cp.stacked_index[cp.intrinsics_state_at + k] = layout_.intrinsics_state_at[cp.camera] + k;
    if (cp.has_extrinsics) {
      const int e = mrcal_state_index_extrinsics(0, 1, 1, nframes, 0, 0, nobs, cp.sel, model);
      for (int k = 0; k < 6; ++k)
        cp.stacked_index[e + k] = layout_.extrinsics_state_at[cp.camera] + k;
    }
    const int f = mrcal_state_index_frames(0, 1, next, nframes, 0, 0, nobs, cp.sel, model);
    for (int k = 0; k < 6 * nframes; ++k) cp.stacked_index[f + k] = frames_at_ + k;
    if (p.board_warp) {
      const int w = mrcal_state_index_calobject_warp(1, next, nframes, 0, 0, nobs, cp.sel, model);
      for (int k = 0; k < 2; ++k) cp.stacked_index[w + k] = warp_at_ + k;
    }
    if (std::count(cp.stacked_index.begin(), cp.stacked_index.end(), -1) != 0)
      return make_error("solve_failed",
                        format_printf("camera %d: its mrcal problem has states the rig's "
                                      "stacked problem does not place",
                                      cp.camera));
    // The packing scale of shared states (board poses, warp) must agree between the cameras'
    // problems: mrcal's scales depend on the state's kind only, which this checks.
    cp.unpack_scale.assign(cp.nstate, 1.0);
    mrcal_unpack_solver_state_vector(cp.unpack_scale.data(), 1, next, nframes, 0, 0, cp.sel, model);
    for (int k = 0; k < cp.nstate; ++k) {
      double& stacked = unpack_scale_[cp.stacked_index[k]];
      if (stacked != 0 && std::abs(stacked - cp.unpack_scale[k]) > 1e-12 * std::abs(stacked))
        return make_error("solve_failed",
                          "mrcal scales a board pose differently in two cameras' problems");
      stacked = cp.unpack_scale[k];
    }
  }
  if (std::count(unpack_scale_.begin(), unpack_scale_.end(), 0.0) != 0)
    return make_error("solve_failed", "a state of the rig is in no camera's problem");
  return {};
}

std::vector<double> StackedRig::packed_state(const RigProblem& p) const {
  std::vector<double> full(nstate_, 0.0);
  for (int c = 0; c < p.ncameras; ++c)
    for (int k = 0; k < layout_.intrinsics_solved[c]; ++k)
      full[layout_.intrinsics_state_at[c] + k] = p.intrinsics[p.intrinsics_at[c] + k];
  auto put_pose = [&](int at, const mrcal_pose_t& pose) {
    for (int k = 0; k < 3; ++k) {
      full[at + k] = pose.r.xyz[k];
      full[at + 3 + k] = pose.t.xyz[k];
    }
  };
  for (int c = 1; c < p.ncameras; ++c)
    put_pose(layout_.extrinsics_state_at[c], p.extrinsics[c - 1]);
  for (size_t f = 0; f < p.frames.size(); ++f) put_pose(frames_at_ + 6 * f, p.frames[f]);
  if (p.board_warp) {
    full[warp_at_] = p.warp.x2;
    full[warp_at_ + 1] = p.warp.y2;
  }
  for (int k = 0; k < nstate_; ++k) full[k] /= unpack_scale_[k];
  return full;
}

void StackedRig::write_state(const std::vector<double>& packed, RigProblem* p) const {
  std::vector<double> full(nstate_);
  for (int k = 0; k < nstate_; ++k) full[k] = packed[k] * unpack_scale_[k];
  for (int c = 0; c < p->ncameras; ++c)
    for (int k = 0; k < layout_.intrinsics_solved[c]; ++k)
      p->intrinsics[p->intrinsics_at[c] + k] = full[layout_.intrinsics_state_at[c] + k];
  auto get_pose = [&](int at, mrcal_pose_t* pose) {
    for (int k = 0; k < 3; ++k) {
      pose->r.xyz[k] = full[at + k];
      pose->t.xyz[k] = full[at + 3 + k];
    }
  };
  for (int c = 1; c < p->ncameras; ++c)
    get_pose(layout_.extrinsics_state_at[c], &p->extrinsics[c - 1]);
  for (size_t f = 0; f < p->frames.size(); ++f) get_pose(frames_at_ + 6 * f, &p->frames[f]);
  if (p->board_warp) {
    p->warp.x2 = full[warp_at_];
    p->warp.y2 = full[warp_at_ + 1];
  }
}

Result<StackedRig::Evaluation> StackedRig::evaluate(RigProblem* p) const {
  const int per_view = board_.cols * board_.rows;
  const int nframes = static_cast<int>(p->frames.size());
  Evaluation e;
  e.jtx = cv::Mat::zeros(nstate_, 1, CV_64F);
  e.jtj = cv::Mat::zeros(nstate_, nstate_, CV_64F);
  e.jobs = cv::Mat::zeros(nstate_, nstate_, CV_64F);
  p->x.assign(2 * p->pool.size(), 0.0);
  const mrcal_problem_constants_t constants = {-1.0, -1.0};
  for (const CameraProblem& cp : cameras_) {
    const int nobs = static_cast<int>(cp.observations.size());
    std::vector<mrcal_point3_t> pool;
    pool.reserve(static_cast<size_t>(nobs) * per_view);
    for (int o : cp.rig_observation)
      pool.insert(pool.end(), p->pool.begin() + static_cast<size_t>(o) * per_view,
                  p->pool.begin() + static_cast<size_t>(o + 1) * per_view);
    std::vector<double> b_packed(cp.nstate), x(cp.nmeasurements);
    SparseJacobian j(cp.nstate, cp.nmeasurements, cp.nonzeros);
    const mrcal_pose_t* extrinsics = cp.has_extrinsics ? &p->extrinsics[cp.camera - 1] : nullptr;
    const bool evaluated = mrcal_optimizer_callback(
        b_packed.data(), cp.nstate * static_cast<int>(sizeof(double)), x.data(),
        cp.nmeasurements * static_cast<int>(sizeof(double)), &j.jt,
        p->intrinsics.data() + p->intrinsics_at[cp.camera], extrinsics, p->frames.data(), nullptr,
        &p->warp, 1, cp.has_extrinsics ? 1 : 0, nframes, 0, 0, cp.observations.data(), nullptr,
        nobs, 0, pool.data(), &p->lensmodels[cp.camera], &p->imagersizes[2 * cp.camera], cp.sel,
        &constants, board_.spacing_m, board_.cols, board_.rows, false);
    if (!evaluated)
      return make_error("solve_failed",
                        format_printf("mrcal_optimizer_callback failed on camera %d", cp.camera));
    for (double v : x) e.cost += v * v;
    for (int o = 0; o < nobs; ++o)
      std::copy_n(x.begin() + 2 * static_cast<size_t>(o) * per_view, 2 * per_view,
                  p->x.begin() + 2 * static_cast<size_t>(cp.rig_observation[o]) * per_view);
    double* jtx = e.jtx.ptr<double>();
    for (int r = 0; r < cp.nmeasurements; ++r) {
      cv::Mat& information = r < cp.nmeasurements_boards ? e.jobs : e.jtj;
      for (int a = j.row_start[r]; a < j.row_start[r + 1]; ++a) {
        const int row = cp.stacked_index[j.col[a]];
        jtx[row] += j.val[a] * x[r];
        double* out = information.ptr<double>(row);
        for (int b = j.row_start[r]; b < j.row_start[r + 1]; ++b)
          out[cp.stacked_index[j.col[b]]] += j.val[a] * j.val[b];
      }
    }
  }
  e.jtj += e.jobs;
  if (!std::isfinite(e.cost))
    return make_error("solve_failed", "the rig's residuals are not finite");
  return e;
}

// Levenberg-Marquardt from p's state; leaves p at the lowest cost found and returns the
// evaluation there.
Result<StackedRig::Evaluation> levenberg_marquardt(const StackedRig& rig, RigProblem* p,
                                                   const std::atomic<bool>* cancel) {
  std::vector<double> b = rig.packed_state(*p);
  StackedRig::Evaluation now;
  CAMLAB_ASSIGN(now, rig.evaluate(p));
  double lambda = 1e-3;
  for (int iteration = 0; iteration < kMaxIterations; ++iteration) {
    if (Status go = check_not_cancelled(cancel, "rig calibration"); !go) return go.error();
    // Marquardt's scaling: the damping follows each state's own curvature.
    cv::Mat damped = now.jtj.clone();
    double largest = 0;
    for (int k = 0; k < rig.nstate(); ++k) largest = std::max(largest, now.jtj.at<double>(k, k));
    for (int k = 0; k < rig.nstate(); ++k)
      damped.at<double>(k, k) += lambda * std::max(now.jtj.at<double>(k, k), 1e-12 * largest);
    cv::Mat step;
    if (!cv::solve(damped, -now.jtx, step, cv::DECOMP_CHOLESKY)) {
      lambda *= 10;
      if (lambda > 1e12) break;
      continue;
    }
    std::vector<double> tried = b;
    double largest_step = 0;
    for (int k = 0; k < rig.nstate(); ++k) {
      tried[k] += step.at<double>(k);
      largest_step = std::max(largest_step, std::abs(step.at<double>(k)));
    }
    RigProblem candidate = *p;
    rig.write_state(tried, &candidate);
    auto next = rig.evaluate(&candidate);
    if (next.ok() && next->cost < now.cost) {
      const double gain = now.cost - next->cost;
      *p = std::move(candidate);
      b = std::move(tried);
      now = std::move(*next);
      lambda = std::max(lambda / 10, 1e-12);
      if (gain <= 1e-12 * now.cost || largest_step < 1e-12) break;
    } else {
      lambda *= 10;
      if (lambda > 1e12 || largest_step < 1e-14) break;
    }
  }
  return now;
}

// Marks as outliers the inlier corners whose residual exceeds kOutlierSigmas; how many.
int reject_outliers(const StackedRig& rig, RigProblem* p) {
  double sum_sq = 0;
  int coordinates = 0;
  for (size_t k = 0; k < p->pool.size(); ++k)
    if (p->pool[k].z > 0 && !p->missing[k]) {
      sum_sq += p->x[2 * k] * p->x[2 * k] + p->x[2 * k + 1] * p->x[2 * k + 1];
      coordinates += 2;
    }
  if (coordinates <= rig.nstate()) return 0;
  const double variance = sum_sq / (coordinates - rig.nstate());
  int rejected = 0;
  for (size_t k = 0; k < p->pool.size(); ++k) {
    if (p->pool[k].z <= 0 || p->missing[k]) continue;
    const double sq = p->x[2 * k] * p->x[2 * k] + p->x[2 * k + 1] * p->x[2 * k + 1];
    if (sq > kOutlierSigmas * kOutlierSigmas * variance) {
      p->pool[k].z = -1;
      ++rejected;
    }
  }
  return rejected;
}

}  // namespace

Result<RigInformation> optimize_rig_per_camera(RigProblem* p, const BoardSpec& board,
                                               const std::atomic<bool>* cancel) {
  StackedRig rig(board);
  if (Status ready = rig.set_up(*p); !ready) return ready.error();
  Result<StackedRig::Evaluation> solved = make_error("solve_failed", "not solved");
  const Status ran = run_with_stack(p->solver_stack_bytes(), [&] {
    for (int round = 0; round < kMaxRejectionRounds; ++round) {
      solved = levenberg_marquardt(rig, p, cancel);
      if (!solved || !p->reject_outliers || reject_outliers(rig, p) == 0) return;
    }
    solved = levenberg_marquardt(rig, p, cancel);
  });
  if (!ran) return ran.error();
  if (!solved) return solved.error();
  if (!p->finite_state()) return make_error("solve_failed", "the joint rig solve did not converge");
  return RigInformation{solved->jtj, solved->jobs, rig.unpack_scale(), rig.layout()};
}

}  // namespace camlab::calib
