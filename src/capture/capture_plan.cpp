#include "capture/capture_plan.h"

#include <linux/videodev2.h>

#include <algorithm>
#include <cmath>
#include <optional>
#include <set>
#include <sstream>

#include "capture/settings_json.h"
#include "image/pixel_format.h"

namespace camlab::capture {

namespace {

// How much of the sensor's signal a format keeps (higher is better; -1: camlab cannot
// capture it): linear before JPEG, raw (mono, mosaic) before ISP colour, then bits, and
// mono before mosaic at equal depth.
int format_rank(const std::string& fourcc) {
  const auto info = image::pixel_format_info(fourcc);
  if (!info) return -1;
  if (!info->linear) return 0;
  if (info->layout == image::FrameLayout::kRgb || info->packing == image::SamplePacking::kYuyv)
    return 1;
  return 2 + 2 * info->bits_per_sample + (info->layout == image::FrameLayout::kMono ? 1 : 0);
}

using json = nlohmann::json;

constexpr const char* kExposure = "exposure_time_absolute";
constexpr const char* kExposureAuto = "auto_exposure";
constexpr const char* kGain = "gain";
constexpr const char* kFocus = "focus_absolute";
constexpr const char* kFocusAuto = "focus_automatic_continuous";
constexpr const char* kIris = "iris_absolute";
constexpr size_t kMaxLabelChars = 200;
// A requested f-number matches an iris stop within this relative difference: lenses
// engrave rounded stops (5.6 for 5.657).
constexpr double kFNumberTolerance = 0.03;

Error invalid(const std::string& message) { return make_error("invalid_request", message); }
Error out_of_range(const std::string& message) { return make_error("out_of_range", message); }

std::string number_text(double value) {
  std::ostringstream out;
  out << value;
  return out.str();
}

class PlanBuilder {
 public:
  PlanBuilder(const json& request, const std::vector<device::ControlInfo>& controls,
              const std::vector<device::PixelFormatInfo>& formats, const CameraTraits& traits)
      : request_(request), controls_(controls), formats_(formats), traits_(traits) {}

  Result<CapturePlan> build();

 private:
  Status check_fields(const std::set<std::string>& kind_fields) const;
  Status read_format();
  Status read_fixed_controls();
  Status add_fixed(const std::string& name, int64_t value, const std::string& why);
  Status build_single();
  Status build_bracket();
  Status build_focus_stack();
  Status build_aperture_series();
  Status build_lens_map();

  // One stepped control's values: the value and what it stands for (a step's `requested`).
  using ControlSteps = std::vector<std::pair<int64_t, json>>;
  Result<ControlSteps> focus_steps(const device::ControlInfo& c) const;
  Result<ControlSteps> iris_steps(const device::ControlInfo& c) const;
  // base_exposure_us, when asked: each stop's exposure-time units, the time asked added to
  // its `requested`; none (nullopt each) when not asked.
  Result<std::vector<std::optional<int64_t>>> held_exposure(ControlSteps* iris) const;

  Result<const device::ControlInfo*> require_control(const std::string& name,
                                                     const std::string& kind) const;
  const device::ControlInfo* find_control(const std::string& name) const;
  Result<int64_t> integer(const json& value, const std::string& field) const;
  Result<double> number(const json& value, const std::string& field) const;
  Result<std::vector<json>> list(const std::string& key) const;
  // A list of values of control `c` (whole numbers on its grid) under `key`.
  Result<std::vector<int64_t>> control_values(const std::string& key,
                                              const device::ControlInfo& c) const;
  Status check_value(const device::ControlInfo& c, int64_t value, const std::string& field) const;
  Result<int64_t> exposure_units(const device::ControlInfo& c, double exposure_us,
                                 bool round_to_grid, const std::string& field) const;
  void add_step(std::map<std::string, int64_t> controls, json requested);

