// Capture-folder focus-stack analysis.
#include "analysis/focus/focus_report.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

#include "analysis/channel_signal.h"
#include "base/cancel.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"

namespace camlab::analysis {
namespace {

using nlohmann::json;

json num(double v) { return std::isfinite(v) ? json(v) : json(nullptr); }

double position_at(const std::vector<double>& positions, double index) {
  const double last = static_cast<double>(positions.size() - 1);
  const double i = std::clamp(index, 0.0, last);
  const size_t i0 = static_cast<size_t>(std::floor(i));
  const size_t i1 = std::min(i0 + 1, positions.size() - 1);
  const double t = i - static_cast<double>(i0);
  return (1.0 - t) * positions[i0] + t * positions[i1];
}

struct Entry {
  int index;
  double position, distance_m, lens_to_sensor_mm;
};

// The image a focus stack of `view` reads: the mono frame (""), the luminance of a colour
// frame ("Y"), or one plane of channel R, G or B (a mosaic's first plane of that colour,
// at half resolution; an RGB frame's plane).
// A frame with the curve its camera declared (a webcam's YUYV) is decoded to light first.
Result<cv::Mat> view_of(const image::CaptureFolder& folder, int index, const std::string& view) {
  image::FrameSidecar side;
  cv::Mat stored;
  CAMLAB_ASSIGN(side, folder.load_sidecar(index));
  CAMLAB_ASSIGN(stored, folder.load_stored_image(index));
  image::LightFrame light;
  CAMLAB_ASSIGN(light, image::decode_to_light(stored, side));
  stored = std::move(light.stored);
  side = std::move(light.sidecar);
  if (view.empty()) {
    if (Status mono = image::check_mono_linear(side, "frame " + std::to_string(index)); !mono)
      return mono.error();
    return stored;
  }
  if (view == "Y") return image::luminance_view(stored, side);
  if (side.layout == image::FrameLayout::kRgb) return channel_samples(stored, side, view);
  image::CfaPlanes planes;
  CAMLAB_ASSIGN(planes, image::cfa_planes(stored, side));
  for (size_t k = 0; k < 4; ++k)
    if (planes.colours[k] == view[0]) return planes.planes[k];
  return make_error("invalid_argument", "no channel '" + view + "' in the mosaic");
}

Result<FocusReport> focus_of(const image::CaptureFolder& folder, const std::vector<Entry>& entries,
                             bool have_distance, const FocusStackOptions& options,
                             const std::string& view) {
  const int count = static_cast<int>(folder.frames().size());
  FocusReport report;
  report.channel = view;
  report.frames = count;
  FocusStackOptions stack_options = options;
  {
    image::FrameSidecar first;
    CAMLAB_ASSIGN(first, folder.load_sidecar(entries.front().index));
    first = image::light_sidecar(first);  // as view_of reads the frames
    // An RGB frame's planes come from an ISP, black already removed.
    stack_options.black_level = first.layout == image::FrameLayout::kRgb ? 0 : first.black_level_dn;
  }
  FocusStackAccumulator acc(stack_options);
  for (const Entry& e : entries) {
    if (!report.positions.empty() && e.position == report.positions.back())
      continue;  // repeats at one position: the first frame only
    if (Status s = check_not_cancelled(options.cancel, "analysis"); !s) return s.error();
    cv::Mat image;
    CAMLAB_ASSIGN(image, view_of(folder, e.index, view));
    // Magnification relative to the first frame from the lens-to-sensor distance (thin
    // lens: the image scales with it); 1 when a frame does not record it.
    const double z0 = entries.front().lens_to_sensor_mm;
    const double magnification = z0 > 0 && e.lens_to_sensor_mm > 0 ? e.lens_to_sensor_mm / z0 : 1.0;
    if (Status s = acc.add(image, magnification); !s) return s.error();
    report.positions.push_back(e.position);
    report.focus_distance_m.push_back(e.distance_m);
  }
  FocusStackResult stack;
  CAMLAB_ASSIGN(stack, acc.finish());
  report.valid = stack.valid;
  report.all_in_focus = stack.all_in_focus;
  report.best_position.create(stack.best_index.size(), CV_32F);
  report.depth_m = cv::Mat::zeros(stack.best_index.size(), CV_32F);
  for (int r = 0; r < stack.best_index.rows; ++r)
    for (int c = 0; c < stack.best_index.cols; ++c) {
      const double idx = stack.best_index.at<float>(r, c);
      report.best_position.at<float>(r, c) = static_cast<float>(position_at(report.positions, idx));
      if (have_distance && stack.valid.at<uint8_t>(r, c)) {
        const double d = distance_at_index(report.focus_distance_m, idx);
        report.depth_m.at<float>(r, c) = std::isfinite(d) ? static_cast<float>(d) : 0.0f;
      }
    }
  for (RegionFocus& rf : stack.regions) {
    RegionFocusReport rr;
    rr.best_position = position_at(report.positions, rf.best_index);
    if (have_distance && rf.status == kFocusOk)
      rr.distance_m = distance_at_index(report.focus_distance_m, rf.best_index);
    rr.focus = std::move(rf);
    report.regions.push_back(std::move(rr));
  }
  return report;
}

}  // namespace

Result<FocusReport> analyze_focus(const std::filesystem::path& capture_dir,
                                  const FocusStackOptions& options) {
  image::CaptureFolder folder;
  CAMLAB_ASSIGN(folder, image::CaptureFolder::open(capture_dir));
  const int count = static_cast<int>(folder.frames().size());
  if (count == 0) return make_error("no_frames", "the capture folder holds no frames");
  image::FrameSidecar first;
  CAMLAB_ASSIGN(first, folder.load_sidecar(0));
  std::vector<std::string> channels;
  CAMLAB_ASSIGN(channels, measurable_channels(image::light_sidecar(first)));
  std::vector<Entry> entries;
  bool have_distance = true;
  for (int i = 0; i < count; ++i) {
    image::FrameSidecar side;
    CAMLAB_ASSIGN(side, folder.load_sidecar(i));
    const json& s = side.settings;
    if (!s.contains("focus_position") || !s["focus_position"].is_number())
      return make_error("missing_settings",
                        "frame " + std::to_string(i) + " has no focus_position in its settings");
    double d = std::numeric_limits<double>::quiet_NaN();
    if (s.contains("focus_distance_m"))
      d = s["focus_distance_m"].is_number() ? s["focus_distance_m"].get<double>()
                                            : std::numeric_limits<double>::infinity();
    have_distance &= !std::isnan(d);
    const double zs = s.contains("lens_to_sensor_mm") && s["lens_to_sensor_mm"].is_number()
                          ? s["lens_to_sensor_mm"].get<double>()
                          : 0.0;
    entries.push_back({i, s["focus_position"].get<double>(), d, zs});
  }
  std::stable_sort(entries.begin(), entries.end(),
                   [](const Entry& a, const Entry& b) { return a.position < b.position; });
  if (channels.size() == 1) return focus_of(folder, entries, have_distance, options, "");
  // Colour: the luminance at full resolution, then each channel on its own samples (the
  // channels focus apart when the lens has longitudinal chromatic aberration).
  FocusReport report;
  CAMLAB_ASSIGN(report, focus_of(folder, entries, have_distance, options, "Y"));
  for (const std::string& channel : channels) {
    FocusReport one;
    CAMLAB_ASSIGN(one, focus_of(folder, entries, have_distance, options, channel));
    report.channels.push_back(std::move(one));
  }
  return report;
}

namespace {

json view_json(const FocusReport& r) {
  json regions = json::array();
  int ok = 0;
  for (const RegionFocusReport& rr : r.regions) {
    json j = {
        {"rect", {rr.focus.rect.x, rr.focus.rect.y, rr.focus.rect.width, rr.focus.rect.height}},
        {"status", rr.focus.status},
        {"best_index", rr.focus.best_index},
        {"best_index_sigma", rr.focus.best_index_sigma},
        {"best_position", rr.best_position},
        {"confidence", rr.focus.confidence}};
    if (rr.distance_m) j["distance_m"] = num(*rr.distance_m);
    ok += rr.focus.status == kFocusOk;
    regions.push_back(j);
  }
  const int valid = r.valid.empty() ? 0 : cv::countNonZero(r.valid);
  return {
      {"frames", r.frames},
      {"positions", r.positions},
      {"regions_ok", ok},
      {"regions", regions},
      {"valid_pixel_fraction", r.valid.empty() ? 0.0 : double(valid) / double(r.valid.total())}};
}

}  // namespace

json to_json(const FocusReport& r) {
  json j = view_json(r);
  j["kind"] = "focus";
  if (r.channels.empty()) return j;
  j["view"] = "luminance";
  json channels = json::object();
  for (const FocusReport& c : r.channels) {
    channels[c.channel] = view_json(c);
    channels[c.channel]["pixel_scale"] =
        c.valid.empty() || r.valid.empty() ? 1.0 : double(r.valid.cols) / double(c.valid.cols);
  }
  j["channels"] = channels;
  return j;
}

}  // namespace camlab::analysis
