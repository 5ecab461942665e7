#include "calib/model_selection.h"

#include <algorithm>
#include <chrono>
#include <memory>
#include <numeric>

#include "calib/lens_model.h"

namespace camlab::calib {

std::vector<std::string> default_candidate_models() {
  return {"LENSMODEL_PINHOLE", "LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8",
          "LENSMODEL_OPENCV12"};
}

namespace {

// The full data's solution as a warm start for a fold whose views are data.views[fold_views[k]].
std::shared_ptr<const WarmStart> warm_start_for(const Solution& full, const std::vector<int>& fold_views) {
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

// Held-out error of one model: views split into `folds` interleaved groups.
Result<double> heldout_error(const CalibrationData& data, const SolveOptions& options,
                             const Solution& full, const std::vector<int>& views, int folds) {
  std::vector<CornerResidual> all;
  for (int f = 0; f < folds; ++f) {
    CalibrationData train = data;
    SolveOptions fold_options = options;
    fold_options.compute_covariance = false;  // only the held-out error is used
    train.views.clear();
    std::vector<int> test, train_views;
    for (size_t i = 0; i < views.size(); ++i) {
      if (static_cast<int>(i % folds) == f) {
        test.push_back(views[i]);
      } else {
        train.views.push_back(data.views[views[i]]);
        train_views.push_back(views[i]);
      }
    }
    fold_options.warm_start = warm_start_for(full, train_views);
    Solution s;
    CAMLAB_ASSIGN(s, solve(train, fold_options));
    Solution h;
    CAMLAB_ASSIGN(h, fit_poses(data, s.model, s.calobject_warp, test));
    all.insert(all.end(), h.residuals.begin(), h.residuals.end());
  }
  return trimmed_rms_px(all, 0.98);
}

// Held-out error with too few views to leave whole views out: every view stays in, and
// a third of its corners (an interleaved pattern that moves by one per row and per view,
// so each fold thins the whole imager evenly) is left out of each fold's fit; the error
// is that of the left-out corners through the fitted lens and the fitted poses. It
// measures how well a model interpolates between corners, not how well it generalises
// to new board poses, so it is weaker evidence than leaving views out (stated in the
// report as cross_validation "corners").
Result<double> heldout_error_by_corners(const CalibrationData& data, const SolveOptions& options,
                                        const Solution& full, const std::vector<int>& views, int folds) {
  std::vector<CornerResidual> all;
  const int cols = data.board.cols;
  for (int f = 0; f < folds; ++f) {
    CalibrationData train = data;
    std::vector<std::pair<int, int>> test;  // (view, corner)
    for (int v : views)
      for (int j = 0; j < static_cast<int>(train.views[v].corners.size()); ++j) {
        auto& c = train.views[v].corners[j];
        if (c.present && (j % cols + 2 * (j / cols) + v) % folds == f) {
          c.present = false;
          test.emplace_back(v, j);
        }
      }
    SolveOptions fold_options = options;
    fold_options.compute_covariance = false;
    std::vector<int> all_views(data.views.size());
    std::iota(all_views.begin(), all_views.end(), 0);
    fold_options.warm_start = warm_start_for(full, all_views);
    Solution s;
    CAMLAB_ASSIGN(s, solve(train, fold_options));
    for (auto [v, j] : test) {
      const auto it = std::find(s.views_used.begin(), s.views_used.end(), v);
      if (it == s.views_used.end()) continue;
      auto q = project_board_corner(s.model, data.board, s.rt_cam_board[it - s.views_used.begin()],
                                    s.calobject_warp, j);
      if (!q) continue;
      const auto& obs = data.views[v].corners[j];
      all.push_back({v, j, (*q)[0] - obs.x_px, (*q)[1] - obs.y_px, false});
    }
  }
  if (all.empty()) return make_error("too_few_views", "no held-out corner could be projected");
  return trimmed_rms_px(all, 0.98);
}

}  // namespace

Result<ModelSelection> select_model(const CalibrationData& data, const SolveOptions& options,
                                    const std::vector<std::string>& candidates, int folds) {
  std::vector<int> views;
  for (int v = 0; v < static_cast<int>(data.views.size()); ++v)
    if (data.views[v].present_count() >= 8) views.push_back(v);
  const bool by_views = static_cast<int>(views.size()) >= 6;
  folds = by_views ? std::clamp(folds, 2, std::max(2, static_cast<int>(views.size()) / 3))
                   : std::max(folds, 2);

  ModelSelection out;
  out.cross_validation = by_views ? "views" : "corners";
  int best = -1;
  double best_heldout = 0;
  int misses = 0;
  std::vector<Solution> solutions;
  for (const auto& name : candidates) {
    ModelEvidence e;
    e.lensmodel = name;
    if (auto n = lensmodel_param_count(name); n.ok()) e.params = *n;
    SolveOptions o = options;
    o.lensmodel = name;
    auto s = solve(data, o);
    if (!s) {
      e.error = s.error().message;
      out.evidence.push_back(e);
      solutions.emplace_back();
      continue;
    }
    e.rms_px = s->rms_px;
    e.solve_s = s->solve_s;
    const auto cv_t0 = std::chrono::steady_clock::now();
    auto h = by_views ? heldout_error(data, o, *s, views, folds)
                      : heldout_error_by_corners(data, o, *s, views, folds);
    if (!h) {
      e.error = "cross-validation failed: " + h.error().message;
      out.evidence.push_back(e);
      solutions.emplace_back();
      continue;
    }
    e.heldout_px = *h;
    e.cv_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - cv_t0).count();
    e.ok = true;
    out.evidence.push_back(e);
    solutions.push_back(std::move(*s));
    const int idx = static_cast<int>(out.evidence.size()) - 1;
    if (best < 0 || e.heldout_px < best_heldout * 0.95 - 0.005) {
      best = idx;
      best_heldout = e.heldout_px;
      misses = 0;
    } else if (++misses >= 2) {
      break;
    }
  }
  if (best < 0) return make_error("solve_failed", "no lens model could be fitted");
  out.chosen = std::move(solutions[best]);
  return out;
}

}  // namespace camlab::calib
