// Rig views of a synchronised capture: the frames one trigger started, one per camera,
// grouped by their start times rather than by their order in each camera's capture (a
// camera that dropped or discarded a frame would otherwise pair every later frame with the
// wrong trigger). Each view's skew is the spread of its frames' starts; a view whose skew
// exceeds the request's bound is flagged, never silently paired.
//
// Grouping: all frames in order of start; a view takes frames while they start within
// half a frame interval of its first and come from cameras it does not have yet.
//
// Reentrant.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include <nlohmann/json.hpp>

namespace camlab::service {

struct FrameStart {
  int camera = 0;        // index into the request's cameras
  int frame = 0;         // the frame's index in that camera's capture (frame_NNNNNN)
  int64_t start_us = 0;  // start of exposure, Unix time
};

struct RigView {
  int64_t start_us = 0;                    // the earliest frame's start
  int64_t skew_us = 0;                     // latest minus earliest start
  std::vector<std::optional<int>> frames;  // per camera: its frame index, or none
  bool complete() const;
};

std::vector<RigView> group_rig_views(std::vector<FrameStart> starts, int cameras,
                                     int64_t frame_interval_us);

// {"views": [{"start_unix_us", "skew_us", "frames": [index or null per camera], "complete",
//  "within_bound"}], "complete", "incomplete", "over_bound", "max_skew_us" (the bound),
//  "worst_skew_us" (of the complete views, null when none)}.
nlohmann::json rig_views_json(const std::vector<RigView>& views, int64_t max_skew_us);

}  // namespace camlab::service
