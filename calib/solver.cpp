#include "calib/solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <numeric>
#include <optional>

#include "base/cancel.h"
#include "base/format.h"
#include "base/log.h"
#include "base/stack_thread.h"
#include "calib/library_stderr.h"
#include "calib/mrcal_api.h"
#include "calib/mrcal_problem.h"
#include "calib/seed.h"
#include "calib/uncertainty.h"

namespace camlab::calib {

namespace {

using Problem = MrcalProblem;

// One mrcal_optimize call. Returns false when mrcal fails or leaves non-finite values.
bool optimize(Problem* p, const BoardSpec& board, mrcal_problem_selections_t sel) {
  if (is_cancelled(p->cancel)) return false;  // solve() reports it as "cancelled"
  const int nobs = static_cast<int>(p->observations.size());
  const int nframes = static_cast<int>(p->frames.size());
  const int nx = mrcal_num_measurements(nobs, 0, board.cols, board.rows, 1, 0, nframes, 0, 0, sel,
                                        &p->lensmodel);
  p->x.assign(nx, 0.0);
  const mrcal_problem_constants_t constants = {-1.0, -1.0};
  const auto t0 = std::chrono::steady_clock::now();
  mrcal_stats_t stats{};
  stats.rms_reproj_error__pixels = -1;
  const Status ran = run_with_stack(solver_stack_bytes(*p), [&] {
    stats = mrcal_optimize(nullptr, 0, p->x.data(), nx * static_cast<int>(sizeof(double)),
                           p->intrinsics.data(), nullptr, p->frames.data(), nullptr, &p->warp, 1, 0,
                           nframes, 0, 0, p->observations.data(), nullptr, nobs, 0, p->pool.data(),
                           &p->lensmodel, p->imagersize, sel, &constants, board.spacing_m,
                           board.cols, board.rows, false, false);
  });
  if (!ran) {
    log_warning(log::Category::kCalib, "%s", ran.error().message.c_str());
    return false;
  }
  if (!(stats.rms_reproj_error__pixels >= 0) || !std::isfinite(stats.rms_reproj_error__pixels))
    return false;
  for (double v : p->intrinsics)
    if (!std::isfinite(v)) return false;
  for (const auto& f : p->frames)
    for (int k = 0; k < 3; ++k)
      if (!std::isfinite(f.r.xyz[k]) || !std::isfinite(f.t.xyz[k])) return false;
  // CAMLAB_LOG=calib=debug: one line per mrcal_optimize call (time, RMS, intrinsics).
  if (log::enabled(log::Category::kCalib, log::Level::kDebug)) {
    std::string intrinsics;
    for (double v : p->intrinsics) intrinsics += " " + format_significant(v, 5);
    log_debug(log::Category::kCalib, "stage %.3f s rms %.4f outliers %d intrinsics%s",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count(),
              stats.rms_reproj_error__pixels, stats.Noutliers, intrinsics.c_str());
  }
  return std::isfinite(p->warp.x2) && std::isfinite(p->warp.y2);
}

mrcal_problem_selections_t selections(bool core, bool distortions, bool warp, bool regularize,
                                      bool outliers) {
  return mrcal_selections(core, distortions, warp, regularize, outliers);
}

// Per-view median length of the unweighted residuals (px) of the corners that are in the
// solve. A median, not an RMS: one gross outlier corner (25 px among 140 good ones) lifts
// a view's RMS over the straggler limit, and the whole good view would be set aside.
std::vector<double> view_median_residual_px(const Problem& p, int per_view) {
  const size_t nviews = p.frames.size();
  std::vector<double> medians(nviews, 0.0);
  std::vector<double> lengths;
  for (size_t i = 0; i < nviews; ++i) {
    lengths.clear();
    for (int k = 0; k < per_view; ++k) {
      const size_t j = i * per_view + k;
      if (p.pool[j].z <= 0) continue;
      const double w = p.pool[j].z;
      lengths.push_back(std::hypot(p.x[2 * j], p.x[2 * j + 1]) / w);
    }
    if (lengths.empty()) continue;
    std::nth_element(lengths.begin(), lengths.begin() + lengths.size() / 2, lengths.end());
    medians[i] = lengths[lengths.size() / 2];
  }
  return medians;
}

// Suspect views: a planar PnP on a partial edge view through a core-only projection can
// land far off, and such a view would drag the lens with it. Suspects keep a weight of
// 1e-3 (their pose stays determined; they no longer pull the lens) until a pose through a
// better model brings them in line with the rest.
struct ViewWeights {
  std::vector<mrcal_point3_t> full_pool;  // the observations at their true weights
  std::vector<char> suspect;              // per view
  double radial_r0 = 0;                   // > 0: down-weight corners far from the centre
  double cx = 0, cy = 0;
};

void apply_weights(Problem* p, const ViewWeights& w, int per_view) {
  p->pool = w.full_pool;
  for (size_t j = 0; j < p->pool.size(); ++j) {
    auto& q = p->pool[j];
    if (q.z <= 0) continue;
    if (w.suspect[j / per_view]) q.z *= 1e-3;
    if (w.radial_r0 > 0) {
      const double r = std::hypot(q.x - w.cx, q.y - w.cy) / w.radial_r0;
      q.z *= 1.0 / (1.0 + r * r * r * r);
    }
  }
}

std::vector<char> find_stragglers(const Problem& p, int per_view) {
  const auto median = view_median_residual_px(p, per_view);
  std::vector<double> sorted = median;
  std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
  const double limit = std::max(5 * sorted[sorted.size() / 2], 2.0);
  std::vector<char> out(median.size());
  for (size_t i = 0; i < median.size(); ++i) out[i] = median[i] > limit;
  return out;
}

// After a stage: re-pose the stragglers and suspects through the current model, refit
// all poses with the lens fixed, and reclassify. Returns true when the suspect set
// changed (the caller re-solves the stage), and sets *failed when mrcal fails.
bool update_suspects(Problem* p, const CalibrationData& data, const std::vector<int>& views,
                     ViewWeights* w, bool* failed) {
  const int per = data.board.cols * data.board.rows;
  auto bad = find_stragglers(*p, per);
  bool any = false;
  for (size_t i = 0; i < views.size(); ++i) any |= bad[i] || w->suspect[i];
  if (!any) return false;
  char name[128];
  mrcal_lensmodel_name(name, sizeof name, &p->lensmodel);
  const LensModel current{name, p->intrinsics, data.imager_width_px, data.imager_height_px};
  const std::vector<mrcal_pose_t> before = p->frames;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!bad[i] && !w->suspect[i]) continue;
    auto pose = pose_from_corners(data, views[i], current);
    if (!pose) continue;
    for (int k = 0; k < 3; ++k) {
      p->frames[i].r.xyz[k] = (*pose)[k];
      p->frames[i].t.xyz[k] = (*pose)[3 + k];
    }
  }
  // Judge every view at its full weight with the lens fixed.
  const auto saved_suspect = w->suspect;
  std::fill(w->suspect.begin(), w->suspect.end(), 0);
  apply_weights(p, *w, per);
  if (!optimize(p, data.board, selections(false, false, false, false, false))) {
    *failed = true;
    return false;
  }
  w->suspect = find_stragglers(*p, per);
  apply_weights(p, *w, per);
  return w->suspect != saved_suspect ||
         std::any_of(bad.begin(), bad.end(), [](char c) { return c; });
}

