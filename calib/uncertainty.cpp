// Projection uncertainty: the state covariance from mrcal's Jacobian, and its propagation
// to projections (see the header for the derivation).
#include "calib/uncertainty.h"

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <memory>

#include <opencv2/core.hpp>

#include "base/stack_thread.h"
#include "calib/cholmod_sparse.h"
#include "calib/lens_model.h"
#include "calib/mrcal_problem.h"

namespace camlab::calib {

double PixelCovariance::worst_px() const {
  return std::sqrt(
      std::max(0.0, 0.5 * (xx + yy) + std::sqrt(0.25 * (xx - yy) * (xx - yy) + xy * xy)));
}

double PixelCovariance::rms_px() const { return std::sqrt(std::max(0.0, 0.5 * (xx + yy))); }

Result<PackedInformation> packed_information(const MrcalProblem& p, const BoardSpec& board,
                                             mrcal_problem_selections_t sel) {
  const int nobs = static_cast<int>(p.observations.size());
  const int nframes = static_cast<int>(p.frames.size());
  const int W = board.cols, H = board.rows;
  const int nstate = mrcal_num_states(1, 0, nframes, 0, 0, nobs, sel, &p.lensmodel);
  const int nmeas = mrcal_num_measurements(nobs, 0, W, H, 1, 0, nframes, 0, 0, sel, &p.lensmodel);
  const int nmeas_boards = mrcal_num_measurements_boards(nobs, W, H);
  const int nnz = _mrcal_num_j_nonzero(nobs, 0, W, H, 1, 0, nframes, 0, 0, p.observations.data(),
                                       nullptr, sel, &p.lensmodel);
  std::vector<double> b_packed(nstate);
  SparseJacobian j(nstate, nmeas, nnz);
  PackedInformation info;
  info.nstate = nstate;
  info.x.assign(nmeas, 0.0);
  const mrcal_problem_constants_t constants = {-1.0, -1.0};
  bool evaluated = false;
  if (Status s = run_with_stack(solver_stack_bytes(p),
                                [&] {
                                  evaluated = mrcal_optimizer_callback(
                                      b_packed.data(), nstate * static_cast<int>(sizeof(double)),
                                      info.x.data(), nmeas * static_cast<int>(sizeof(double)),
                                      &j.jt, p.intrinsics.data(), nullptr, p.frames.data(), nullptr,
                                      &p.warp, 1, 0, nframes, 0, 0, p.observations.data(), nullptr,
                                      nobs, 0, p.pool.data(), &p.lensmodel, p.imagersize, sel,
                                      &constants, board.spacing_m, W, H, false);
                                });
      !s)
    return s.error();
  if (!evaluated)
    return make_error("solve_failed", "mrcal_optimizer_callback failed on the solved problem");

  // J^T J over all rows, and J_obs^T J_obs over the board observations' rows.
  j.information(nmeas_boards, &info.jtj, &info.jobs);

  // b = D b*: D from unpacking ones.
  info.unpack.assign(nstate, 1.0);
  mrcal_unpack_solver_state_vector(info.unpack.data(), 1, 0, nframes, 0, 0, sel, &p.lensmodel);

  const int nintr = mrcal_lensmodel_num_params(&p.lensmodel);
  info.intrinsic_index.assign(nintr, -1);
  const int i_intr = mrcal_state_index_intrinsics(0, 1, 0, nframes, 0, 0, nobs, sel, &p.lensmodel);
  if (i_intr >= 0) {
    int k = i_intr;
    for (int j = 0; j < nintr; ++j) {
      const bool core = j < 4;
      if (core ? sel.do_optimize_intrinsics_core : sel.do_optimize_intrinsics_distortions)
        info.intrinsic_index[j] = k++;
    }
  }
  info.frame_index.assign(nframes, -1);
  for (int f = 0; f < nframes; ++f)
    info.frame_index[f] = mrcal_state_index_frames(f, 1, 0, nframes, 0, 0, nobs, sel, &p.lensmodel);
  info.warp_index = mrcal_state_index_calobject_warp(1, 0, nframes, 0, 0, nobs, sel, &p.lensmodel);
  return info;
}

Result<StateCovariance> state_covariance(const MrcalProblem& p, const BoardSpec& board,
                                         mrcal_problem_selections_t sel,
                                         const std::vector<char>& downweighted) {
  PackedInformation info;
  CAMLAB_ASSIGN(info, packed_information(p, board, sel));
  const int nstate = info.nstate;
  const int nframes = static_cast<int>(p.frames.size());
  const std::vector<double>& x = info.x;
  cv::Mat jtj_inv;
  if (cv::invert(info.jtj, jtj_inv, cv::DECOMP_CHOLESKY) == 0)
    return make_error("singular",
                      "J^T J of the solve is singular: the data do not determine every "
                      "parameter, so no projection uncertainty can be given");
  const cv::Mat var_packed = jtj_inv * info.jobs * jtj_inv;  // Var(b*) / sigma^2
  const std::vector<double>& d = info.unpack;

  // Our layout: every intrinsic (the ones not optimised stay 0), then 6 per board.
  const int nintr = static_cast<int>(info.intrinsic_index.size());
  std::vector<int> index(nintr + 6 * nframes, -1);
  std::copy(info.intrinsic_index.begin(), info.intrinsic_index.end(), index.begin());
  for (int f = 0; f < nframes; ++f) {
    const int i0 = info.frame_index[f];
    for (int j = 0; j < 6 && i0 >= 0; ++j) index[nintr + 6 * f + j] = i0 + j;
  }
  StateCovariance c;
  c.n = static_cast<int>(index.size());
  c.values.assign(static_cast<size_t>(c.n) * c.n, 0.0);
  for (int a = 0; a < c.n; ++a) {
    if (index[a] < 0) continue;
    const double* row = var_packed.ptr<double>(index[a]);
    for (int b = 0; b < c.n; ++b)
      if (index[b] >= 0)
        c.values[static_cast<size_t>(a) * c.n + b] = d[index[a]] * row[index[b]] * d[index[b]];
  }
  c.in_reference.resize(nframes);
  for (int f = 0; f < nframes; ++f)
    c.in_reference[f] = f < static_cast<int>(downweighted.size()) ? !downweighted[f] : 1;
  if (std::none_of(c.in_reference.begin(), c.in_reference.end(), [](char v) { return v; }))
    std::fill(c.in_reference.begin(), c.in_reference.end(), 1);

  // sigma from the inlier residuals, with the degrees of freedom the fit used.
  double ss = 0;
  int inliers = 0;
  for (size_t j = 0; j < p.pool.size(); ++j) {
    if (p.pool[j].z <= 0) continue;
    ss += x[2 * j] * x[2 * j] + x[2 * j + 1] * x[2 * j + 1];
    ++inliers;
  }
  c.observed_sigma_px = std::sqrt(ss / std::max(1, 2 * inliers - nstate));
  c.state_count = nstate;
  c.pool_weight.reserve(p.pool.size());
  for (const auto& q : p.pool) c.pool_weight.push_back(q.z);
  c.optimized_core = sel.do_optimize_intrinsics_core;
  c.optimized_distortions = sel.do_optimize_intrinsics_distortions;
  c.optimized_warp = sel.do_optimize_calobject_warp;
  c.regularized = sel.do_apply_regularization;
  return c;
}

namespace {

// dq/db (2 x n, row-major) of the point p_cam (a direction when at_infinity) under the
// mean-frames definition (header).
Result<std::vector<double>> projection_gradient(const Solution& s, const StateCovariance& c,
                                                const double p_cam[3], bool at_infinity) {
  mrcal_lensmodel_t lm;
  if (!mrcal_lensmodel_from_name(&lm, s.model.lensmodel.c_str()))
    return make_error("bad_lensmodel", "unknown lens model '" + s.model.lensmodel + "'");
  const int nintr = static_cast<int>(s.model.intrinsics.size());
  const int nviews = static_cast<int>(s.rt_cam_board.size());
  if (c.n != nintr + 6 * nviews)
    return make_error("no_covariance", "the covariance does not match the solution");
  mrcal_point2_t q;
  mrcal_point3_t dq_dp[2];
  std::vector<double> dq_dintr(2 * nintr);
  const mrcal_point3_t p{{p_cam[0], p_cam[1], p_cam[2]}};
  if (!mrcal_project(&q, dq_dp, dq_dintr.data(), &p, 1, &lm, s.model.intrinsics.data()))
    return make_error("projection_failed", "mrcal could not project the point");
  std::vector<double> g(2 * static_cast<size_t>(c.n), 0.0);
  for (int r = 0; r < 2; ++r)
    for (int j = 0; j < nintr; ++j) g[r * c.n + j] = dq_dintr[r * nintr + j];
  int in_mean = 0;
  for (char v : c.in_reference) in_mean += v != 0;
  for (int f = 0; f < nviews; ++f) {
    if (!c.in_reference[f]) continue;
    const auto& rt = s.rt_cam_board[f];
    double p_frame[3], p_ref[3], dpref[18];  // dpref: 3 x 6 (or 3 x 3 at infinity)
    if (at_infinity) {
      mrcal_rotate_point_r_inverted(p_frame, nullptr, nullptr, rt.data(), p_cam);
      mrcal_rotate_point_r(p_ref, dpref, nullptr, rt.data(), p_frame);
    } else {
      mrcal_transform_point_rt_inverted(p_frame, nullptr, nullptr, rt.data(), p_cam);
      mrcal_transform_point_rt(p_ref, dpref, nullptr, rt.data(), p_frame);
    }
    const int cols = at_infinity ? 3 : 6;
    for (int r = 0; r < 2; ++r)
      for (int j = 0; j < cols; ++j) {
        double v = 0;
        for (int k = 0; k < 3; ++k) v += dq_dp[r].xyz[k] * dpref[k * cols + j];
        g[r * c.n + nintr + 6 * f + j] = v / in_mean;
      }
  }
  return g;
}

PixelCovariance propagate(const std::vector<double>& g, const StateCovariance& c, double sigma) {
  // Var(q) = sigma^2 g C g^T; g is sparse only in the boards' rotations at infinity, so
  // a dense product is simplest (2 n^2 operations).
  double v[2][2] = {{0, 0}, {0, 0}};
  std::vector<double> cg(c.n);
  for (int r = 0; r < 2; ++r) {
    const double* gr = g.data() + static_cast<size_t>(r) * c.n;
    for (int a = 0; a < c.n; ++a) {
      const double* row = c.values.data() + static_cast<size_t>(a) * c.n;
      double sum = 0;
      for (int b = 0; b < c.n; ++b) sum += row[b] * gr[b];
      cg[a] = sum;
    }
    for (int r2 = 0; r2 < 2; ++r2) {
      const double* g2 = g.data() + static_cast<size_t>(r2) * c.n;
      double sum = 0;
      for (int a = 0; a < c.n; ++a) sum += g2[a] * cg[a];
      v[r2][r] = sum;
    }
  }
  const double s2 = sigma * sigma;
  return {s2 * v[0][0], s2 * 0.5 * (v[0][1] + v[1][0]), s2 * v[1][1]};
}

double median_board_distance_m(const Solution& s, const BoardSpec* board) {
  std::vector<double> d;
  for (const auto& rt : s.rt_cam_board) {
    double centre[3] = {0, 0, 0}, p[3];
    if (board) {
      centre[0] = 0.5 * (board->cols - 1) * board->spacing_m;
      centre[1] = 0.5 * (board->rows - 1) * board->spacing_m;
    }
    mrcal_transform_point_rt(p, nullptr, nullptr, rt.data(), centre);
    d.push_back(std::sqrt(p[0] * p[0] + p[1] * p[1] + p[2] * p[2]));
  }
  if (d.empty()) return 0;
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

}  // namespace

double working_distance_m(const Solution& s) {
  return median_board_distance_m(s, s.board.cols > 0 ? &s.board : nullptr);
}

Result<PixelCovariance> projection_uncertainty_of_point(const Solution& s,
                                                        const std::array<double, 3>& p_cam,
                                                        bool at_infinity, double sigma_px) {
  if (!s.covariance)
    return make_error("no_covariance", s.covariance_error.empty() ? "the solve kept no covariance"
                                                                  : s.covariance_error);
  std::vector<double> g;
  CAMLAB_ASSIGN(g, projection_gradient(s, *s.covariance, p_cam.data(), at_infinity));
  return propagate(g, *s.covariance, sigma_px > 0 ? sigma_px : s.covariance->observed_sigma_px);
}

Result<PixelCovariance> projection_uncertainty(const Solution& s, double x_px, double y_px,
                                               double distance_m, double observed_sigma_px) {
  if (!s.covariance)
    return make_error("no_covariance", s.covariance_error.empty() ? "the solve kept no covariance"
                                                                  : s.covariance_error);
  if (!std::isfinite(x_px) || !std::isfinite(y_px) || !(distance_m > 0))
    return make_error("invalid_argument", "the pixel must be finite and the distance > 0");
  auto v = unproject(s.model, {x_px, y_px});
  if (!v) return make_error("projection_failed", v.error().message);
  const bool inf = !std::isfinite(distance_m);
  const double scale = inf ? 1.0 : distance_m;
  return projection_uncertainty_of_point(s, {(*v)[0] * scale, (*v)[1] * scale, (*v)[2] * scale},
                                         inf, observed_sigma_px);
}

Result<UncertaintySummary> summarize_uncertainty(const Solution& s) {
  if (!s.covariance)
    return make_error("no_covariance", s.covariance_error.empty() ? "the solve kept no covariance"
                                                                  : s.covariance_error);
  UncertaintySummary out;
  out.observed_sigma_px = s.covariance->observed_sigma_px;
  out.working_distance_m = working_distance_m(s);
  const double w = s.model.width_px - 1, h = s.model.height_px - 1;
  const struct {
    const char* name;
    double x, y;
  } where[] = {{"centre", 0.5 * w, 0.5 * h},
               {"top_left", 0, 0},
               {"top_right", w, 0},
               {"bottom_left", 0, h},
               {"bottom_right", w, h}};
  for (const auto& wh : where) {
    UncertaintyPoint pt;
    pt.where = wh.name;
    pt.x_px = wh.x;
    pt.y_px = wh.y;
    if (auto u = projection_uncertainty(s, wh.x, wh.y, std::numeric_limits<double>::infinity());
        u.ok())
      pt.at_infinity_px = u->worst_px();
    if (out.working_distance_m > 0)
      if (auto u = projection_uncertainty(s, wh.x, wh.y, out.working_distance_m); u.ok())
        pt.at_working_distance_px = u->worst_px();
    out.points.push_back(pt);
  }
  return out;
}

Result<std::vector<double>> uncertainty_grid(const Solution& s, int cols, int rows,
                                             double distance_m) {
  if (cols < 2 || rows < 2 || cols * rows > 1 << 16)
    return make_error("invalid_argument", "the grid needs 2..65536 points, at least 2 per side");
  if (!s.covariance) return make_error("no_covariance", s.covariance_error);
  std::vector<double> out(static_cast<size_t>(cols) * rows, std::nan(""));
  for (int r = 0; r < rows; ++r)
    for (int k = 0; k < cols; ++k) {
      const double x = k * (s.model.width_px - 1.0) / (cols - 1);
      const double y = r * (s.model.height_px - 1.0) / (rows - 1);
      if (auto u = projection_uncertainty(s, x, y, distance_m); u.ok())
        out[static_cast<size_t>(r) * cols + k] = u->worst_px();
    }
  return out;
}

Result<nlohmann::json> mrcal_optimization_inputs(const CalibrationData& data, const Solution& s) {
  if (!s.covariance) return make_error("no_covariance", "the solve kept no state to export");
  const StateCovariance& c = *s.covariance;
  const int per_view = data.board.cols * data.board.rows;
  if (c.pool_weight.size() != s.views_used.size() * per_view)
    return make_error("no_covariance", "the kept state does not match the solution");
  nlohmann::json obs = nlohmann::json::array(), indices = nlohmann::json::array();
  for (size_t i = 0; i < s.views_used.size(); ++i) {
    const auto& view = data.views[s.views_used[i]];
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < data.board.rows; ++r) {
      nlohmann::json row = nlohmann::json::array();
      for (int k = 0; k < data.board.cols; ++k) {
        const int j = r * data.board.cols + k;
        const auto& cn = view.corners[j];
        const double wgt = c.pool_weight[i * per_view + j];
        row.push_back({cn.present ? cn.x_px : 0.0, cn.present ? cn.y_px : 0.0, wgt});
      }
      rows.push_back(row);
    }
    obs.push_back(rows);
    indices.push_back({static_cast<int>(i), 0, -1});
  }
  nlohmann::json frames = nlohmann::json::array();
  for (const auto& rt : s.rt_cam_board) frames.push_back(rt);
  return nlohmann::json{
      {"lensmodel", s.model.lensmodel},
      {"intrinsics", {s.model.intrinsics}},
      {"frames_rt_toref", frames},
      {"observations_board", obs},
      {"indices_frame_camintrinsics_camextrinsics", indices},
      {"imagersizes", {{s.model.width_px, s.model.height_px}}},
      {"calobject_warp", s.calobject_warp},
      {"calibration_object_spacing", data.board.spacing_m},
      {"do_optimize_intrinsics_core", c.optimized_core},
      {"do_optimize_intrinsics_distortions", c.optimized_distortions},
      {"do_optimize_extrinsics", true},  // no extrinsics: the camera is the reference
      {"do_optimize_frames", true},
      {"do_optimize_calobject_warp", c.optimized_warp},
      {"do_apply_regularization", c.regularized},
      {"do_apply_outlier_rejection", false},
      {"observed_sigma_px", c.observed_sigma_px}};
}

}  // namespace camlab::calib