  const json& request_;
  const std::vector<device::ControlInfo>& controls_;
  const std::vector<device::PixelFormatInfo>& formats_;
  const CameraTraits& traits_;
  CapturePlan plan_;
};

const device::ControlInfo* PlanBuilder::find_control(const std::string& name) const {
  auto it = std::find_if(controls_.begin(), controls_.end(),
                         [&](const auto& c) { return c.name == name; });
  return it == controls_.end() ? nullptr : &*it;
}

Result<const device::ControlInfo*> PlanBuilder::require_control(const std::string& name,
                                                                const std::string& kind) const {
  const device::ControlInfo* c = find_control(name);
  if (!c)
    return make_error("unsupported",
                      "this camera has no " + name + " control, which " + kind + " needs");
  if (c->read_only)
    return make_error("unsupported", "this camera's " + name + " control is read-only");
  return c;
}

Result<int64_t> PlanBuilder::integer(const json& value, const std::string& field) const {
  if (value.is_number_integer()) {
    if (value.is_number_unsigned() && value.get<uint64_t>() > static_cast<uint64_t>(INT64_MAX))
      return invalid(field + " is too large");
    return value.get<int64_t>();
  }
  // 1000.0 from a client that only has doubles is still a whole number.
  if (value.is_number_float()) {
    const double v = value.get<double>();
    if (std::isfinite(v) && v == std::floor(v) && std::abs(v) < 9e15)
      return static_cast<int64_t>(v);
  }
  return invalid(field + " must be a whole number, not " + value.dump());
}

Result<double> PlanBuilder::number(const json& value, const std::string& field) const {
  if (!value.is_number()) return invalid(field + " must be a number, not " + value.dump());
  const double v = value.get<double>();
  if (!std::isfinite(v)) return invalid(field + " must be finite");
  return v;
}

Result<std::vector<json>> PlanBuilder::list(const std::string& key) const {
  const json& value = request_.at(key);
  if (!value.is_array()) return invalid(key + " must be a list");
  if (value.empty()) return invalid(key + " must not be empty");
  if (value.size() > static_cast<size_t>(kMaxStepsPerPlan))
    return invalid(key + " has " + std::to_string(value.size()) + " entries; at most " +
                   std::to_string(kMaxStepsPerPlan) + " steps per capture");
  return std::vector<json>(value.begin(), value.end());
}

Result<std::vector<int64_t>> PlanBuilder::control_values(const std::string& key,
                                                         const device::ControlInfo& c) const {
  std::vector<json> items;
  CAMLAB_ASSIGN(items, list(key));
  std::vector<int64_t> values;
  for (size_t i = 0; i < items.size(); ++i) {
    const std::string field = key + "[" + std::to_string(i) + "]";
    int64_t v = 0;
    CAMLAB_ASSIGN(v, integer(items[i], field));
    if (Status s = check_value(c, v, field); !s) return s.error();
    values.push_back(v);
  }
  return values;
}

Status PlanBuilder::check_value(const device::ControlInfo& c, int64_t value,
                                const std::string& field) const {
  const std::string unit = c.unit.empty() ? "" : " " + c.unit;
  if (c.type == device::ControlType::kMenu || c.type == device::ControlType::kIntegerMenu) {
    std::string allowed;
    for (const auto& [index, name] : c.menu) {
      if (index == value) return {};
      allowed += (allowed.empty() ? "" : ", ") + std::to_string(index) + " (" + name + ")";
    }
    return out_of_range(field + " = " + std::to_string(value) + " is not one of " + c.name +
                        "'s values: " + allowed);
  }
  if (value < c.minimum || value > c.maximum)
    return out_of_range(field + " = " + std::to_string(value) + " is outside " + c.name +
                        "'s range [" + std::to_string(c.minimum) + ", " +
                        std::to_string(c.maximum) + "]" + unit);
  const int64_t step = std::max<int64_t>(c.step, 1);
  if ((value - c.minimum) % step != 0)
    return out_of_range(field + " = " + std::to_string(value) + " is not on " + c.name +
                        "'s grid: " + std::to_string(c.minimum) + ".." + std::to_string(c.maximum) +
                        " in steps of " + std::to_string(step) + unit);
  return {};
}

Result<int64_t> PlanBuilder::exposure_units(const device::ControlInfo& c, double exposure_us,
                                            bool round_to_grid, const std::string& field) const {
  // exposure_time_absolute counts 100 us (V4L2); the message speaks microseconds.
  const int64_t step = std::max<int64_t>(c.step, 1);
  const std::string allowed = "the camera's exposure range is " + std::to_string(c.minimum * 100) +
                              ".." + std::to_string(c.maximum * 100) + " us in steps of " +
                              std::to_string(step * 100) + " us";
  const double grid_index =
      (exposure_us / 100.0 - static_cast<double>(c.minimum)) / static_cast<double>(step);
  const double nearest = std::round(grid_index);
  if (!round_to_grid && std::abs(grid_index - nearest) > 1e-6)
    return out_of_range(field + " = " + number_text(exposure_us) +
                        " us is not on the exposure grid: " + allowed);
  const double units = static_cast<double>(c.minimum) + nearest * static_cast<double>(step);
  if (!(units >= static_cast<double>(c.minimum) && units <= static_cast<double>(c.maximum)))
    return out_of_range(field + " = " + number_text(exposure_us) +
                        " us is out of range: " + allowed);
  return static_cast<int64_t>(units);
}

Status PlanBuilder::check_fields(const std::set<std::string>& kind_fields) const {
  static const std::set<std::string> common = {"kind",  "repeats",     "format", "controls",
                                               "label", "exposure_us", "gain"};
  for (const auto& [key, value] : request_.items()) {
    if (common.count(key) || kind_fields.count(key)) continue;
    std::string allowed;
    for (const auto& k : common) allowed += (allowed.empty() ? "" : ", ") + k;
    for (const auto& k : kind_fields) allowed += ", " + k;
    return invalid("unknown field '" + key + "' for kind " + plan_.kind + " (allowed: " + allowed +
                   ")");
  }
  return {};
}

Status PlanBuilder::read_format() {
  if (formats_.empty()) return make_error("unsupported", "the camera lists no pixel formats");
  json format = request_.value("format", json::object());
  if (!format.is_object())
    return invalid("format must be an object {fourcc, width, height, frame_interval_us}");
  for (const auto& [key, value] : format.items())
    if (key != "fourcc" && key != "width" && key != "height" && key != "frame_interval_us")
      return invalid("unknown field 'format." + key +
                     "' (allowed: fourcc, width, height, frame_interval_us)");

  const device::PixelFormatInfo* chosen = nullptr;
  if (format.contains("fourcc")) {
    if (!format["fourcc"].is_string() || format["fourcc"].get<std::string>().empty() ||
        format["fourcc"].get<std::string>().size() > 4)
      return invalid("format.fourcc must be a V4L2 fourcc of 1 to 4 characters, e.g. \"Y16\"");
    std::string fourcc = format["fourcc"].get<std::string>();
    fourcc.resize(4, ' ');
    std::string listed;
    for (const auto& f : formats_) {
      if (f.fourcc == fourcc) chosen = &f;
      listed += (listed.empty() ? "" : ", ") + f.fourcc;
    }
    if (!chosen)
      return out_of_range("format.fourcc '" + fourcc +
                          "' is not offered by the camera (it offers: " + listed + ")");
  } else {
    // The format that keeps the most of the sensor's DN: raw before processed, deeper
    // before shallower, and JPEG (lossy, not linear) only when nothing else is offered.
    int best_rank = -1;
    for (const auto& f : formats_) {
      const int rank = format_rank(f.fourcc);
      if (rank > best_rank) best_rank = rank, chosen = &f;
    }
    if (!chosen) chosen = &formats_.front();
  }
  if (chosen->sizes.empty())
    return make_error("unsupported", "the camera lists no frame sizes for " + chosen->fourcc);

  const device::FrameSizeInfo* size = nullptr;
  if (format.contains("width") != format.contains("height"))
    return invalid("format needs both width and height, or neither");
  if (format.contains("width")) {
    int64_t width = 0, height = 0;
    CAMLAB_ASSIGN(width, integer(format["width"], "format.width"));
    CAMLAB_ASSIGN(height, integer(format["height"], "format.height"));
    std::string listed;
    for (const auto& s : chosen->sizes) {
      if (s.width == width && s.height == height) size = &s;
      listed +=
          (listed.empty() ? "" : ", ") + std::to_string(s.width) + "x" + std::to_string(s.height);
    }
    if (!size)
      return out_of_range("format " + std::to_string(width) + "x" + std::to_string(height) +
                          " is not offered for " + chosen->fourcc + " (sizes: " + listed + ")");
  } else {
    size = &*std::max_element(chosen->sizes.begin(), chosen->sizes.end(),
                              [](const auto& a, const auto& b) {
                                return uint64_t{a.width} * a.height < uint64_t{b.width} * b.height;
                              });
  }

  plan_.format.fourcc = chosen->fourcc;
  plan_.format.width = size->width;
  plan_.format.height = size->height;
  if (format.contains("frame_interval_us")) {
    double interval_us = 0;
    CAMLAB_ASSIGN(interval_us, number(format["frame_interval_us"], "format.frame_interval_us"));
    if (!(interval_us > 0 && interval_us < 1e9))
      return invalid("format.frame_interval_us must be positive");
    std::string listed;
    bool found = false;
    for (const auto& i : size->intervals) {
      const double listed_us = i.seconds() * 1e6;
      found |= std::abs(listed_us - interval_us) <= 0.005 * listed_us;
      listed += (listed.empty() ? "" : ", ") + number_text(listed_us);
    }
    // A camera that lists no intervals (stepwise/continuous) gets the request as is.
    if (!found && !size->intervals.empty())
      return out_of_range("format.frame_interval_us = " + number_text(interval_us) +
                          " is not offered at " + std::to_string(size->width) + "x" +
                          std::to_string(size->height) + " (intervals: " + listed + " us)");
    plan_.format.interval = {static_cast<uint32_t>(std::lround(interval_us)), 1000000};
  }
  return {};
}

Status PlanBuilder::add_fixed(const std::string& name, int64_t value, const std::string& why) {
  auto [it, inserted] = plan_.fixed_controls.emplace(name, value);
  if (!inserted && it->second != value)
    return invalid("controls." + name + " = " + std::to_string(it->second) + " contradicts " + why +
                   " (which sets " + std::to_string(value) + ")");
  return {};
}

Status PlanBuilder::read_fixed_controls() {
  if (request_.contains("controls")) {
    const json& controls = request_["controls"];
    if (!controls.is_object())
      return invalid("controls must be an object of V4L2 control names to values");
    if (controls.size() > static_cast<size_t>(kMaxFixedControls))
      return invalid("controls has " + std::to_string(controls.size()) + " entries; at most " +
                     std::to_string(kMaxFixedControls));
    for (const auto& [name, value] : controls.items()) {
      const device::ControlInfo* c = find_control(name);
      if (!c) {
        std::string known;
        for (const auto& k : controls_) known += (known.empty() ? "" : ", ") + k.name;
        return invalid("controls." + name + ": the camera has no such control (it has: " + known +
                       ")");
      }
      if (c->read_only) return make_error("unsupported", "controls." + name + " is read-only");
      int64_t v = 0;
      CAMLAB_ASSIGN(v, integer(value, "controls." + name));
      if (Status s = check_value(*c, v, "controls." + name); !s) return s;
      plan_.fixed_controls[name] = v;
    }
  }
  if (request_.contains("exposure_us")) {
    const device::ControlInfo* c = nullptr;
    CAMLAB_ASSIGN(c, require_control(kExposure, "exposure_us"));
    double us = 0;
    CAMLAB_ASSIGN(us, number(request_["exposure_us"], "exposure_us"));
    int64_t units = 0;
    CAMLAB_ASSIGN(units, exposure_units(*c, us, false, "exposure_us"));
    if (Status s = add_fixed(kExposure, units, "exposure_us"); !s) return s;
  }
  if (request_.contains("gain")) {
    const device::ControlInfo* c = nullptr;
    CAMLAB_ASSIGN(c, require_control(kGain, "gain"));
    int64_t gain = 0;
    CAMLAB_ASSIGN(gain, integer(request_["gain"], "gain"));
    if (Status s = check_value(*c, gain, "gain"); !s) return s;
    if (Status s = add_fixed(kGain, gain, "gain"); !s) return s;
  }
  return {};
}

void PlanBuilder::add_step(std::map<std::string, int64_t> controls, json requested) {
  CaptureStep step;
  step.controls = std::move(controls);
  step.requested = std::move(requested);
  step.labels = {{"step_index", static_cast<int>(plan_.steps.size())}};
  plan_.steps.push_back(std::move(step));
}

Status PlanBuilder::build_single() {
  if (Status s = check_fields({}); !s) return s;
  add_step({}, json::object());
  return {};
}

Status PlanBuilder::build_bracket() {
  if (Status s = check_fields({"exposures_us", "base_exposure_us", "ev_steps"}); !s) return s;
  if (request_.contains("exposure_us"))
    return invalid("a bracket steps the exposure: give exposures_us or ev_steps, not exposure_us");
  const device::ControlInfo* c = nullptr;
  CAMLAB_ASSIGN(c, require_control(kExposure, "an exposure bracket"));
  const bool explicit_list = request_.contains("exposures_us");
  if (explicit_list == (request_.contains("base_exposure_us") || request_.contains("ev_steps")))
    return invalid("a bracket needs either exposures_us, or base_exposure_us with ev_steps");
  std::vector<double> exposures_us;
  if (explicit_list) {
    std::vector<json> items;
    CAMLAB_ASSIGN(items, list("exposures_us"));
    for (size_t i = 0; i < items.size(); ++i) {
      double us = 0;
      CAMLAB_ASSIGN(us, number(items[i], "exposures_us[" + std::to_string(i) + "]"));
      exposures_us.push_back(us);
    }
  } else {
    if (!request_.contains("base_exposure_us") || !request_.contains("ev_steps"))
      return invalid("an EV bracket needs both base_exposure_us and ev_steps");
    double base_us = 0;
    CAMLAB_ASSIGN(base_us, number(request_["base_exposure_us"], "base_exposure_us"));
    if (!(base_us > 0)) return invalid("base_exposure_us must be positive");
    std::vector<json> items;
    CAMLAB_ASSIGN(items, list("ev_steps"));
    for (size_t i = 0; i < items.size(); ++i) {
      double ev = 0;
      CAMLAB_ASSIGN(ev, number(items[i], "ev_steps[" + std::to_string(i) + "]"));
      if (std::abs(ev) > 20)
        return invalid("ev_steps[" + std::to_string(i) + "] = " + number_text(ev) +
                       " is beyond +-20 EV");
      exposures_us.push_back(base_us * std::exp2(ev));  // +1 EV of exposure = twice the time
    }
  }
  for (size_t i = 0; i < exposures_us.size(); ++i) {
    const std::string field = explicit_list
                                  ? "exposures_us[" + std::to_string(i) + "]"
                                  : "base_exposure_us x 2^ev_steps[" + std::to_string(i) + "]";
    int64_t units = 0;
    CAMLAB_ASSIGN(units, exposure_units(*c, exposures_us[i], !explicit_list, field));
    add_step({{kExposure, units}}, {{"exposure_us", exposures_us[i]}});
  }
  // Manual exposure, or the camera would override the bracket.
  if (find_control(kExposureAuto))
    return add_fixed(kExposureAuto, V4L2_EXPOSURE_MANUAL, "an exposure bracket");
  return {};
}

Result<PlanBuilder::ControlSteps> PlanBuilder::focus_steps(const device::ControlInfo& c) const {
  std::vector<int64_t> positions;
  const bool explicit_list = request_.contains("positions");
  const bool range =
      request_.contains("start") || request_.contains("stop") || request_.contains("step");
  if (explicit_list == range)
    return invalid("a focus stack needs either positions, or start, stop and step");
  if (explicit_list) {
    CAMLAB_ASSIGN(positions, control_values("positions", c));
  } else {
    if (!request_.contains("start") || !request_.contains("stop") || !request_.contains("step"))
      return invalid("a focus range needs start, stop and step");
    int64_t start = 0, stop = 0, step = 0;
    CAMLAB_ASSIGN(start, integer(request_["start"], "start"));
    CAMLAB_ASSIGN(stop, integer(request_["stop"], "stop"));
    CAMLAB_ASSIGN(step, integer(request_["step"], "step"));
    if (Status s = check_value(c, start, "start"); !s) return s.error();
    if (Status s = check_value(c, stop, "stop"); !s) return s.error();
    if (step == 0 || (stop > start && step < 0) || (stop < start && step > 0))
      return invalid("step = " + std::to_string(step) + " does not lead from start = " +
                     std::to_string(start) + " to stop = " + std::to_string(stop));
    // Both ends are inside the control's range, so the count cannot overflow.
    const int64_t count = (stop - start) / step + 1;
    if (count > kMaxStepsPerPlan)
      return invalid("start..stop in steps of " + std::to_string(step) + " makes " +
                     std::to_string(count) + " positions; at most " +
                     std::to_string(kMaxStepsPerPlan));
    for (int64_t i = 0; i < count; ++i) {
      const int64_t p = start + i * step;
      if (Status s = check_value(c, p, "start + " + std::to_string(i) + " x step"); !s)
        return s.error();
      positions.push_back(p);
    }
  }
  ControlSteps out;
  for (int64_t p : positions) {
    json requested = {{"focus_position", p}};
    add_physical_focus(traits_, p, &requested);
    out.emplace_back(p, std::move(requested));
  }
  return out;
}

Result<PlanBuilder::ControlSteps> PlanBuilder::iris_steps(const device::ControlInfo& c) const {
  const bool by_f_number = request_.contains("f_numbers");
  if (by_f_number == request_.contains("iris_positions"))
    return invalid("an aperture series needs either f_numbers or iris_positions");
  const auto& table = traits_.f_number_by_iris_position;
  ControlSteps out;
  if (by_f_number) {
    if (table.empty())
      return make_error(
          "unsupported",
          "this camera's iris positions have no known f-numbers; ask for iris_positions");
    std::string stops;
    for (int64_t p = c.minimum; p <= c.maximum && p < static_cast<int64_t>(table.size()); ++p)
      if (p >= 0)
        stops += (stops.empty() ? "f/" : ", f/") + number_text(table[static_cast<size_t>(p)]);
    std::vector<json> items;
    CAMLAB_ASSIGN(items, list("f_numbers"));
    for (size_t i = 0; i < items.size(); ++i) {
      const std::string field = "f_numbers[" + std::to_string(i) + "]";
      double n = 0;
      CAMLAB_ASSIGN(n, number(items[i], field));
      if (!(n > 0)) return invalid(field + " must be positive");
      int64_t best = -1;
      for (int64_t p = std::max<int64_t>(c.minimum, 0);
           p <= c.maximum && p < static_cast<int64_t>(table.size()); ++p)
        if (std::abs(table[static_cast<size_t>(p)] / n - 1) <= kFNumberTolerance &&
            (best < 0 || std::abs(table[static_cast<size_t>(p)] - n) <
                             std::abs(table[static_cast<size_t>(best)] - n)))
          best = p;
      if (best < 0)
        return out_of_range(field + " = f/" + number_text(n) +
                            " is not one of this lens's iris stops: " + stops);
      out.emplace_back(
          best, json{{"f_number", table[static_cast<size_t>(best)]}, {"iris_position", best}});
    }
  } else {
    std::vector<int64_t> positions;
    CAMLAB_ASSIGN(positions, control_values("iris_positions", c));
    for (int64_t p : positions) {
      json requested = {{"iris_position", p}};
      if (p >= 0 && p < static_cast<int64_t>(table.size()))
        requested["f_number"] = table[static_cast<size_t>(p)];
      out.emplace_back(p, std::move(requested));
    }
  }
  return out;
}

// base_exposure_us is the first stop's exposure time, each other's grown as (N / first N)^2
// so that every stop is exposed alike (the image-side irradiance goes as 1 / N^2): at one
// time for all, f/5.6 lies four stops under f/1.4, its edges' noise four times as large
// against their contrast, and a lens map's best foci that much looser (docs/analysis.md,
// "Lens map").
Result<std::vector<std::optional<int64_t>>> PlanBuilder::held_exposure(ControlSteps* iris) const {
  std::vector<std::optional<int64_t>> exposure(iris->size());
  if (!request_.contains("base_exposure_us")) return exposure;
  if (request_.contains("exposure_us"))
    return invalid(
        "give exposure_us (one time for every stop) or base_exposure_us (the first stop's, "
        "the others' grown to the same exposure), not both");
  const device::ControlInfo* c = nullptr;
  CAMLAB_ASSIGN(c, require_control(kExposure, "base_exposure_us"));
  double base_us = 0;
  CAMLAB_ASSIGN(base_us, number(request_["base_exposure_us"], "base_exposure_us"));
  if (!(base_us > 0)) return invalid("base_exposure_us must be positive");
  for (const auto& [stop, requested] : *iris)
    if (!requested.contains("f_number"))
      return make_error("unsupported",
                        "base_exposure_us needs each stop's f-number; iris position " +
                            std::to_string(stop) + " has none known");
  const double first_n = iris->front().second["f_number"].get<double>();
  for (size_t i = 0; i < iris->size(); ++i) {
    json& requested = (*iris)[i].second;
    const double n = requested["f_number"].get<double>();
    const double us = base_us * (n / first_n) * (n / first_n);
    int64_t units = 0;
    CAMLAB_ASSIGN(units, exposure_units(*c, us, true,
                                        "base_exposure_us x (f/" + number_text(n) + " / f/" +
                                            number_text(first_n) + ")^2"));
    exposure[i] = units;
    requested["exposure_us"] = us;
  }
  return exposure;
}

Status PlanBuilder::build_focus_stack() {
  if (Status s = check_fields({"positions", "start", "stop", "step"}); !s) return s;
  const device::ControlInfo* c = nullptr;
  CAMLAB_ASSIGN(c, require_control(kFocus, "a focus stack"));
  ControlSteps focus;
  CAMLAB_ASSIGN(focus, focus_steps(*c));
  for (auto& [p, requested] : focus) add_step({{kFocus, p}}, std::move(requested));
  if (find_control(kFocusAuto)) return add_fixed(kFocusAuto, 0, "a focus stack");
  return {};
}

Status PlanBuilder::build_aperture_series() {
  if (Status s = check_fields({"f_numbers", "iris_positions", "base_exposure_us"}); !s) return s;
  const device::ControlInfo* c = nullptr;
  CAMLAB_ASSIGN(c, require_control(kIris, "an aperture series"));
  ControlSteps iris;
  CAMLAB_ASSIGN(iris, iris_steps(*c));
  std::vector<std::optional<int64_t>> exposure;
  CAMLAB_ASSIGN(exposure, held_exposure(&iris));
  for (size_t i = 0; i < iris.size(); ++i) {
    std::map<std::string, int64_t> controls = {{kIris, iris[i].first}};
    if (exposure[i]) controls[kExposure] = *exposure[i];
    add_step(std::move(controls), std::move(iris[i].second));
  }
  // Aperture priority would undo the series by changing the exposure time.
  if (find_control(kExposureAuto))
    return add_fixed(kExposureAuto, V4L2_EXPOSURE_MANUAL, "an aperture series");
  return {};
}

// A lens map's grid: every iris stop x every focus position, the focus stepped inside each
// stop (one iris move per stop; the lens map reads one focus sweep per f-number), the
// exposure held across the stops when base_exposure_us asks (held_exposure).
Status PlanBuilder::build_lens_map() {
  if (Status s = check_fields({"f_numbers", "iris_positions", "positions", "start", "stop", "step",
                               "base_exposure_us"});
      !s)
    return s;
  const device::ControlInfo *focus_control = nullptr, *iris_control = nullptr;
  CAMLAB_ASSIGN(focus_control, require_control(kFocus, "a lens map"));
  CAMLAB_ASSIGN(iris_control, require_control(kIris, "a lens map"));
  ControlSteps focus, iris;
  CAMLAB_ASSIGN(iris, iris_steps(*iris_control));
  CAMLAB_ASSIGN(focus, focus_steps(*focus_control));
  if (iris.size() * focus.size() > static_cast<size_t>(kMaxStepsPerPlan))
    return invalid(std::to_string(iris.size()) + " stops x " + std::to_string(focus.size()) +
                   " focus positions = " + std::to_string(iris.size() * focus.size()) +
                   " steps; at most " + std::to_string(kMaxStepsPerPlan));
  std::vector<std::optional<int64_t>> exposure;
  CAMLAB_ASSIGN(exposure, held_exposure(&iris));
  for (size_t i = 0; i < iris.size(); ++i)
    for (const auto& [position, focus_requested] : focus) {
      json requested = iris[i].second;
      requested.update(focus_requested);
      std::map<std::string, int64_t> controls = {{kIris, iris[i].first}, {kFocus, position}};
      if (exposure[i]) controls[kExposure] = *exposure[i];
      add_step(std::move(controls), std::move(requested));
    }
  if (find_control(kFocusAuto))
    if (Status s = add_fixed(kFocusAuto, 0, "a lens map"); !s) return s;
  if (find_control(kExposureAuto))
    return add_fixed(kExposureAuto, V4L2_EXPOSURE_MANUAL, "a lens map");
  return {};
}

Result<CapturePlan> PlanBuilder::build() {
  if (!request_.is_object()) return invalid("the capture request must be a JSON object");
  if (!request_.contains("kind") || !request_["kind"].is_string())
    return invalid("kind is required: single, bracket, focus_stack, aperture_series or lens_map");
  plan_.kind = request_["kind"].get<std::string>();
  if (request_.contains("repeats")) {
    int64_t repeats = 0;
    CAMLAB_ASSIGN(repeats, integer(request_["repeats"], "repeats"));
    if (repeats < 1 || repeats > kMaxRepeats)
      return invalid("repeats = " + std::to_string(repeats) + " is not in 1.." +
                     std::to_string(kMaxRepeats));
    plan_.repeats = static_cast<int>(repeats);
  }
  std::string label;
  if (request_.contains("label")) {
    if (!request_["label"].is_string() ||
        request_["label"].get<std::string>().size() > kMaxLabelChars)
      return invalid("label must be a string of at most " + std::to_string(kMaxLabelChars) +
                     " characters");
    label = request_["label"].get<std::string>();
  }
  // Fixed controls first: a kind's own settings then win a contradiction with an error.
  if (Status s = read_fixed_controls(); !s) return s.error();
  Status built;
  if (plan_.kind == "single")
    built = build_single();
  else if (plan_.kind == "bracket")
    built = build_bracket();
  else if (plan_.kind == "focus_stack")
    built = build_focus_stack();
  else if (plan_.kind == "aperture_series")
    built = build_aperture_series();
  else if (plan_.kind == "lens_map")
    built = build_lens_map();
  else
    return invalid("unknown kind '" + plan_.kind +
                   "' (single, bracket, focus_stack, aperture_series, lens_map)");
  if (!built) return built.error();
  for (const auto& step : plan_.steps)
    for (const auto& [name, value] : step.controls)
      if (plan_.fixed_controls.count(name))
        return invalid("controls." + name + " contradicts the " + plan_.kind + ", which steps " +
                       name);
  if (Status s = read_format(); !s) return s.error();
  if (plan_.total_frames() > kMaxFramesPerPlan)
    return invalid(std::to_string(plan_.steps.size()) + " steps x " +
                   std::to_string(plan_.repeats) +
                   " repeats = " + std::to_string(plan_.total_frames()) + " frames; at most " +
                   std::to_string(kMaxFramesPerPlan) + " per capture");

  plan_.traits = traits_;
  json steps = json::array();
  for (const auto& step : plan_.steps) steps.push_back(step.requested);
  plan_.request = {
      {"kind", plan_.kind},
      {"repeats", plan_.repeats},
      {"format",
       {{"fourcc", plan_.format.fourcc},
        {"width", plan_.format.width},
        {"height", plan_.format.height}}},
      {"controls", plan_.fixed_controls},
      {"steps", std::move(steps)},
  };
  if (plan_.format.interval.denominator != 0)
    plan_.request["format"]["frame_interval_us"] = plan_.format.interval.seconds() * 1e6;
  if (!label.empty()) plan_.request["label"] = label;
  return std::move(plan_);
}

}  // namespace

Result<CapturePlan> plan_capture(const nlohmann::json& request,
                                 const std::vector<device::ControlInfo>& controls,
                                 const std::vector<device::PixelFormatInfo>& formats,
                                 const CameraTraits& traits) {
  return PlanBuilder(request, controls, formats, traits).build();
}

}  // namespace camlab::capture