// k1, k2 of a radial polynomial that mimics the stereographic core over the field the
// corners cover: r_p (1 + k1 r_p^2 + k2 r_p^4) = 2 tan(theta / 2) with r_p = tan(theta),
// least squares over theta. Starting OPENCV4 there instead of at zero distortion keeps a
// wide lens's edge corners near their observations.
void seed_k1_k2_from_stereographic(const Problem& p, std::vector<double>* intrinsics) {
  const double f = 0.5 * (p.intrinsics[0] + p.intrinsics[1]);
  double u_max = 0;
  for (const auto& q : p.pool)
    if (q.z > 0)
      u_max = std::max(u_max, std::hypot(q.x - p.intrinsics[2], q.y - p.intrinsics[3]) / f);
  const double theta_max = std::min(2 * std::atan(u_max / 2), 75.0 * M_PI / 180);
  double a11 = 0, a12 = 0, a22 = 0, b1 = 0, b2 = 0;
  for (int i = 1; i <= 50; ++i) {
    const double th = theta_max * i / 50, rp = std::tan(th), rs = 2 * std::tan(th / 2);
    const double g1 = rp * rp * rp, g2 = g1 * rp * rp, y = rs - rp;
    a11 += g1 * g1;
    a12 += g1 * g2;
    a22 += g2 * g2;
    b1 += g1 * y;
    b2 += g2 * y;
  }
  const double det = a11 * a22 - a12 * a12;
  if (!(std::fabs(det) > 1e-300)) return;
  (*intrinsics)[4] = (a22 * b1 - a12 * b2) / det;
  (*intrinsics)[5] = (a11 * b2 - a12 * b1) / det;
}

