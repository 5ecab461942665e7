#include "capture/frame_report.h"

#include <algorithm>
#include <cmath>
#include <optional>

namespace camlab::capture {

namespace {

struct Reported {
  const char* control;
  const char* quantity;
  double scale;  // quantity = control value x scale
};

constexpr Reported kReported[] = {
    {"exposure_time_absolute", "exposure_us", 100.0},
    {"exposure_time", "exposure_us", 1.0},
    {"analogue_gain", "analogue_gain", 1e-3},
    {"lens_position", "lens_position", 1e-3},
};

std::optional<double> reported(const device::FrameMetadata& meta, const std::string& quantity) {
  if (quantity == "exposure_us" && meta.exposure_us) return static_cast<double>(*meta.exposure_us);
  if (quantity == "analogue_gain" && meta.analogue_gain) return *meta.analogue_gain;
  if (quantity == "lens_position" && meta.lens_position) return *meta.lens_position;
  return std::nullopt;
}

bool close_enough(const std::string& quantity, double got, double want) {
  const double diff = std::abs(got - want);
  if (quantity == "exposure_us") return diff <= std::max(0.05 * std::abs(want), 30.0);
  if (quantity == "analogue_gain") return diff <= 0.05 * std::abs(want);
  return diff <= 0.05;  // lens position, dioptres
}

}  // namespace

bool is_reported_control(const std::string& name) {
  return std::any_of(std::begin(kReported), std::end(kReported),
                     [&](const Reported& r) { return name == r.control; });
}

std::map<std::string, double> expected_report(const std::map<std::string, int64_t>& controls,
                                              const std::set<std::string>& names) {
  std::map<std::string, double> out;
  for (const Reported& r : kReported) {
    if (!names.contains(r.control)) continue;
    auto it = controls.find(r.control);
    if (it != controls.end()) out[r.quantity] = static_cast<double>(it->second) * r.scale;
  }
  return out;
}

bool reports_all(const device::FrameMetadata& meta, const std::map<std::string, double>& expected) {
  return std::all_of(expected.begin(), expected.end(),
                     [&](const auto& e) { return reported(meta, e.first).has_value(); });
}

bool report_matches(const device::FrameMetadata& meta,
                    const std::map<std::string, double>& expected) {
  return std::all_of(expected.begin(), expected.end(), [&](const auto& e) {
    auto got = reported(meta, e.first);
    return got && close_enough(e.first, *got, e.second);
  });
}

nlohmann::json report_json(const device::FrameMetadata& meta) {
  nlohmann::json out = nlohmann::json::object();
  if (meta.exposure_us) out["exposure_us"] = *meta.exposure_us;
  if (meta.analogue_gain) out["analogue_gain"] = *meta.analogue_gain;
  if (meta.lens_position) out["lens_position"] = *meta.lens_position;
  if (meta.focus_fom) out["focus_fom"] = *meta.focus_fom;
  return out;
}

}  // namespace camlab::capture
