#include "analysis/capture_check.h"

#include <set>
#include <string>
#include <utility>

namespace camlab::analysis {

namespace {

double number_or(const nlohmann::json& settings, const char* key, double fallback) {
  return settings.contains(key) && settings[key].is_number() ? settings[key].get<double>()
                                                             : fallback;
}

// What the frames' settings take: distinct exposure x gain pairs, f-numbers, focus positions.
struct Swept {
  std::set<std::pair<double, double>> exposures;
  std::set<double> f_numbers, focus_positions;
  std::string describe() const {
    std::string s;
    auto add = [&](const char* name, size_t n) {
      if (n < 2) return;
      s += std::string(s.empty() ? "" : ", ") + name + " (" + std::to_string(n) + " values)";
    };
    add("exposure_us x gain", exposures.size());
    add("f_number", f_numbers.size());
    add("focus_position", focus_positions.size());
    return s.empty() ? "no setting" : s;
  }
};

}  // namespace

Status check_capture_for(std::string_view analysis, const image::CaptureFolder& folder) {
  Swept swept;
  const int count = static_cast<int>(folder.frames().size());
  if (count == 0) return {};  // the analysis says "no_frames" itself
  for (int i = 0; i < count; ++i) {
    image::FrameSidecar side;
    CAMLAB_ASSIGN(side, folder.load_sidecar(i));
    const nlohmann::json& s = side.settings;
    swept.exposures.insert({number_or(s, "exposure_us", 0), number_or(s, "gain", 1)});
    if (s.contains("f_number")) swept.f_numbers.insert(number_or(s, "f_number", 0));
    if (s.contains("focus_position"))
      swept.focus_positions.insert(number_or(s, "focus_position", 0));
  }
  const std::string kind = folder.manifest().value("kind", std::string("unknown"));
  const std::string holds = "this capture (kind '" + kind + "', " + std::to_string(count) +
                            " frames) sweeps " + swept.describe();
  if (analysis == "exposure" && swept.exposures.size() < 2)
    return make_error("invalid_argument",
                      "an exposure analysis needs a bracket: frames at 2 or more exposure_us x "
                      "gain settings (a pair of each for photon transfer); " +
                          holds);
  if (analysis == "focus" && swept.focus_positions.size() < 2)
    return make_error("invalid_argument",
                      "a focus analysis needs a focus stack: frames at 2 or more focus_position "
                      "values; " +
                          holds);
  if (analysis == "lensmap" && swept.focus_positions.size() < 5)
    return make_error("invalid_argument",
                      "a lens map needs a focus sweep: frames at 5 or more focus_position values "
                      "(at each f-number), on a chart of slanted edges across the field; " +
                          holds);
  if (analysis == "defocus" && swept.exposures.size() >= 2 && swept.f_numbers.size() < 2 &&
      swept.focus_positions.size() < 2)
    return make_error("invalid_argument",
                      "a defocus analysis needs an aperture series (f_number swept), a focus "
                      "stack (focus_position swept) or frames of one setting, not an exposure "
                      "bracket; " +
                          holds);
  return {};
}

}  // namespace camlab::analysis