// Stage 1 fits only the core and rough poses, which every other corner in each
// direction determines nearly as well as all of them, at a quarter of the measurements
// (the first stages start farthest from the optimum and take the most iterations). The
// coarse board is corners (2i, 2j) of the real one: spacing doubled, same origin, so
// its poses are the real board's. Used only when each view keeps 8+ coarse corners.
std::optional<CalibrationData> coarse_data(const CalibrationData& data,
                                           const std::vector<int>& views) {
  const BoardSpec& b = data.board;
  CalibrationData coarse;
  coarse.board = {(b.cols + 1) / 2, (b.rows + 1) / 2, 2 * b.spacing_m};
  if (coarse.board.cols < 3 || coarse.board.rows < 3) return std::nullopt;
  coarse.imager_width_px = data.imager_width_px;
  coarse.imager_height_px = data.imager_height_px;
  coarse.views.resize(data.views.size());
  for (int v : views) {
    auto& corners = coarse.views[v].corners;
    for (int j = 0; j < b.rows; j += 2)
      for (int i = 0; i < b.cols; i += 2) corners.push_back(data.views[v].corners[j * b.cols + i]);
    if (coarse.views[v].present_count() < 8) return std::nullopt;
  }
  return coarse;
}

// Stage 1 on `p` (poses seeded): poses alone, then the seed projection's core with them.
// Corners far from the centre are down-weighted here: a core-only projection cannot
// describe a wide lens's edges, and letting them pull would bias the core every later
// stage starts from. Sets w->suspect; leaves w->radial_r0 at 0.
Status run_stage1(Problem* p, const BoardSpec& board, ViewWeights* w) {
  const int per_view = board.cols * board.rows;
  w->radial_r0 = 0.35 * std::hypot(p->imagersize[0], p->imagersize[1]);
  apply_weights(p, *w, per_view);
  if (!optimize(p, board, selections(false, false, false, false, false)))
    return make_error("solve_failed", "the pose solve did not converge");
  w->suspect = find_stragglers(*p, per_view);
  apply_weights(p, *w, per_view);
  if (!optimize(p, board, selections(true, false, false, false, false)))
    return make_error("solve_failed", "the core solve did not converge");
  w->radial_r0 = 0;
  return {};
}

// Core + distortions + poses of p's current model with regularization, then the
// suspect views re-judged (update_suspects) and the stage re-solved when they changed.
Status solve_stage(Problem* p, const CalibrationData& data, const std::vector<int>& views,
                   const std::string& name, ViewWeights* w) {
  apply_weights(p, *w, data.board.cols * data.board.rows);
  const bool distort = p->intrinsics.size() > 4;
  const auto sel = selections(true, distort, false, distort, false);
  const Error not_converged = make_error("solve_failed", "the " + name + " solve did not converge");
  if (!optimize(p, data.board, sel)) return not_converged;
  bool failed = false;
  for (int round = 0; round < 2 && update_suspects(p, data, views, w, &failed); ++round)
    if (failed || !optimize(p, data.board, sel)) return not_converged;
  if (failed) return make_error("solve_failed", "the " + name + " pose refit did not converge");
  return {};
}

