#include "calib/model_selection.h"

#include <algorithm>

#include "calib/lens_model.h"

namespace camlab::calib {

std::vector<std::string> default_candidate_models() {
  return {"LENSMODEL_PINHOLE", "LENSMODEL_OPENCV4", "LENSMODEL_OPENCV5", "LENSMODEL_OPENCV8",
          "LENSMODEL_OPENCV12"};
}

namespace {

// Held-out error of one model: views split into `folds` interleaved groups.
Result<double> heldout_error(const CalibrationData& data, const SolveOptions& options,
                             const std::vector<int>& views, int folds) {
  std::vector<CornerResidual> all;
  for (int f = 0; f < folds; ++f) {
    CalibrationData train = data;
    train.views.clear();
    std::vector<int> test;
    for (size_t i = 0; i < views.size(); ++i) {
      if (static_cast<int>(i % folds) == f) test.push_back(views[i]);
      else train.views.push_back(data.views[views[i]]);
    }
    Solution s;
    CAMLAB_ASSIGN(s, solve(train, options));
    Solution h;
    CAMLAB_ASSIGN(h, fit_poses(data, s.model, s.calobject_warp, test));
    all.insert(all.end(), h.residuals.begin(), h.residuals.end());
  }
  return trimmed_rms_px(all, 0.98);
}

}  // namespace

Result<ModelSelection> select_model(const CalibrationData& data, const SolveOptions& options,
                                    const std::vector<std::string>& candidates, int folds) {
  std::vector<int> views;
  for (int v = 0; v < static_cast<int>(data.views.size()); ++v)
    if (data.views[v].present_count() >= 8) views.push_back(v);
  folds = std::clamp(folds, 2, std::max(2, static_cast<int>(views.size()) / 3));
  const bool cross_validate = static_cast<int>(views.size()) >= 6;

  ModelSelection out;
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
    if (cross_validate) {
      auto h = heldout_error(data, o, views, folds);
      if (!h) {
        e.error = "cross-validation failed: " + h.error().message;
        out.evidence.push_back(e);
        solutions.emplace_back();
        continue;
      }
      e.heldout_px = *h;
    } else {
      e.heldout_px = s->rms_px;  // too few views to hold any out: the fit's own RMS
    }
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
