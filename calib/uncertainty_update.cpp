// The projection uncertainty with one more view (see the header for the derivation).
#include "calib/uncertainty_update.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "calib/uncertainty.h"

namespace camlab::calib {

Result<MrcalProblem> solved_problem(const CalibrationData& data, const Solution& s,
                                    const AddedView* extra, mrcal_problem_selections_t* sel) {
  if (!s.covariance)
    return make_error("no_covariance", s.covariance_error.empty() ? "the solve kept no covariance"
                                                                  : s.covariance_error);
  const int per_view = data.board.cols * data.board.rows;
  const bool same_board = s.board.cols == data.board.cols && s.board.rows == data.board.rows &&
                          s.board.spacing_m == data.board.spacing_m;
  if (!same_board || s.model.width_px != data.imager_width_px ||
      s.model.height_px != data.imager_height_px ||
      s.covariance->pool_weight.size() != s.views_used.size() * per_view ||
      s.rt_cam_board.size() != s.views_used.size() ||
      std::any_of(s.views_used.begin(), s.views_used.end(), [&](int v) {
        return v < 0 || v >= static_cast<int>(data.views.size()) ||
               static_cast<int>(data.views[v].corners.size()) != per_view;
      }))
    return make_error("invalid_argument",
                      "the solution is not of these data (board, imager or views differ)");
  MrcalProblem p = make_mrcal_problem(data, s.views_used);
  if (!mrcal_lensmodel_from_name(&p.lensmodel, s.model.lensmodel.c_str()) ||
      static_cast<int>(s.model.intrinsics.size()) != mrcal_lensmodel_num_params(&p.lensmodel))
    return make_error("bad_lensmodel", "the solution's lens model '" + s.model.lensmodel +
                                           "' does not match its intrinsics");
  p.intrinsics = s.model.intrinsics;
  for (size_t i = 0; i < s.rt_cam_board.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      p.frames[i].r.xyz[k] = s.rt_cam_board[i][k];
      p.frames[i].t.xyz[k] = s.rt_cam_board[i][3 + k];
    }
  for (size_t j = 0; j < p.pool.size(); ++j) p.pool[j].z = s.covariance->pool_weight[j];
  p.warp.x2 = s.calobject_warp[0];
  p.warp.y2 = s.calobject_warp[1];
  if (extra) {
    if (extra->visible.size() != static_cast<size_t>(per_view) ||
        extra->corners_px.size() != 2 * extra->visible.size())
      return make_error("invalid_argument", "the added view's corners do not match the board");
    mrcal_observation_board_t o{};
    o.icam.intrinsics = 0;
    o.icam.extrinsics = -1;
    o.iframe = static_cast<int>(p.frames.size());
    p.observations.push_back(o);
    mrcal_pose_t pose;
    for (int k = 0; k < 3; ++k) {
      pose.r.xyz[k] = extra->rt_cam_board[k];
      pose.t.xyz[k] = extra->rt_cam_board[3 + k];
    }
    p.frames.push_back(pose);
    for (size_t k = 0; k < extra->visible.size(); ++k) {
      mrcal_point3_t q;
      q.x = extra->visible[k] ? extra->corners_px[2 * k] : 0.0;
      q.y = extra->visible[k] ? extra->corners_px[2 * k + 1] : 0.0;
      q.z = extra->visible[k] ? 1.0 : -1.0;
      p.pool.push_back(q);
      p.missing.push_back(extra->visible[k] ? 0 : 1);
    }
  }
  *sel = mrcal_selections(s.covariance->optimized_core, s.covariance->optimized_distortions,
                          s.covariance->optimized_warp, s.covariance->regularized, false);
  return p;
}

Result<UncertaintyPredictor> UncertaintyPredictor::make(const CalibrationData& data,
                                                        const Solution& solution) {
  UncertaintyPredictor u;
  u.data_ = &data;
  u.solution_ = &solution;
  // A placeholder frame for the added view, none of its corners observed: it gives no
  // rows, but the problem's measurement count (mrcal scales its regularization by it) is
  // that of the problem with the view.
  AddedView placeholder;
  placeholder.rt_cam_board = {0, 0, 0, 0, 0, 1};
  placeholder.visible.assign(static_cast<size_t>(data.board.cols) * data.board.rows, 0);
  placeholder.corners_px.assign(2 * placeholder.visible.size(), 0.0);
  CAMLAB_ASSIGN(u.problem_, solved_problem(data, solution, &placeholder, &u.sel_));
  CAMLAB_ASSIGN(u.info_, packed_information(u.problem_, data.board, u.sel_));
  return u;
}

namespace {

// d(rt p_frame)/d rt (3 x 6, row-major) at p_frame = rt^-1 p: the derivative of the
// point p carried into a board's frame and back through a perturbed pose.
void pose_derivative(const std::array<double, 6>& rt, const double p[3], double out[18]) {
  double p_frame[3], p_ref[3];
  mrcal_transform_point_rt_inverted(p_frame, nullptr, nullptr, rt.data(), p);
  mrcal_transform_point_rt(p_ref, out, nullptr, rt.data(), p_frame);
}

}  // namespace

Result<std::vector<double>> UncertaintyPredictor::worst_px_with(
    const AddedView& view, const std::vector<std::array<double, 3>>& points) const {
  const BoardSpec& board = data_->board;
  // The view's own rows: mrcal's callback on the problem of that view alone.
  MrcalProblem one;
  one.lensmodel = problem_.lensmodel;
  one.intrinsics = problem_.intrinsics;
  one.warp = problem_.warp;
  one.imagersize[0] = problem_.imagersize[0];
  one.imagersize[1] = problem_.imagersize[1];
  mrcal_observation_board_t o{};
  o.icam.intrinsics = 0;
  o.icam.extrinsics = -1;
  o.iframe = 0;
  one.observations.push_back(o);
  mrcal_pose_t pose;
  for (int k = 0; k < 3; ++k) {
    pose.r.xyz[k] = view.rt_cam_board[k];
    pose.t.xyz[k] = view.rt_cam_board[3 + k];
  }
  one.frames.push_back(pose);
  for (size_t k = 0; k < view.visible.size(); ++k)
    one.pool.push_back(
        {{view.visible[k] ? view.corners_px[2 * k] : 0.0,
          view.visible[k] ? view.corners_px[2 * k + 1] : 0.0, view.visible[k] ? 1.0 : -1.0}});
  PackedInformation c;
  CAMLAB_ASSIGN(c, packed_information(one, board, sel_));

  // The view's packed state mapped into the solved problem's, its pose at the
  // placeholder's.
  const int m = info_.nstate;
  const int slot = info_.frame_index.back();
  const std::vector<double>& unpack = info_.unpack;
  std::vector<int> to(c.nstate, -1);
  for (size_t j = 0; j < c.intrinsic_index.size(); ++j)
    if (c.intrinsic_index[j] >= 0) to[c.intrinsic_index[j]] = info_.intrinsic_index[j];
  if (c.warp_index >= 0 && info_.warp_index >= 0)
    for (int k = 0; k < 2; ++k) to[c.warp_index + k] = info_.warp_index + k;
  for (int k = 0; k < 6; ++k) to[c.frame_index[0] + k] = slot + k;
  cv::Mat a = info_.jtj.clone(), b = info_.jobs.clone();
  // J_packed = J_full D, so rows packed with the one-view D_c become ours by D / D_c.
  for (int i = 0; i < c.nstate; ++i) {
    if (to[i] < 0) continue;
    const double si = unpack[to[i]] / c.unpack[i];
    for (int j = 0; j < c.nstate; ++j) {
      if (to[j] < 0) continue;
      const double v = c.jobs.at<double>(i, j) * si * unpack[to[j]] / c.unpack[j];
      a.at<double>(to[i], to[j]) += v;
      b.at<double>(to[i], to[j]) += v;
    }
  }

  // L: z = [intrinsics, Omega, dT] from the packed state (rows), scaled by D.
  const int nintr = static_cast<int>(info_.intrinsic_index.size());
  const int r = nintr + 6;
  cv::Mat lt = cv::Mat::zeros(m, r, CV_64F);  // L^T
  for (int j = 0; j < nintr; ++j)
    if (info_.intrinsic_index[j] >= 0)
      lt.at<double>(info_.intrinsic_index[j], j) = unpack[info_.intrinsic_index[j]];
  const StateCovariance& cov = *solution_->covariance;
  std::vector<const std::array<double, 6>*> frames;
  std::vector<int> first_index;
  for (size_t f = 0; f < solution_->rt_cam_board.size(); ++f) {
    if (f < cov.in_reference.size() && !cov.in_reference[f]) continue;
    if (info_.frame_index[f] < 0) continue;
    frames.push_back(&solution_->rt_cam_board[f]);
    first_index.push_back(info_.frame_index[f]);
  }
  frames.push_back(&view.rt_cam_board);
  first_index.push_back(slot);
  const double inv_n = 1.0 / frames.size();
  const double origin[3] = {0, 0, 0}, ex[3] = {1, 0, 0}, ey[3] = {0, 1, 0}, ez[3] = {0, 0, 1};
  for (size_t f = 0; f < frames.size(); ++f) {
    double g0[18], gx[18], gy[18], gz[18];
    pose_derivative(*frames[f], origin, g0);
    pose_derivative(*frames[f], ex, gx);
    pose_derivative(*frames[f], ey, gy);
    pose_derivative(*frames[f], ez, gz);
    for (int j = 0; j < 6; ++j) {
      const int col = first_index[f] + j;
      const double d = unpack[col] * inv_n;
      // Omega x e_y has Omega_x as its z; Omega x e_z has Omega_y as its x; Omega x e_x
      // has Omega_z as its y.
      lt.at<double>(col, nintr + 0) += d * (gy[2 * 6 + j] - g0[2 * 6 + j]);
      lt.at<double>(col, nintr + 1) += d * (gz[0 * 6 + j] - g0[0 * 6 + j]);
      lt.at<double>(col, nintr + 2) += d * (gx[1 * 6 + j] - g0[1 * 6 + j]);
      for (int k = 0; k < 3; ++k) lt.at<double>(col, nintr + 3 + k) += d * g0[k * 6 + j];
    }
  }
  cv::Mat x;
  if (!cv::solve(a, lt, x, cv::DECOMP_CHOLESKY))
    return make_error("singular", "J^T J with the added view is singular");
  const cv::Mat var_z = x.t() * b * x;  // Var(z) / sigma^2, r x r

  const double sigma = cov.observed_sigma_px;
  std::vector<double> out(points.size(), std::numeric_limits<double>::quiet_NaN());
  std::vector<double> dq_dintr(2 * static_cast<size_t>(nintr)), g(2 * static_cast<size_t>(r));
  for (size_t i = 0; i < points.size(); ++i) {
    const auto& pt = points[i];
    if (!std::isfinite(pt[0])) continue;
    mrcal_point2_t q;
    mrcal_point3_t dq_dp[2];
    const mrcal_point3_t p{{pt[0], pt[1], pt[2]}};
    if (!mrcal_project(&q, dq_dp, dq_dintr.data(), &p, 1, &problem_.lensmodel,
                       problem_.intrinsics.data()))
      continue;
    for (int row = 0; row < 2; ++row) {
      double* gr = &g[row * r];
      for (int j = 0; j < nintr; ++j) gr[j] = dq_dintr[row * nintr + j];
      const double* d = dq_dp[row].xyz;
      // dq/dOmega = dq/dp (-[p]_x); -[p]_x = [[0, pz, -py], [-pz, 0, px], [py, -px, 0]].
      gr[nintr + 0] = -d[1] * pt[2] + d[2] * pt[1];
      gr[nintr + 1] = d[0] * pt[2] - d[2] * pt[0];
      gr[nintr + 2] = -d[0] * pt[1] + d[1] * pt[0];
      for (int k = 0; k < 3; ++k) gr[nintr + 3 + k] = d[k];
    }
    double v[2][2] = {{0, 0}, {0, 0}};
    for (int r1 = 0; r1 < 2; ++r1)
      for (int r2 = 0; r2 < 2; ++r2) {
        double sum = 0;
        for (int a1 = 0; a1 < r; ++a1) {
          const double* row = var_z.ptr<double>(a1);
          double inner = 0;
          for (int a2 = 0; a2 < r; ++a2) inner += row[a2] * g[r2 * r + a2];
          sum += g[r1 * r + a1] * inner;
        }
        v[r1][r2] = sigma * sigma * sum;
      }
    out[i] = PixelCovariance{v[0][0], 0.5 * (v[0][1] + v[1][0]), v[1][1]}.worst_px();
  }
  return out;
}

}  // namespace camlab::calib