// The models a solve passes through to reach `target`. OpenCV models grow through the
// chain OPENCV4 -> 8 -> 12 (OPENCV5 from OPENCV4), each starting from the previous one's
// solution with its new terms at zero: a rational model started from zero distortion on
// a wide lens falls into a local minimum, a chain does not.
std::vector<std::string> model_chain(const mrcal_lensmodel_t& target, const std::string& name) {
  switch (target.type) {
    case MRCAL_LENSMODEL_OPENCV12:
      return {"LENSMODEL_OPENCV4", "LENSMODEL_OPENCV8", "LENSMODEL_OPENCV12"};
    case MRCAL_LENSMODEL_OPENCV8:
      return {"LENSMODEL_OPENCV4", "LENSMODEL_OPENCV8"};
    case MRCAL_LENSMODEL_OPENCV5:
      return {"LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5"};
    default:
      return {name};
  }
}

// One model of the chain: starts from p's current model (shared leading parameters
// kept, new terms at zero, or k1 k2 from the stereographic seed), solves core +
// distortions + poses with regularization, then re-judges the suspect views.
Status fit_chain_model(Problem* p, const CalibrationData& data, const std::vector<int>& views,
                       const std::string& name, bool stereographic_core, ViewWeights* w) {
  mrcal_lensmodel_t m;
  mrcal_lensmodel_from_name(&m, name.c_str());
  std::vector<double> next(mrcal_lensmodel_num_params(&m), 0.0);
  // OpenCV models share their leading parameters (fx fy cx cy k1 k2 p1 p2 k3 ...).
  const bool opencv_to_opencv =
      p->lensmodel.type >= MRCAL_LENSMODEL_OPENCV4 && p->lensmodel.type <= MRCAL_LENSMODEL_OPENCV12;
  const size_t keep = opencv_to_opencv ? std::min(next.size(), p->intrinsics.size()) : 4;
  std::copy(p->intrinsics.begin(), p->intrinsics.begin() + keep, next.begin());
  if (stereographic_core && m.type == MRCAL_LENSMODEL_OPENCV4 &&
      p->lensmodel.type == MRCAL_LENSMODEL_STEREOGRAPHIC)
    seed_k1_k2_from_stereographic(*p, &next);
  p->lensmodel = m;
  p->intrinsics = next;
  return solve_stage(p, data, views, name, w);
}

void fill_solution(const Problem& p, const CalibrationData& data, const std::vector<int>& views,
                   const std::vector<char>& suspect, Solution* s) {
  s->views_used = views;
  s->rt_cam_board.clear();
  for (const auto& f : p.frames)
    s->rt_cam_board.push_back({f.r.x, f.r.y, f.r.z, f.t.x, f.t.y, f.t.z});
  s->calobject_warp = {p.warp.x2, p.warp.y2};
  s->residuals.clear();
  const int per_view = data.board.cols * data.board.rows;
  double sum = 0;
  s->inliers = s->outliers = 0;
  s->worst_px = 0;
  for (int i = 0; i < static_cast<int>(views.size()); ++i)
    for (int k = 0; k < per_view; ++k) {
      const size_t j = static_cast<size_t>(i) * per_view + k;
      if (p.missing[j]) continue;
      const double w = data.views[views[i]].corners[k].weight;
      CornerResidual r;
      r.view = views[i];
      r.corner = k;
      r.outlier = p.pool[j].z < 0 || suspect[i];
      const double wz = suspect[i] ? p.pool[j].z : w;
      r.dx_px = p.x[2 * j] / wz;
      r.dy_px = p.x[2 * j + 1] / wz;
      if (r.outlier) {
        ++s->outliers;
      } else {
        ++s->inliers;
        const double e2 = r.dx_px * r.dx_px + r.dy_px * r.dy_px;
        sum += e2;
        s->worst_px = std::max(s->worst_px, std::sqrt(e2));
      }
      s->residuals.push_back(r);
    }
  s->rms_px = std::sqrt(sum / std::max(1, s->inliers));
}

// Residuals of outliers are 0 in mrcal's x: recompute them by projecting the board.
void fill_outlier_residuals(const Problem& p, const CalibrationData& data, Solution* s) {
  for (auto& r : s->residuals) {
    if (!r.outlier || r.dx_px != 0 || r.dy_px != 0) continue;
    const size_t i =
        std::find(s->views_used.begin(), s->views_used.end(), r.view) - s->views_used.begin();
    const auto& f = p.frames[i];
    auto q = project_board_corner(s->model, data.board, {f.r.x, f.r.y, f.r.z, f.t.x, f.t.y, f.t.z},
                                  {p.warp.x2, p.warp.y2}, r.corner);
    if (!q) continue;
    const auto& obs = data.views[r.view].corners[r.corner];
    r.dx_px = (*q)[0] - obs.x_px;
    r.dy_px = (*q)[1] - obs.y_px;
  }
}

