// The joint rig solve (rig_solver.h): single-camera solves, extrinsics chained over shared
// views, one mrcal problem of every camera, and the extrinsics' covariance.
#include "calib/rig/rig_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>

#include <opencv2/core.hpp>

#include "base/cancel.h"
#include "base/format.h"
#include "base/stack_thread.h"
#include "calib/cholmod_sparse.h"
#include "calib/mrcal_api.h"
#include "calib/report.h"
#include "calib/rig/board_labels.h"
#include "calib/rig/rig_joint_solve.h"
#include "calib/rig/rig_problem.h"
#include "calib/solver.h"

namespace camlab::calib {

namespace {

constexpr double kDegPerRad = 180 / M_PI;

mrcal_pose_t to_pose(const Rt& rt) {
  mrcal_pose_t p;
  for (int k = 0; k < 3; ++k) {
    p.r.xyz[k] = rt[k];
    p.t.xyz[k] = rt[3 + k];
  }
  return p;
}

Rt from_pose(const mrcal_pose_t& p) {
  return {p.r.xyz[0], p.r.xyz[1], p.r.xyz[2], p.t.xyz[0], p.t.xyz[1], p.t.xyz[2]};
}

// mrcal's selections for the problem of one lens model (every camera's lensmodels[0]).
mrcal_problem_selections_t one_model_selections(const RigProblem& p) {
  return rig_selections(p.nparams[0], true, p.board_warp, p.reject_outliers);
}

int measurement_count(const RigProblem& p, const BoardSpec& b) {
  return mrcal_num_measurements(static_cast<int>(p.observations.size()), 0, b.cols, b.rows,
                                p.ncameras, p.ncameras - 1, static_cast<int>(p.frames.size()), 0, 0,
                                one_model_selections(p), &p.lensmodels[0]);
}

int state_count(const RigProblem& p) {
  return mrcal_num_states(p.ncameras, p.ncameras - 1, static_cast<int>(p.frames.size()), 0, 0,
                          static_cast<int>(p.observations.size()), one_model_selections(p),
                          &p.lensmodels[0]);
}

// Every camera one model: mrcal_optimize itself, with its outlier rejection.
Status optimize_rig_one_model(RigProblem* p, const BoardSpec& b) {
  const int nx = measurement_count(*p, b);
  p->x.assign(nx, 0.0);
  const mrcal_problem_constants_t constants = {-1.0, -1.0};
  mrcal_stats_t stats{};
  stats.rms_reproj_error__pixels = -1;
  const Status ran = run_with_stack(p->solver_stack_bytes(), [&] {
    stats = mrcal_optimize(nullptr, 0, p->x.data(), nx * static_cast<int>(sizeof(double)),
                           p->intrinsics.data(), p->extrinsics.data(), p->frames.data(), nullptr,
                           &p->warp, p->ncameras, p->ncameras - 1,
                           static_cast<int>(p->frames.size()), 0, 0, p->observations.data(),
                           nullptr, static_cast<int>(p->observations.size()), 0, p->pool.data(),
                           &p->lensmodels[0], p->imagersizes.data(), one_model_selections(*p),
                           &constants, b.spacing_m, b.cols, b.rows, false, false);
  });
  if (!ran) return ran;
  const bool finite = std::isfinite(stats.rms_reproj_error__pixels) &&
                      stats.rms_reproj_error__pixels >= 0 && p->finite_state();
  if (!finite) return make_error("solve_failed", "the joint rig solve did not converge");
  return {};
}

// J^T J and J_obs^T J_obs of the one-model problem, from mrcal_optimizer_callback.
Result<RigInformation> rig_information_one_model(const RigProblem& p, const BoardSpec& b) {
  const mrcal_problem_selections_t sel = one_model_selections(p);
  const int n = p.ncameras;
  const int nobs = static_cast<int>(p.observations.size());
  const int nframes = static_cast<int>(p.frames.size());
  const int nstate = state_count(p);
  const int nmeas = measurement_count(p, b);
  const int nmeas_boards = mrcal_num_measurements_boards(nobs, b.cols, b.rows);
  const int nnz = _mrcal_num_j_nonzero(nobs, 0, b.cols, b.rows, n, n - 1, nframes, 0, 0,
                                       p.observations.data(), nullptr, sel, &p.lensmodels[0]);
  std::vector<double> b_packed(nstate), x(nmeas);
  SparseJacobian j(nstate, nmeas, nnz);
  const mrcal_problem_constants_t constants = {-1.0, -1.0};
  bool evaluated = false;
  const Status ran = run_with_stack(p.solver_stack_bytes(), [&] {
    evaluated = mrcal_optimizer_callback(
        b_packed.data(), nstate * static_cast<int>(sizeof(double)), x.data(),
        nmeas * static_cast<int>(sizeof(double)), &j.jt, p.intrinsics.data(), p.extrinsics.data(),
        p.frames.data(), nullptr, &p.warp, n, n - 1, nframes, 0, 0, p.observations.data(), nullptr,
        nobs, 0, p.pool.data(), &p.lensmodels[0], p.imagersizes.data(), sel, &constants,
        b.spacing_m, b.cols, b.rows, false);
  });
  if (!ran) return ran.error();
  if (!evaluated)
    return make_error("solve_failed", "mrcal_optimizer_callback failed on the solved rig");
  RigInformation info;
  j.information(nmeas_boards, &info.jtj, &info.jobs);
  info.unpack_scale.assign(nstate, 1.0);
  mrcal_unpack_solver_state_vector(info.unpack_scale.data(), n, n - 1, nframes, 0, 0, sel,
                                   &p.lensmodels[0]);
  info.layout.intrinsics_state_at.assign(n, -1);
  info.layout.intrinsics_solved.assign(n, 0);
  info.layout.extrinsics_state_at.assign(n, -1);
  for (int c = 0; c < n; ++c) {
    info.layout.intrinsics_state_at[c] =
        mrcal_state_index_intrinsics(c, n, n - 1, nframes, 0, 0, nobs, sel, &p.lensmodels[0]);
    info.layout.intrinsics_solved[c] = mrcal_num_states_intrinsics(1, sel, &p.lensmodels[0]);
    if (c > 0)
      info.layout.extrinsics_state_at[c] =
          mrcal_state_index_extrinsics(c - 1, n, n - 1, nframes, 0, 0, nobs, sel, &p.lensmodels[0]);
  }
  return info;
}

// sigma^2 (J^T J)^-1 J_obs^T J_obs (J^T J)^-1 in full units (rig_solver.h), with sigma
// from the board residuals of the inliers; returns sigma.
Result<double> rig_state_covariance(const RigProblem& p, const RigInformation& info,
                                    cv::Mat* covariance) {
  const int nstate = info.jtj.rows;
  // The noise: the board measurements of inliers (2 a corner), less the states they fit.
  double sum_sq = 0;
  int inlier_measurements = 0;
  for (size_t k = 0; k < p.pool.size(); ++k)
    if (p.pool[k].z > 0 && !p.missing[k]) {
      sum_sq += p.x[2 * k] * p.x[2 * k] + p.x[2 * k + 1] * p.x[2 * k + 1];
      inlier_measurements += 2;
    }
  const int dof = inlier_measurements - nstate;
  if (dof <= 0)
    return make_error("too_few_views", format_printf("the rig's %d corner coordinates cannot "
                                                     "determine its %d parameters",
                                                     inlier_measurements, nstate));
  const double sigma = std::sqrt(sum_sq / dof);
  cv::Mat inv;
  if (cv::invert(info.jtj, inv, cv::DECOMP_CHOLESKY) == 0)
    return make_error("singular",
                      "J^T J of the rig solve is singular: the views do not determine every "
                      "camera's pose (a camera seen through too few shared views, or motion "
                      "about one axis only)");
  cv::Mat d = cv::Mat::diag(cv::Mat(info.unpack_scale));
  *covariance = sigma * sigma * (d * inv * info.jobs * inv * d);
  return sigma;
}

// The camera centre's distance from camera 0 (the baseline) and its 1-sigma from the
// pose covariance: |c| with c = -R^T t, differentiated numerically (1e-7 rad, 1e-7 m).
std::pair<double, double> baseline_and_sigma(const Rt& rt, const cv::Matx66d& cov) {
  auto length = [](const Rt& p) {
    const Rt inv = invert_rt(p);
    return std::sqrt(inv[3] * inv[3] + inv[4] * inv[4] + inv[5] * inv[5]);
  };
  const double base = length(rt);
  cv::Matx16d grad;
  for (int k = 0; k < 6; ++k) {
    Rt plus = rt, minus = rt;
    plus[k] += 1e-7;
    minus[k] -= 1e-7;
    grad(0, k) = (length(plus) - length(minus)) / 2e-7;
  }
  const double var = (grad * cov * grad.t())(0, 0);
  return {base, std::sqrt(std::max(0.0, var)) * 1000};
}

Status check_data(const RigData& data) {
  const int n = static_cast<int>(data.cameras.size());
  if (n < kRigCamerasMin || n > kRigCamerasMax)
    return make_error("invalid_argument", format_printf("a rig has %d to %d cameras, not %d",
                                                        kRigCamerasMin, kRigCamerasMax, n));
  const CalibrationData& first = data.cameras[0];
  for (int c = 0; c < n; ++c) {
    const CalibrationData& cam = data.cameras[c];
    if (cam.views.size() != first.views.size())
      return make_error("invalid_argument",
                        format_printf("camera %d has %zu views and camera 0 %zu: a rig view is "
                                      "one board pose seen by every camera (or missing)",
                                      c, cam.views.size(), first.views.size()));
    if (cam.board.cols != first.board.cols || cam.board.rows != first.board.rows ||
        cam.board.spacing_m != first.board.spacing_m)
      return make_error("invalid_argument",
                        format_printf("camera %d's board differs from camera 0's: one board "
                                      "moves through the rig",
                                      c));
  }
  return {};
}

}  // namespace

RigData turned_rig_data(const RigData& data, const RigSolution& solution) {
  RigData out = data;
  for (size_t c = 0; c < out.cameras.size() && c < solution.label_turns.size(); ++c)
    for (const auto& [view, q] : solution.label_turns[c])
      out.cameras[c].views[view] = turned_view(out.cameras[c].views[view], out.cameras[c].board, q);
  return out;
}

Result<RigSolution> solve_rig(const RigData& input, const RigSolveOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  if (Status valid = check_data(input); !valid) return valid.error();
  const int n = static_cast<int>(input.cameras.size());
  if (!options.lensmodels.empty() && static_cast<int>(options.lensmodels.size()) != n)
    return make_error("invalid_argument",
                      format_printf("%zu lens models for %d cameras: one a camera, or one for all",
                                    options.lensmodels.size(), n));
  std::vector<std::string> lensmodel_names(n, options.lensmodel);
  if (!options.lensmodels.empty()) lensmodel_names = options.lensmodels;
  std::vector<int> nparams(n);
  for (int c = 0; c < n; ++c) {
    auto count = lensmodel_param_count(lensmodel_names[c]);
    if (!count) return count.error().with_context(format_printf("camera %d: ", c));
    nparams[c] = *count;
  }
  const BoardSpec board = input.cameras[0].board;
  const int per_view = board.cols * board.rows;
  RigSolution out;
  out.board = board;

  // Each camera alone: its lens, its board poses and the corners it rejects.
  std::vector<Solution> single(n);
  std::vector<ViewPoses> poses(n);
  for (int c = 0; c < n; ++c) {
    if (Status go = check_not_cancelled(options.cancel, "rig calibration"); !go) return go.error();
    int seen = 0;
    for (const auto& v : input.cameras[c].views) seen += v.present_count() >= 8;
    if (seen < 3)
      return make_error("too_few_views",
                        format_printf("camera %d sees the board in %d views; a camera of a rig "
                                      "needs at least 3",
                                      c, seen));
    SolveOptions o;
    o.lensmodel = lensmodel_names[c];
    o.reject_outliers = options.reject_outliers;
    o.board_warp = options.board_warp;
    o.compute_covariance = false;
    o.cancel = options.cancel;
    auto s = solve(input.cameras[c], o);
    if (!s) return s.error().with_context(format_printf("camera %d alone: ", c));
    for (size_t k = 0; k < s->views_used.size(); ++k)
      if (k >= s->view_downweighted.size() || !s->view_downweighted[k])
        poses[c][s->views_used[k]] = s->rt_cam_board[k];
    single[c] = std::move(*s);
  }
  // Each camera's data judged as a single camera's would be (report.h): a lens solved from
  // too few, fronto-parallel, centre-only or far boards is no better inside a rig, and its
  // errors reach the extrinsics through the joint solve.
  for (int c = 0; c < n; ++c)
    for (const Warning& w : make_report(input.cameras[c], single[c], 0).warnings)
      if (w.code != "fov_undefined" && w.code != "implausible_intrinsics")
        out.warnings.push_back(
            format_printf("camera %d: %s: %s", c, w.code.c_str(), w.message.c_str()));
  // A splined model's frame is not its optical axis (a turn of the camera trades with its
  // knots, held by mrcal's regularisation only), and that regularisation biases a joint
  // solve: on the 4-camera ring with a 180 deg fisheye (rig_solver_test.cpp) baselines came
  // out 0.4-0.6% long at 60 views, 1.6-1.8 sigma, and 2.6 sigma at 40 views.
  for (int c = 0; c < n; ++c)
    if (lensmodel_names[c].find("SPLINED") != std::string::npos)
      out.warnings.push_back(format_printf(
          "splined_model: camera %d has a splined model: its rotation is in its spline's own "
          "frame, not its optical axis (a turn trades with the knots, held by mrcal's "
          "regularisation only); baselines and triangulated points are what to use, and they "
          "carry a bias of up to about 2 stated sigma; use 60 or more rig views",
          c));
  RigLabelling labelling;
  CAMLAB_ASSIGN(labelling, chain_and_label(&poses, board, &out.warnings));
  const std::vector<Rt>& rt_cam_ref = labelling.rt_cam_ref;
  out.label_turns = labelling.turns;
  // From here on every camera's corners carry one labelling of each view.
  const RigData data = turned_rig_data(input, out);

  // The joint problem, seeded from the single solves.
  RigProblem p;
  p.ncameras = n;
  p.nparams = nparams;
  p.lensmodel_names = lensmodel_names;
  p.board_warp = options.board_warp;
  p.reject_outliers = options.reject_outliers;
  for (int c = 0; c < n; ++c) {
    p.lensmodels.emplace_back();
    mrcal_lensmodel_from_name(&p.lensmodels.back(), lensmodel_names[c].c_str());
    p.intrinsics_at.push_back(static_cast<int>(p.intrinsics.size()));
    p.intrinsics.insert(p.intrinsics.end(), single[c].model.intrinsics.begin(),
                        single[c].model.intrinsics.end());
    p.imagersizes.push_back(data.cameras[c].imager_width_px);
    p.imagersizes.push_back(data.cameras[c].imager_height_px);
    if (c > 0) p.extrinsics.push_back(to_pose(rt_cam_ref[c]));
  }
  p.warp.x2 = single[0].calobject_warp[0];
  p.warp.y2 = single[0].calobject_warp[1];
  std::vector<std::vector<char>> outlier(n);
  for (int c = 0; c < n; ++c) {
    outlier[c].assign(data.cameras[c].views.size() * per_view, 0);
    for (const auto& r : single[c].residuals) {
      if (!r.outlier) continue;
      const auto turn = out.label_turns[c].find(r.view);
      const int corner = turn == out.label_turns[c].end()
                             ? r.corner
                             : turned_corner(board, turn->second, r.corner);
      outlier[c][static_cast<size_t>(r.view) * per_view + corner] = 1;
    }
  }
  std::vector<int> obs_camera;  // per observation
  for (int v = 0; v < static_cast<int>(data.cameras[0].views.size()); ++v) {
    std::vector<Rt> estimates;
    for (int c = 0; c < n; ++c)
      if (auto it = poses[c].find(v); it != poses[c].end())
        estimates.push_back(compose_rt(invert_rt(rt_cam_ref[c]), it->second));
    if (estimates.empty()) continue;
    const int frame = static_cast<int>(p.frames.size());
    p.frames.push_back(to_pose(mean_rt(estimates)));
    out.views_used.push_back(v);
    for (int c = 0; c < n; ++c) {
      if (!poses[c].count(v)) continue;
      mrcal_observation_board_t o{};
      o.icam.intrinsics = static_cast<uint16_t>(c);
      o.icam.extrinsics = static_cast<int16_t>(c - 1);
      o.iframe = frame;
      p.observations.push_back(o);
      obs_camera.push_back(c);
      const auto& corners = data.cameras[c].views[v].corners;
      for (int k = 0; k < per_view; ++k) {
        const CornerObservation& q = corners[k];
        const bool rejected = outlier[c][static_cast<size_t>(v) * per_view + k];
        p.pool.push_back({{q.present ? q.x_px : 0.0, q.present ? q.y_px : 0.0,
                           q.present && !rejected ? q.weight : -1.0}});
        p.missing.push_back(!q.present);
      }
    }
  }
  if (Status go = check_not_cancelled(options.cancel, "rig calibration"); !go) return go.error();
  // One model for all: mrcal_optimize; a model per camera: one mrcal problem a camera,
  // stacked (rig_joint_solve.h).
  RigInformation information;
  if (options.stacked_solve || !p.one_lensmodel()) {
    CAMLAB_ASSIGN(information, optimize_rig_per_camera(&p, board, options.cancel));
  } else {
    if (Status solved = optimize_rig_one_model(&p, board); !solved) return solved.error();
    CAMLAB_ASSIGN(information, rig_information_one_model(p, board));
  }

  // Residuals per camera, the covariance, and the extrinsics' sigmas.
  out.cameras.resize(n);
  std::vector<double> sum_sq(n, 0.0);
  double all_sq = 0;
  int all_inliers = 0;
  for (size_t o = 0; o < p.observations.size(); ++o) {
    RigCamera& cam = out.cameras[obs_camera[o]];
    ++cam.views;
    for (int k = 0; k < per_view; ++k) {
      const size_t i = o * per_view + k;
      if (p.missing[i]) continue;
      if (p.pool[i].z <= 0) {
        ++cam.outliers;
        continue;
      }
      const double dx = p.x[2 * i] / p.pool[i].z, dy = p.x[2 * i + 1] / p.pool[i].z;
      sum_sq[obs_camera[o]] += dx * dx + dy * dy;
      ++cam.inliers;
    }
  }
  cv::Mat covariance;
  CAMLAB_ASSIGN(out.corner_sigma_px, rig_state_covariance(p, information, &covariance));
  // The covariance of every camera's intrinsics and extrinsics (rig_solver.h's layout):
  // each state's index in the solve's vector, -1 for a parameter the solve held.
  std::vector<int> index;
  std::vector<size_t> extrinsics_at(n, 0);  // per camera: its rt_cam_ref's row in the layout
  for (int c = 0; c < n; ++c) {
    const int at = information.layout.intrinsics_state_at[c];
    for (int k = 0; k < nparams[c]; ++k)
      index.push_back(at >= 0 && k < information.layout.intrinsics_solved[c] ? at + k : -1);
  }
  for (int c = 1; c < n; ++c) {
    extrinsics_at[c] = index.size();
    for (int k = 0; k < 6; ++k) index.push_back(information.layout.extrinsics_state_at[c] + k);
  }
  out.parameter_count = static_cast<int>(index.size());
  out.parameter_covariance.assign(index.size() * index.size(), 0.0);
  for (size_t a = 0; a < index.size(); ++a)
    for (size_t b = 0; b < index.size(); ++b)
      if (index[a] >= 0 && index[b] >= 0)
        out.parameter_covariance[a * index.size() + b] = covariance.at<double>(index[a], index[b]);
  for (int c = 0; c < n; ++c) {
    RigCamera& cam = out.cameras[c];
    cam.model.lensmodel = lensmodel_names[c];
    cam.model.intrinsics.assign(p.intrinsics.begin() + p.intrinsics_at[c],
                                p.intrinsics.begin() + p.intrinsics_at[c] + nparams[c]);
    cam.model.width_px = data.cameras[c].imager_width_px;
    cam.model.height_px = data.cameras[c].imager_height_px;
    cam.rms_px = cam.inliers ? std::sqrt(sum_sq[c] / cam.inliers) : 0;
    cam.single_rms_px = single[c].rms_px;
    all_sq += sum_sq[c];
    all_inliers += cam.inliers;
    if (c == 0) continue;
    cam.rt_cam_ref = from_pose(p.extrinsics[c - 1]);
    // Its rt_cam_ref's block of the parameter covariance.
    const size_t at = extrinsics_at[c];
    cv::Matx66d block;
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) {
        block(a, b) = out.parameter_covariance[(at + a) * out.parameter_count + at + b];
        cam.rt_covariance[6 * a + b] = block(a, b);
      }
    for (int k = 0; k < 3; ++k) {
      cam.rotation_sigma_deg[k] = std::sqrt(std::max(0.0, block(k, k))) * kDegPerRad;
      cam.translation_sigma_mm[k] = std::sqrt(std::max(0.0, block(3 + k, 3 + k))) * 1000;
    }
    std::tie(cam.baseline_m, cam.baseline_sigma_mm) = baseline_and_sigma(cam.rt_cam_ref, block);
  }
  out.rms_px = all_inliers ? std::sqrt(all_sq / all_inliers) : 0;
  for (size_t f = 0; f < p.frames.size(); ++f) out.rt_ref_board.push_back(from_pose(p.frames[f]));
  out.calobject_warp = {p.warp.x2, p.warp.y2};
  out.solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace camlab::calib
