#include "analysis/analysis_summary.h"

#include <map>

#include <opencv2/core.hpp>

#include "base/format.h"

namespace camlab::analysis {

namespace {

void count_defocus(const DefocusReport& r, int* fits, int* measured,
                   std::map<std::string, int>* left_out, int* aperture_fits, int* v_fits,
                   int* targets) {
  for (const TargetDefocus& t : r.targets) {
    ++*targets;
    *aperture_fits += t.aperture ? 1 : 0;
    *v_fits += t.v_curve ? 1 : 0;
    for (const FrameEdge& fe : t.frames) {
      ++*fits;
      if (fe.edge.measured())
        ++*measured;
      else
        ++(*left_out)[fe.edge.status];
    }
  }
  for (const DefocusReport& c : r.channels)
    count_defocus(c, fits, measured, left_out, aperture_fits, v_fits, targets);
}

}  // namespace

nlohmann::json summary_json(const DefocusReport& report) {
  int fits = 0, measured = 0, aperture_fits = 0, v_fits = 0, targets = 0;
  std::map<std::string, int> left_out;
  count_defocus(report, &fits, &measured, &left_out, &aperture_fits, &v_fits, &targets);
  return {{"kind", "defocus"},     {"edge_fits", fits},  {"measured", measured},
          {"left_out", left_out},  {"targets", targets}, {"aperture_fits", aperture_fits},
          {"v_curve_fits", v_fits}};
}

nlohmann::json summary_json(const ExposureReport& report) {
  nlohmann::json channels = nlohmann::json::array();
  auto one = [](const ExposureReport& r) {
    int linearity_used = 0;
    for (const auto& p : r.linearity) linearity_used += p.used ? 1 : 0;
    return nlohmann::json{
        {"settings", r.linearity.size()},
        {"linearity_used", linearity_used},
        {"photon_transfer_used", r.photon_transfer ? r.photon_transfer->used_count : 0},
        {"left_out", r.left_out}};
  };
  if (report.channels.empty()) {
    nlohmann::json j = one(report);
    j["kind"] = "exposure";
    return j;
  }
  for (const ExposureReport& c : report.channels) {
    nlohmann::json j = one(c);
    j["channel"] = c.channel;
    channels.push_back(j);
  }
  return {{"kind", "exposure"}, {"channels", channels}};
}

nlohmann::json summary_json(const FocusReport& report) {
  std::map<std::string, int> by_status;
  for (const auto& r : report.regions) ++by_status[r.focus.status];
  const double valid =
      report.valid.empty() ? 0.0 : cv::countNonZero(report.valid) / double(report.valid.total());
  return {{"kind", "focus"},
          {"positions", report.positions.size()},
          {"regions", report.regions.size()},
          {"regions_by_status", by_status},
          {"depth_valid_share", valid}};
}

std::string summary_text(const nlohmann::json& s) {
  const std::string kind = s.value("kind", "");
  auto counts = [](const nlohmann::json& m) {
    std::string out;
    for (const auto& [key, n] : m.items())
      out += (out.empty() ? "" : ", ") + std::to_string(n.get<int>()) + " " + key;
    return out.empty() ? std::string("none") : out;
  };
  if (kind == "defocus")
    return "summary: " + std::to_string(s["measured"].get<int>()) + " of " +
           std::to_string(s["edge_fits"].get<int>()) +
           " edge fits measured; left out: " + counts(s["left_out"]) + "; " +
           std::to_string(s["aperture_fits"].get<int>()) + " C = k/N fit(s) and " +
           std::to_string(s["v_curve_fits"].get<int>()) + " V-curve fit(s) over " +
           std::to_string(s["targets"].get<int>()) + " target(s)\n";
  if (kind == "focus")
    return "summary: " + std::to_string(s["regions"].get<int>()) + " regions over " +
           std::to_string(s["positions"].get<int>()) +
           " positions: " + counts(s["regions_by_status"]) + "\n";
  if (kind == "sfr")
    return "summary: " + std::to_string(s["measured"].get<int>()) + " of " +
           std::to_string(s["edges"].get<int>()) +
           " edge fit(s) measured; left out: " + counts(s["left_out"]) + "\n";
  if (kind == "lensmap") {
    std::string stops;
    for (const auto& f : s["f_numbers"])
      stops += (stops.empty() ? "f/" : ", f/") +
               (f.is_number() ? format_printf("%g", f.get<double>()) : std::string("?"));
    return "summary: best-focus surface at " + std::to_string(s["f_numbers"].size()) +
           " f-stop(s) (" + stops + ") from " + std::to_string(s["edges_used"].get<int>()) +
           " of " + std::to_string(s["edges"].get<int>()) +
           " edge(s) through focus; left out: " + counts(s["left_out"]) + "\n";
  }
  if (kind == "exposure") {
    auto one = [](const nlohmann::json& c) {
      std::string t = std::to_string(c["settings"].get<int>()) + " settings, " +
                      std::to_string(c["linearity_used"].get<int>()) + " in the linearity fit, " +
                      std::to_string(c["photon_transfer_used"].get<int>()) +
                      " in the photon transfer fit, " + std::to_string(c["left_out"].size()) +
                      " left out (each with its reason in the report)";
      return t;
    };
    if (!s.contains("channels")) return "summary: " + one(s) + "\n";
    std::string t;
    for (const auto& c : s["channels"])
      t += "summary " + c.value("channel", std::string()) + ": " + one(c) + "\n";
    return t;
  }
  return "";
}

}  // namespace camlab::analysis
