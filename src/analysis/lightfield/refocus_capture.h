// Refocused images as a capture folder (docs/capture-folder.md, kind "refocus"), so that
// camlab's existing analyses read them: a sweep of focus distances is a focus stack
// (`camlab analyze focus`: depth from focus after capture), a set of synthetic f-numbers
// an aperture series (`camlab analyze defocus`: the blur against the synthetic aperture).
//
// Each frame is one (focus distance, f-number) pair, refocused (refocus.h) and stored as
// a frame of the views' bit depth, rounded. Its settings are those of the virtual
// sensor it stands for: focus_distance_m, lens_to_sensor_mm = z_r, f_number = the
// synthetic aperture's effective f-number, focus_position = the distance's place from the
// farthest (0) to the nearest, as a lens's focus steps run; exposure and gain as
// captured. Frames carry no truth.
//
// Reentrant.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "analysis/lightfield/light_field.h"
#include "analysis/lightfield/refocus.h"
#include "base/result.h"

namespace camlab::analysis::lightfield {

// `frames` distances from near_m to far_m (metres, far may be infinite), evenly spaced
// in dioptres (1/m) as a focus motor's steps nearly are. Errors: "out_of_range" (frames
// not in 2..1000, near_m not below far_m, near_m not positive).
Result<std::vector<double>> focus_sweep_m(double near_m, double far_m, int frames);

struct RefocusCaptureSummary {
  std::filesystem::path out_dir;
  int frames = 0;
  nlohmann::json frames_json = nlohmann::json::array();  // per frame: what was made
  std::vector<std::string> warnings;                     // each once
  double seconds = 0;
};

// One frame per distance (far to near) and f-number (0: the captured aperture). Errors:
// those of refocus() (checked for every pair before the first frame is written) and of
// the folder.
Result<RefocusCaptureSummary> write_refocus_capture(const LightField& light_field,
                                                    const std::vector<double>& focus_m,
                                                    const std::vector<double>& f_numbers,
                                                    const std::filesystem::path& out_dir);

// What refocus() made, without the image, as JSON (infinite distances null).
nlohmann::json to_json(const RefocusResult& result);

}  // namespace camlab::analysis::lightfield
