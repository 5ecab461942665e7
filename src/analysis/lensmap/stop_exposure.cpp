#include "analysis/lensmap/stop_exposure.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "base/format.h"
#include "optics/optics.h"

namespace camlab::analysis {

using nlohmann::json;

namespace {

// A setting's number, or `otherwise` where it is missing or not a number (a sidecar from
// elsewhere may carry anything).
double number_or(const json& settings, const char* key, double otherwise) {
  const auto it = settings.find(key);
  return it != settings.end() && it->is_number() ? it->get<double>() : otherwise;
}

}  // namespace

json relative_exposure_by_f_number(const json& sfr_report) {
  std::map<double, std::vector<double>> exposure;  // f-number -> each frame's T x gain / N^2
  const json frames = sfr_report.value("frames", json::array());
  if (!frames.is_array()) return json::object();
  for (const json& frame : frames) {
    if (!frame.is_object()) continue;
    const json settings = frame.value("settings", json::object());
    if (!settings.is_object()) continue;
    const double n = number_or(settings, "f_number", 0), t = number_or(settings, "exposure_us", 0);
    const double gain = number_or(settings, "gain", 1);
    const auto relative = optics::relative_exposure(n, t * 1e-6);  // T / N^2
    if (!relative || !(gain > 0)) continue;
    exposure[std::round(n * 1000) / 1000].push_back(*relative * gain);
  }
  if (exposure.empty()) return json::object();
  std::map<double, double> median;
  double highest = 0;
  for (auto& [n, values] : exposure) {
    std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
    median[n] = values[values.size() / 2];
    highest = std::max(highest, median[n]);
  }
  json out = json::object();
  for (const auto& [n, h] : median) out[format_printf("f/%g", n)] = h / highest;
  return out;
}

std::optional<std::string> unequal_exposure_warning(const json& relative_exposure) {
  if (relative_exposure.size() < 2) return std::nullopt;
  std::string lowest_name;
  double lowest = 1;
  for (const auto& [name, value] : relative_exposure.items())
    if (value.get<double>() < lowest) lowest = value.get<double>(), lowest_name = name;
  if (lowest >= 1 / std::sqrt(2.0)) return std::nullopt;
  return format_printf(
      "the f-numbers were not exposed alike: %s got %.2g of the best-exposed one's exposure "
      "(%.1f stops under), so its edges are noisier and its surface the looser for it; hold "
      "the exposure across the stops (a capture's base_exposure_us, camlab render "
      "--hold-exposure: the time grows as N^2)",
      lowest_name.c_str(), lowest, -std::log2(lowest));
}

}  // namespace camlab::analysis
