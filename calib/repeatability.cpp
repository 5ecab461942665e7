#include "calib/repeatability.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <mutex>
#include <thread>

#include "base/cancel.h"
#include "base/format.h"
#include "calib/lens_model.h"

namespace camlab::calib {

namespace {

// The solution of `full`'s model on data.views[subset], warm-started from `full`.
Result<Solution> solve_subset(const CalibrationData& data, const SolveOptions& options,
                              const Solution& full, const std::vector<int>& subset) {
  CalibrationData part = data;
  part.views.clear();
  for (int v : subset) part.views.push_back(data.views[v]);
  SolveOptions o = options;
  o.lensmodel = full.model.lensmodel;
  o.seed = nullptr;  // other data than the seed was made from
  o.compute_covariance = false;
  o.warm_start = warm_start_from(full, subset);
  return solve(part, o);
}

double rms_px(const std::vector<CornerResidual>& residuals) {
  double sum = 0;
  int n = 0;
  for (const auto& r : residuals) {
    sum += r.dx_px * r.dx_px + r.dy_px * r.dy_px;
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 0.0;
}

void odd_even(const CalibrationData& data, const SolveOptions& options, const Solution& full,
              Repeatability* out) {
  const std::vector<int>& used = full.views_used;
  if (used.size() < 8) {
    out->odd_even_reason =
        "not run: " + std::to_string(used.size()) + " views; each half needs 4 or more";
    return;
  }
  std::vector<int> odd, even;
  for (size_t i = 0; i < used.size(); ++i) (i % 2 ? odd : even).push_back(used[i]);
  out->odd_views = static_cast<int>(odd.size());
  out->even_views = static_cast<int>(even.size());
  auto a = solve_subset(data, options, full, odd);
  auto b = a ? solve_subset(data, options, full, even) : a;
  if (!a || !b) {
    out->odd_even_reason = "not run: a half did not solve: " + (!a ? a : b).error().message;
    return;
  }
  auto d = projection_difference(a->model, b->model, 0.8);
  if (!d) {
    out->odd_even_reason = "not run: " + d.error().message;
    return;
  }
  out->odd_even_ran = true;
  out->odd_even_rms_px = d->rms_px;
  out->odd_even_max_px = d->max_px;
  out->halves_focal_px = {a->model.intrinsics[0], b->model.intrinsics[0]};
  out->halves_warp_m = {a->calobject_warp, b->calobject_warp};
}

Status leave_one_out(const CalibrationData& data, const SolveOptions& options, const Solution& full,
                     Repeatability* out) {
  const std::vector<int>& used = full.views_used;
  if (used.size() < 4) return {};
  // At most kMaxLeaveOneOutViews, spread evenly over the set.
  std::vector<int> predicted;
  const size_t n = std::min<size_t>(used.size(), kMaxLeaveOneOutViews);
  for (size_t k = 0; k < n; ++k) predicted.push_back(used[k * used.size() / n]);
  std::vector<std::vector<CornerResidual>> residuals(n);
  std::vector<char> solved(n, 0);
  size_t next = 0;
  std::mutex mutex;
  auto worker = [&] {
    for (;;) {
      size_t k;
      {
        std::lock_guard<std::mutex> lock(mutex);
        if (next >= n || (options.cancel && options.cancel->load())) return;
        k = next++;
      }
      std::vector<int> rest;
      for (int v : used)
        if (v != predicted[k]) rest.push_back(v);
      auto s = solve_subset(data, options, full, rest);
      if (!s) continue;
      auto h = fit_poses(data, s->model, s->calobject_warp, {predicted[k]});
      if (!h) continue;
      residuals[k] = std::move(h->residuals);
      solved[k] = 1;
    }
  };
  const unsigned threads = std::clamp<unsigned>(std::thread::hardware_concurrency(), 1u, 4u);
  std::vector<std::thread> pool;
  for (unsigned t = 1; t < threads; ++t) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
  if (Status s = check_not_cancelled(options.cancel, "calibration"); !s) return s;
  std::vector<CornerResidual> all;
  for (size_t k = 0; k < n; ++k) {
    if (!solved[k]) continue;
    out->left_out.push_back({data.views[predicted[k]].name, rms_px(residuals[k])});
    all.insert(all.end(), residuals[k].begin(), residuals[k].end());
  }
  out->left_out_rms_px = rms_px(all);
  return {};
}

}  // namespace

nlohmann::json to_json(const Repeatability& r) {
  nlohmann::json odd_even = {{"ran", r.odd_even_ran}};
  if (r.odd_even_ran)
    odd_even.update({{"views", {r.odd_views, r.even_views}},
                     {"projection_diff_rms_px", r.odd_even_rms_px},
                     {"projection_diff_max_px", r.odd_even_max_px},
                     {"fx_px", r.halves_focal_px},
                     {"calobject_warp_m", r.halves_warp_m},
                     {"region", "central 80% of the imager, rotation fitted"}});
  else
    odd_even["reason"] = r.odd_even_reason;
  nlohmann::json per_view = nlohmann::json::array();
  const ViewPrediction* worst = nullptr;
  for (const auto& v : r.left_out) {
    per_view.push_back({{"view", v.view}, {"rms_px", v.rms_px}});
    if (!worst || v.rms_px > worst->rms_px) worst = &v;
  }
  nlohmann::json loo = {{"views", r.left_out.size()}, {"per_view", per_view}};
  if (worst) {
    loo["rms_px"] = r.left_out_rms_px;
    loo["worst"] = {{"view", worst->view}, {"rms_px", worst->rms_px}};
  }
  return {{"odd_even", odd_even}, {"leave_one_out", loo}, {"seconds", r.seconds}};
}

std::string to_text(const Repeatability& r) {
  std::string t = "repeatability (no truth needed): ";
  if (r.odd_even_ran)
    t += format_printf(
        "odd and even views (%d + %d) solved apart differ by %.3f px RMS, max "
        "%.3f px, over the central 80%%",
        r.odd_views, r.even_views, r.odd_even_rms_px, r.odd_even_max_px);
  else
    t += "odd/even " + r.odd_even_reason;
  t += "\n";
  const ViewPrediction* worst = nullptr;
  for (const auto& v : r.left_out)
    if (!worst || v.rms_px > worst->rms_px) worst = &v;
  if (worst)
    t += format_printf(
        "  leave-one-out: %zu views each predicted by the others to %.3f px RMS; "
        "worst %s %.3f px\n",
        r.left_out.size(), r.left_out_rms_px, worst->view.c_str(), worst->rms_px);
  return t;
}

Result<Repeatability> measure_repeatability(const CalibrationData& data,
                                            const SolveOptions& options, const Solution& full) {
  const auto t0 = std::chrono::steady_clock::now();
  Repeatability out;
  odd_even(data, options, full, &out);
  if (Status s = check_not_cancelled(options.cancel, "calibration"); !s) return s.error();
  if (Status s = leave_one_out(data, options, full, &out); !s) return s.error();
  out.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return out;
}

}  // namespace camlab::calib
