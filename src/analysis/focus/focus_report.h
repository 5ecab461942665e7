// Focus-stack analysis of a capture folder (a focus_position sweep): frames sorted by
// focus position and streamed through FocusStackAccumulator (focus_stack.h); region and
// pixel best focus converted to focus positions (linear between frames) and to object
// distances through each frame's settings.focus_distance_m (dioptre interpolation).
//
// Colour captures: the luminance, and each channel on its own samples; JPEG captures are
// refused ("not_linear").
//
// Reentrant.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core/mat.hpp>

#include "analysis/focus/focus_stack.h"
#include "base/result.h"

namespace camlab::analysis {

struct RegionFocusReport {
  RegionFocus focus;
  double best_position = 0;          // focus_position steps (sub-step)
  std::optional<double> distance_m;  // object distance in best focus (inf allowed)
};

struct FocusReport {
  int frames = 0;
  // "" for mono captures. Colour captures: the report is the luminance's ("Y", full
  // resolution) and `channels` holds R, G and B, each on one sample plane of that colour
  // (a mosaic's: half resolution, so its regions and maps are in plane pixels).
  std::string channel;
  std::vector<FocusReport> channels;
  std::vector<double> positions;         // sorted focus positions
  std::vector<double> focus_distance_m;  // per sorted frame (+inf = infinity)
  std::vector<RegionFocusReport> regions;
  cv::Mat depth_m;        // CV_32F, object distance per pixel; 0 where not valid
  cv::Mat valid;          // CV_8U, 255 where the pixel's peak is inside and above the floor
  cv::Mat all_in_focus;   // raw DN, the frames' type
  cv::Mat best_position;  // CV_32F, focus position per pixel (sub-step)
};

Result<FocusReport> analyze_focus(const std::filesystem::path& capture_dir,
                                  const FocusStackOptions& options);

nlohmann::json to_json(const FocusReport& report);

}  // namespace camlab::analysis
