#include "service/jobs/rig_views.h"

#include <algorithm>

namespace camlab::service {

bool RigView::complete() const {
  return std::all_of(frames.begin(), frames.end(), [](const auto& f) { return f.has_value(); });
}

std::vector<RigView> group_rig_views(std::vector<FrameStart> starts, int cameras,
                                     int64_t frame_interval_us) {
  std::stable_sort(starts.begin(), starts.end(), [](const FrameStart& a, const FrameStart& b) {
    return a.start_us < b.start_us;
  });
  // Without an interval, frames apart by 50 ms or more are other triggers.
  const int64_t window_us = frame_interval_us > 0 ? frame_interval_us / 2 : 50'000;
  std::vector<RigView> views;
  for (const FrameStart& s : starts) {
    if (s.camera < 0 || s.camera >= cameras) continue;
    RigView* view = views.empty() ? nullptr : &views.back();
    if (!view || s.start_us - view->start_us >= window_us ||
        view->frames[static_cast<size_t>(s.camera)]) {
      views.push_back(
          {s.start_us, 0, std::vector<std::optional<int>>(static_cast<size_t>(cameras))});
      view = &views.back();
    }
    view->frames[static_cast<size_t>(s.camera)] = s.frame;
    view->skew_us = s.start_us - view->start_us;
  }
  return views;
}

nlohmann::json rig_views_json(const std::vector<RigView>& views, int64_t max_skew_us) {
  nlohmann::json list = nlohmann::json::array();
  int complete = 0, over_bound = 0;
  std::optional<int64_t> worst_us;
  for (const RigView& v : views) {
    nlohmann::json frames = nlohmann::json::array();
    for (const auto& f : v.frames) frames.push_back(f ? nlohmann::json(*f) : nlohmann::json());
    const bool within = v.skew_us <= max_skew_us;
    list.push_back({{"start_unix_us", v.start_us},
                    {"skew_us", v.skew_us},
                    {"frames", frames},
                    {"complete", v.complete()},
                    {"within_bound", within}});
    if (!v.complete()) continue;
    ++complete;
    if (!within) ++over_bound;
    worst_us = std::max(worst_us.value_or(v.skew_us), v.skew_us);
  }
  return {{"views", list},
          {"complete", complete},
          {"incomplete", static_cast<int>(views.size()) - complete},
          {"over_bound", over_bound},
          {"max_skew_us", max_skew_us},
          {"worst_skew_us", worst_us ? nlohmann::json(*worst_us) : nlohmann::json()}};
}

}  // namespace camlab::service