// Stages 3 and 4 (outlier rejection, board warp) on the solved model, then the
// Solution with its residuals and, when asked, the state covariance.
Result<Solution> finish_solve(Problem* p, const CalibrationData& data,
                              const std::vector<int>& views, const std::vector<char>& suspect,
                              const SolveOptions& options, const FocalSeed& seed,
                              std::chrono::steady_clock::time_point t0) {
  const BoardSpec& board = data.board;
  const bool has_distortions = p->intrinsics.size() > 4;
  // Views still far off after the full model are mis-observed (or not this board): they
  // keep their 1e-3 weight (a pose with no observations would make the problem
  // singular), and the report counts their corners as outliers.

  // Stage 3: outlier rejection, now that the model can describe the lens; with the
  // board's warp (stage 4) when that is asked for: one solve less, and the warp (two
  // smooth coefficients) cannot absorb a gross outlier that rejection should catch.
  if (options.reject_outliers && !options.board_warp &&
      !optimize(p, board, selections(true, has_distortions, false, has_distortions, true)))
    return make_error("solve_failed", "the solve with outlier rejection did not converge");
  // Stage 4: the board's warp.
  if (options.board_warp &&
      !optimize(p, board,
                selections(true, has_distortions, true, has_distortions, options.reject_outliers)))
    return make_error("solve_failed", "the solve with board warp did not converge");

  Solution s;
  s.model.lensmodel = options.lensmodel;
  s.model.intrinsics = p->intrinsics;
  s.model.width_px = data.imager_width_px;
  s.model.height_px = data.imager_height_px;
  s.seed_focal_px = seed.focal_px;
  s.seed_projection = seed.projection == SeedProjection::kPinhole ? "pinhole" : "stereographic";
  fill_solution(*p, data, views, suspect, &s);
  fill_outlier_residuals(*p, data, &s);
  s.board = board;
  s.view_downweighted = suspect;
  if (options.compute_covariance) {
    // The Jacobian of the last stage's problem, at its optimum (uncertainty.h).
    auto cov = state_covariance(
        *p, board, selections(true, has_distortions, options.board_warp, has_distortions, false),
        suspect);
    if (cov)
      s.covariance = std::make_shared<const StateCovariance>(std::move(*cov));
    else
      s.covariance_error = cov.error().message;
    log_debug(log::Category::kCalib, "covariance done at %.3f s",
              std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  s.solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

// The problem of every view with a whole corner array, 8+ present corners and a pose:
// known[v] when given, else planar PnP on its present corners through `model` (missing
// corners never enter a pose). Starts at `model`'s intrinsics; *views gets the data
// indices of the views kept. Error "too_few_views" below 2.
Result<Problem> posed_problem(const CalibrationData& data, const LensModel& model,
                              const std::vector<std::optional<std::array<double, 6>>>& known,
                              std::vector<int>* views) {
  views->clear();
  std::vector<std::array<double, 6>> poses;
  for (int v = 0; v < static_cast<int>(data.views.size()); ++v) {
    if (static_cast<int>(data.views[v].corners.size()) != data.board.cols * data.board.rows)
      continue;
    if (data.views[v].present_count() < 8) continue;
    std::optional<std::array<double, 6>> pose;
    if (v < static_cast<int>(known.size())) pose = known[v];
    if (!pose) pose = pose_from_corners(data, v, model);
    if (!pose) continue;
    views->push_back(v);
    poses.push_back(*pose);
  }
  if (views->size() < 2)
    return make_error("too_few_views",
                      "fewer than 2 views have a usable board (8+ corners and a pose)");
  Problem p = make_mrcal_problem(data, *views);
  mrcal_lensmodel_from_name(&p.lensmodel, model.lensmodel.c_str());
  p.intrinsics = model.intrinsics;
  for (size_t i = 0; i < poses.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      p.frames[i].r.xyz[k] = poses[i][k];
      p.frames[i].t.xyz[k] = poses[i][3 + k];
    }
  return p;
}

// A solve from options.warm_start (solver.h): its poses (or PnP through its model for
// views it lacks), then the model's stage and stages 3-4 as in a full solve.
Result<Solution> solve_warm(const CalibrationData& data, const SolveOptions& options,
                            std::chrono::steady_clock::time_point t0) {
  const WarmStart& warm = *options.warm_start;
  std::vector<int> views;
  Problem p;
  CAMLAB_ASSIGN(p, posed_problem(data, warm.model, warm.rt_cam_board, &views));
  p.cancel = options.cancel;
  p.warp.x2 = warm.calobject_warp[0];
  p.warp.y2 = warm.calobject_warp[1];
  ViewWeights weights;
  weights.full_pool = p.pool;
  weights.suspect.assign(views.size(), 0);
  const int per_view = data.board.cols * data.board.rows;
  if (options.reject_outliers)
    for (size_t i = 0; i < views.size(); ++i)
      if (views[i] < static_cast<int>(warm.outlier_corners.size()))
        for (int k : warm.outlier_corners[views[i]])
          if (k >= 0 && k < per_view) weights.full_pool[i * per_view + k].z = -1.0;
  if (Status s = solve_stage(&p, data, views, options.lensmodel, &weights); !s) return s.error();
  FocalSeed seed;
  seed.focal_px = warm.model.intrinsics.empty() ? 0 : warm.model.intrinsics[0];
  return finish_solve(&p, data, views, weights.suspect, options, seed, t0);
}

}  // namespace

size_t solver_stack_bytes(const MrcalProblem& p) {
  // The state: every intrinsic and 6 per view (+ the warp); the measurements: 2 per corner.
  // 64 bytes per state and 16 per measurement cover the stack arrays mrcal 2.2 keeps (a few
  // of each), with 16 MiB for the rest of the call.
  const size_t state = p.intrinsics.size() + 6 * p.frames.size() + 2;
  const size_t measurements = 2 * p.pool.size();
  return (size_t{16} << 20) + 64 * state + 16 * measurements;
}

MrcalProblem make_mrcal_problem(const CalibrationData& data, const std::vector<int>& views) {
  MrcalProblem p;
  p.imagersize[0] = data.imager_width_px;
  p.imagersize[1] = data.imager_height_px;
  for (int i = 0; i < static_cast<int>(views.size()); ++i) {
    mrcal_observation_board_t o{};
    o.icam.intrinsics = 0;
    o.icam.extrinsics = -1;
    o.iframe = i;
    p.observations.push_back(o);
    for (const auto& c : data.views[views[i]].corners) {
      mrcal_point3_t q;
      q.x = c.present ? c.x_px : 0.0;
      q.y = c.present ? c.y_px : 0.0;
      q.z = c.present ? c.weight : -1.0;
      p.pool.push_back(q);
      p.missing.push_back(c.present ? 0 : 1);
    }
  }
  p.frames.resize(views.size());
  return p;
}

mrcal_problem_selections_t mrcal_selections(bool core, bool distortions, bool warp, bool regularize,
                                            bool outliers) {
  mrcal_problem_selections_t s{};
  s.do_optimize_intrinsics_core = core;
  s.do_optimize_intrinsics_distortions = distortions;
  s.do_optimize_extrinsics = false;
  s.do_optimize_frames = true;
  s.do_optimize_calobject_warp = warp;
  s.do_apply_regularization = regularize;
  s.do_apply_outlier_rejection = outliers;
  return s;
}

Result<std::array<double, 2>> project_board_corner(const LensModel& model, const BoardSpec& board,
                                                   const std::array<double, 6>& rt_cam_board,
                                                   const std::array<double, 2>& calobject_warp,
                                                   int corner) {
  if (corner < 0 || corner >= board.cols * board.rows)
    return make_error("invalid_argument", "corner index outside the board");
  const int ci = corner % board.cols, cj = corner / board.cols;
  // mrcal's board warp: z += x2 (1 - (2 ci/W - 1)^2) + y2 (1 - (2 cj/H - 1)^2).
  const double xr = 2.0 * ci / (board.cols - 1) - 1, yr = 2.0 * cj / (board.rows - 1) - 1;
  const double pb[3] = {ci * board.spacing_m, cj * board.spacing_m,
                        calobject_warp[0] * (1 - xr * xr) + calobject_warp[1] * (1 - yr * yr)};
  double pc[3];
  mrcal_transform_point_rt(pc, nullptr, nullptr, rt_cam_board.data(), pb);
  std::vector<double> q;
  CAMLAB_ASSIGN(q, project(model, {pc[0], pc[1], pc[2]}));
  return std::array<double, 2>{q[0], q[1]};
}

double trimmed_rms_px(const std::vector<CornerResidual>& residuals, double keep) {
  std::vector<double> e2;
  for (const auto& r : residuals) e2.push_back(r.dx_px * r.dx_px + r.dy_px * r.dy_px);
  if (e2.empty()) return 0;
  std::sort(e2.begin(), e2.end());
  const size_t n = std::max<size_t>(1, static_cast<size_t>(std::ceil(keep * e2.size())));
  return std::sqrt(std::accumulate(e2.begin(), e2.begin() + std::min(n, e2.size()), 0.0) /
                   std::min(n, e2.size()));
}

namespace {

Result<Solution> solve_staged(const CalibrationData& data, const SolveOptions& options) {
  const auto t0 = std::chrono::steady_clock::now();
  const LibraryStderrCapture quiet_mrcal;  // mrcal's chatter into the log (library_stderr.h)
  const BoardSpec& board = data.board;
  if (board.cols < 2 || board.rows < 2 || !(board.spacing_m > 0))
    return make_error("invalid_argument",
                      "the board needs 2 x 2 or more inner corners and a positive spacing");
  if (data.imager_width_px <= 0 || data.imager_height_px <= 0)
    return make_error("invalid_argument", "the imager size is unknown");
  // Through lens_model.h's check, so a model beyond its limits never reaches mrcal.
  int target_params = 0;
  CAMLAB_ASSIGN(target_params, lensmodel_param_count(options.lensmodel));
  mrcal_lensmodel_t target;
  mrcal_lensmodel_from_name(&target, options.lensmodel.c_str());
  if (options.warm_start && options.warm_start->model.lensmodel == options.lensmodel &&
      options.warm_start->model.intrinsics.size() == static_cast<size_t>(target_params))
    return solve_warm(data, options, t0);

  const std::optional<FocalSeed> seed = options.seed ? std::optional<FocalSeed>(*options.seed)
                                                     : seed_focal(data, options.focal_guess_px);
  log_debug(log::Category::kCalib, "seed %.3f s",
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  if (!seed)
    return make_error("solve_failed",
                      "no view gave a board pose: check the board size and the corners");
  const double cx = (data.imager_width_px - 1) / 2.0, cy = (data.imager_height_px - 1) / 2.0;
  LensModel seed_model;
  seed_model.lensmodel = seed->projection == SeedProjection::kPinhole ? "LENSMODEL_PINHOLE"
                                                                      : "LENSMODEL_STEREOGRAPHIC";
  seed_model.intrinsics = {seed->focal_px, seed->focal_px, cx, cy};
  seed_model.width_px = data.imager_width_px;
  seed_model.height_px = data.imager_height_px;

  // Per-view poses from the present corners only; views without a pose are left out.
  std::vector<int> views;
  Problem p;
  CAMLAB_ASSIGN(p, posed_problem(data, seed_model, {}, &views));
  p.cancel = options.cancel;
  // Stage 1 (run_stage1), then stage 2: the requested model, reached through a chain of
  // models (model_chain). Stage 1 and every model of the chain but the last only bring the
  // state near the optimum: they run on every other corner when the board is large
  // enough (coarse_data), a quarter of the measurements and fewer iterations.
  const std::vector<std::string> chain = model_chain(target, options.lensmodel);
  const bool stereographic_core = seed->projection == SeedProjection::kStereographic;
  ViewWeights weights;
  weights.full_pool = p.pool;
  weights.suspect.assign(views.size(), 0);
  weights.cx = cx;
  weights.cy = cy;
  auto approach = [&](Problem* q, const CalibrationData& d, ViewWeights* w) -> Status {
    if (Status s = run_stage1(q, d.board, w); !s) return s;
    for (size_t k = 0; k + 1 < chain.size(); ++k)
      if (Status s = fit_chain_model(q, d, views, chain[k], stereographic_core, w); !s) return s;
    return {};
  };
  if (auto coarse = coarse_data(data, views)) {
    Problem pc = make_mrcal_problem(*coarse, views);
    pc.cancel = options.cancel;
    pc.lensmodel = p.lensmodel;
    pc.intrinsics = p.intrinsics;
    pc.frames = p.frames;
    ViewWeights coarse_weights = weights;
    coarse_weights.full_pool = pc.pool;
    if (Status s = approach(&pc, *coarse, &coarse_weights); !s) return s.error();
    p.lensmodel = pc.lensmodel;
    p.intrinsics = pc.intrinsics;
    p.frames = pc.frames;
    weights.suspect = coarse_weights.suspect;
  } else if (Status s = approach(&p, data, &weights); !s) {
    return s.error();
  }
  if (Status s = fit_chain_model(&p, data, views, chain.back(), stereographic_core, &weights); !s)
    return s.error();
  return finish_solve(&p, data, views, weights.suspect, options, *seed, t0);
}

}  // namespace

Result<Solution> solve(const CalibrationData& data, const SolveOptions& options) {
  auto solved = solve_staged(data, options);
  // A stage stopped by the flag fails as a stage would: say why instead.
  if (Status s = check_not_cancelled(options.cancel, "calibration"); !s) return s.error();
  return solved;
}

Result<Solution> fit_poses(const CalibrationData& data, const LensModel& model,
                           const std::array<double, 2>& calobject_warp,
                           const std::vector<int>& views_in) {
  const auto t0 = std::chrono::steady_clock::now();
  const LibraryStderrCapture quiet_mrcal;
  std::vector<int> views;
  std::vector<std::array<double, 6>> poses;
  for (int v : views_in) {
    if (v < 0 || v >= static_cast<int>(data.views.size())) continue;
    if (data.views[v].present_count() < 8) continue;
    auto pose = pose_from_corners(data, v, model);
    if (!pose) continue;
    views.push_back(v);
    poses.push_back(*pose);
  }
  if (views.empty()) return make_error("too_few_views", "no held-out view gave a pose");
  Problem p = make_mrcal_problem(data, views);
  if (!mrcal_lensmodel_from_name(&p.lensmodel, model.lensmodel.c_str()))
    return make_error("bad_lensmodel", "unknown lens model '" + model.lensmodel + "'");
  p.intrinsics = model.intrinsics;
  p.warp.x2 = calobject_warp[0];
  p.warp.y2 = calobject_warp[1];
  for (size_t i = 0; i < poses.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      p.frames[i].r.xyz[k] = poses[i][k];
      p.frames[i].t.xyz[k] = poses[i][3 + k];
    }
  if (!optimize(&p, data.board, selections(false, false, false, false, false)))
    return make_error("solve_failed", "the pose fit did not converge");
  Solution s;
  s.model = model;
  fill_solution(p, data, views, std::vector<char>(views.size(), 0), &s);
  s.solve_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return s;
}

std::shared_ptr<const WarmStart> warm_start_from(const Solution& full,
                                                 const std::vector<int>& fold_views) {
  auto warm = std::make_shared<WarmStart>();
  warm->model = full.model;
  warm->calobject_warp = full.calobject_warp;
  for (int v : fold_views) {
    const auto it = std::find(full.views_used.begin(), full.views_used.end(), v);
    auto& outliers = warm->outlier_corners.emplace_back();
    if (it == full.views_used.end()) {
      warm->rt_cam_board.emplace_back();
      continue;
    }
    const size_t i = it - full.views_used.begin();
    warm->rt_cam_board.emplace_back(full.rt_cam_board[i]);
    // A down-weighted view's corners all count as outliers in the report; in the fold it
    // is judged afresh (rejecting all its corners would leave its pose undetermined).
    if (i < full.view_downweighted.size() && full.view_downweighted[i]) continue;
    for (const auto& r : full.residuals)
      if (r.view == v && r.outlier) outliers.push_back(r.corner);
  }
  return warm;
}

}  // namespace camlab::calib
