#include "analysis/sfr/sfr_image.h"

#include <cmath>
#include <cstdio>
#include <map>
#include <numbers>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/channel_signal.h"
#include "analysis/edge/edge_finder.h"
#include "analysis/edge/segment_extent.h"
#include "base/format.h"
#include "base/transfer_function.h"
#include "image/capture_folder.h"
#include "image/frame_views.h"

namespace camlab::analysis {
namespace {

using json = nlohmann::json;

// Where an edge lies in the field: "meridional" when it runs across the radius from the
// centre (its SFR is the resolution along the radius), "sagittal" when it runs along it,
// "axial" within 5% of the half diagonal of the centre, "oblique" between 30 and 60 deg.
std::string field_orientation(const SfrResult& r, const cv::Size& size) {
  const double cx = 0.5 * (size.width - 1), cy = 0.5 * (size.height - 1);
  const double rx = r.centre_x_px - cx, ry = r.centre_y_px - cy;
  const double radius = std::hypot(rx, ry),
               half_diagonal = 0.5 * std::hypot(size.width, size.height);
  if (radius < 0.05 * half_diagonal) return "axial";
  const double a = r.angle_deg * std::numbers::pi / 180;
  // |cos| of the angle between the edge's direction and the radius.
  const double along = std::fabs(std::cos(a) * rx + std::sin(a) * ry) / radius;
  if (along < std::cos(60 * std::numbers::pi / 180)) return "meridional";
  if (along > std::cos(30 * std::numbers::pi / 180)) return "sagittal";
  return "oblique";
}

json optional_number(const std::optional<double>& v) { return v ? json(*v) : json(nullptr); }

std::string cell(const std::optional<double>& v, const char* format) {
  if (!v) return "     -";
  char text[32];
  std::snprintf(text, sizeof text, format, *v);
  return text;
}

// Every edge of `edges` measured on `f` (float, single channel): their JSON entries, one
// text line each, and the tally.
struct Tally {
  int edges = 0, measured = 0;
  std::map<std::string, int> left_out;
};
Result<json> measure_edges(const cv::Mat& f, const std::vector<EdgeSegment>& edges,
                           const SfrImageOptions& options, double lp_per_mm_per_cy_px,
                           std::string* text, Tally* tally) {
  // The edges side by side on OpenCV's threads (slanted_edge_sfr is reentrant): a 12 MP
  // chart's 316 take 0.1 s on one core.
  std::vector<Result<SfrResult>> measured(edges.size(), SfrResult{});
  cv::parallel_for_(cv::Range(0, static_cast<int>(edges.size())), [&](const cv::Range& range) {
    for (int k = range.start; k < range.end; ++k)
      measured[static_cast<size_t>(k)] =
          slanted_edge_sfr(f, edges[static_cast<size_t>(k)], options.sfr);
  });
  std::vector<SfrResult> results;
  for (auto& r : measured) {
    if (!r) return r.error();
    results.push_back(std::move(*r));
  }
  // Another edge through the region: its step sits in the ESF beside this one's (a star's
  // converging sides, a narrow gap), which the SFR alone cannot always tell. Only segments
  // that are edges count (the finder's stray lines show no step), each on the line its SFR
  // found (so that two pieces or two ridges of one edge lie on one line and count once).
  std::vector<EdgeSegment> steps;
  std::vector<size_t> step_of(edges.size(), edges.size());
  for (size_t k = 0; k < edges.size(); ++k) {
    if (results[k].status == kSfrNoEdge) continue;
    const EdgeSegment& e = edges[k];
    const double half = 0.5 * std::hypot(e.end_x_px - e.start_x_px, e.end_y_px - e.start_y_px);
    const double a = results[k].angle_deg * std::numbers::pi / 180;
    const double cx = results[k].centre_x_px, cy = results[k].centre_y_px;
    step_of[k] = steps.size();
    steps.push_back({e.name, cx - half * std::cos(a), cy - half * std::sin(a),
                     cx + half * std::cos(a), cy + half * std::sin(a), 0});
  }
  for (size_t k = 0; k < edges.size(); ++k) {
    SfrResult& r = results[k];
    if (r.status != kSfrOk) continue;
    if (const auto neighbour = neighbour_in_region(steps, step_of[k], options.sfr)) {
      r.status = std::string(kSfrNeighbourInRegion);
      r.message = steps[neighbour->index].name + " passes " +
                  format_significant(neighbour->distance_px, 3) +
                  " px from this edge's line, inside the region read (" +
                  format_significant(options.sfr.half_width_px, 3) +
                  " px each side): a narrower --half-width, or a chart with more room";
    }
  }

  json list = json::array();
  for (size_t k = 0; k < edges.size(); ++k) {
    const EdgeSegment& e = edges[k];
    const SfrResult* r = &results[k];
    ++tally->edges;
    const std::string field = field_orientation(*r, f.size());
    json j = {{"name", e.name},
              {"centre_px", {r->centre_x_px, r->centre_y_px}},
              {"angle_deg", r->angle_deg},
              {"slant_deg", r->slant_deg},
              {"field", field},
              {"status", r->status},
              {"rise_10_90_px", r->rise_10_90_px}};
    if (!r->message.empty()) j["message"] = r->message;
    const bool ok = r->status == kSfrOk;
    if (ok) {
      ++tally->measured;
      j["mtf50_cy_px"] = optional_number(r->mtf50_cy_px);
      j["mtf30_cy_px"] = optional_number(r->mtf30_cy_px);
      j["mtf10_cy_px"] = optional_number(r->mtf10_cy_px);
      j["mtf50_standard_error_cy_px"] = optional_number(r->mtf50_standard_error_cy_px);
      if (lp_per_mm_per_cy_px > 0 && r->mtf50_cy_px)
        j["mtf50_lp_mm"] = *r->mtf50_cy_px * lp_per_mm_per_cy_px;
      if (lp_per_mm_per_cy_px > 0 && r->mtf50_standard_error_cy_px)
        j["mtf50_standard_error_lp_mm"] = *r->mtf50_standard_error_cy_px * lp_per_mm_per_cy_px;
      j["sfr"] = {{"frequency_cy_px", r->frequency_cy_px}, {"sfr", r->sfr}};
    } else {
      ++tally->left_out[r->status];
    }
    list.push_back(std::move(j));
    char line[256];
    std::snprintf(line, sizeof line, "  %-9s (%6.1f, %6.1f) %6.1f %6.1f  %-10s", e.name.c_str(),
                  r->centre_x_px, r->centre_y_px, r->angle_deg, r->slant_deg, field.c_str());
    *text += line;
    if (ok) {
      *text += " " + cell(r->mtf50_cy_px, "%6.3f") + " " + cell(r->mtf30_cy_px, "%6.3f") + " " +
               cell(r->mtf10_cy_px, "%6.3f") + "              " +
               cell(r->mtf50_standard_error_cy_px, "%6.4f");
      if (lp_per_mm_per_cy_px > 0) {
        std::optional<double> lp;
        if (r->mtf50_cy_px) lp = *r->mtf50_cy_px * lp_per_mm_per_cy_px;
        *text += "  " + cell(lp, "%12.1f");
      }
      *text += "  ok\n";
    } else {
      *text += "  " + r->status + ": " + r->message + "\n";
    }
  }
  return list;
}

std::string table_header(double lp_per_mm_per_cy_px) {
  // Appended in place: GCC 12 warned (-Warray-bounds, a false positive) on the chain of
  // temporaries the one-expression form made.
  std::string header =
      "  edge       centre (px)    angle  slant  field        MTF50  MTF30  MTF10 [cy/px]  "
      "MTF50 s.e.";
  if (lp_per_mm_per_cy_px > 0) header += "  MTF50 [lp/mm]";
  header += "  status\n";
  return header;
}

json summary_json(const Tally& t) {
  return {{"kind", "sfr"}, {"edges", t.edges}, {"measured", t.measured}, {"left_out", t.left_out}};
}

// The words of analysis_summary.cpp's "sfr" summary (this room cannot include it: the
// arrows point from the top of analysis/ into its rooms).
std::string summary_line(const Tally& t) {
  std::string left_text;
  for (const auto& [status, count] : t.left_out)
    left_text += (left_text.empty() ? "" : ", ") + std::to_string(count) + " " + status;
  return "summary: " + std::to_string(t.measured) + " of " + std::to_string(t.edges) +
         " edge fit(s) measured; left out: " + (left_text.empty() ? "none" : left_text) + "\n";
}

std::vector<EdgeSegment> edges_in(const cv::Mat& f, const SfrImageOptions& options) {
  EdgeFinderOptions finder;
  finder.min_length_px = options.min_edge_length_px;
  // A chart's every side: a 9 x 7 grid of squares is 252 edges (the finder's default of
  // 64 kept only the longest quarter of them).
  finder.max_edges = kSfrMaxEdges;
  // The finder's reduced-scale segments often cover part of a side; the SFR reads only
  // rows whose windows lie inside the segment (segment_extent.h).
  return extend_along_edges(f, find_edges(f, finder));
}

Error no_edges(const SfrImageOptions& options, const std::string& name) {
  return make_error("no_edge_geometry",
                    "no straight edge " +
                        std::to_string(static_cast<int>(options.min_edge_length_px)) +
                        " px or longer was found in " + name);
}

// A colour frame (a raw mosaic or linear RGB): each edge's SFR in R, G and B as well,
// each channel on its own sites (the others NaN, channel_signal.h) and on the line the
// luminance shows, so the pixel aperture stays one site's and no demosaicing blur enters
// (longitudinal colour shows as channels sharp at different focus). Added to each edge's
// entry as "channels" and as one text line per frame; mono and JPEG frames get none.
Status channel_sfr(const cv::Mat& stored, const image::FrameSidecar& side, const cv::Mat& luminance,
                   const std::vector<EdgeSegment>& edges, const SfrImageOptions& options,
                   json* list, std::string* text) {
  auto channels = measurable_channels(side);
  if (!channels || channels->size() < 3) return {};
  SfrOptions o = options.sfr;
  o.saturation_level = side.white_level_dn > 0 ? side.white_level_dn - side.black_level_dn : 0;
  std::string line = "  MTF50 per channel [cy/px]:";
  for (const std::string& channel : *channels) {
    auto signal = channel_signal(stored, side, channel);
    if (!signal) return signal.error();
    for (size_t k = 0; k < edges.size(); ++k) {
      auto r = slanted_edge_sfr(*signal, luminance, edges[k], o);
      if (!r) return r.error();
      json c = {{"status", r->status}};
      if (r->status == kSfrOk) {
        c["mtf50_cy_px"] = optional_number(r->mtf50_cy_px);
        c["mtf50_standard_error_cy_px"] = optional_number(r->mtf50_standard_error_cy_px);
        c["mtf30_cy_px"] = optional_number(r->mtf30_cy_px);
        c["mtf10_cy_px"] = optional_number(r->mtf10_cy_px);
        // The channel's edge off the luminance's line (lateral colour): image px.
        c["offset_px"] = {r->offset_x_px, r->offset_y_px};
      } else {
        c["message"] = r->message;
      }
      (*list)[k]["channels"][channel] = std::move(c);
    }
  }
  for (size_t k = 0; k < edges.size(); ++k) {
    if ((*list)[k]["status"] != std::string(kSfrOk)) continue;
    line += " " + edges[k].name;
    for (const std::string& channel : *channels) {
      const json& c = (*list)[k]["channels"][channel];
      line += " " + channel + " " +
              (c["status"] == std::string(kSfrOk) && c["mtf50_cy_px"].is_number()
                   ? format_significant(c["mtf50_cy_px"].get<double>(), 3)
                   : std::string("-"));
    }
    line += ";";
  }
  *text += line + "\n";
  return {};
}

}  // namespace

Result<SfrImageReport> analyze_sfr(const cv::Mat& image, const std::string& name,
                                   const SfrImageOptions& options) {
  if (image.empty() || image.channels() != 1)
    return make_error("bad_image", "the SFR needs a single-channel image");
  // A float image (a decoded file) is read in place, as the finder and the SFR read it.
  cv::Mat f = image;
  if (image.type() != CV_32F) image.convertTo(f, CV_32F);
  const std::vector<EdgeSegment> edges = edges_in(f, options);
  if (edges.empty()) return no_edges(options, name);
  const double lp_per_mm_per_cy_px =
      options.pixel_pitch_um > 0 ? 1000.0 / options.pixel_pitch_um : 0.0;
  SfrImageReport out;
  out.text = "sfr: " + name + ", " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
             ", " + std::to_string(edges.size()) + " edge(s)" +
             (lp_per_mm_per_cy_px > 0 ? "" : " (no --pixel-um: cycles/px only)") + "\n" +
             table_header(lp_per_mm_per_cy_px);
  Tally tally;
  auto list = measure_edges(f, edges, options, lp_per_mm_per_cy_px, &out.text, &tally);
  if (!list) return list.error();
  out.text += summary_line(tally);
  out.report = {
      {"image", name},
      {"size_px", {image.cols, image.rows}},
      {"pixel_pitch_um", options.pixel_pitch_um > 0 ? json(options.pixel_pitch_um) : json(nullptr)},
      {"method", "ISO 12233 slanted edge, " + std::to_string(options.sfr.oversampling) +
                     "x oversampled ESF, cycles per pixel across the edge"},
      {"edges", std::move(*list)},
      {"summary", summary_json(tally)}};
  return out;
}

Result<SfrImageReport> analyze_sfr_folder(const std::filesystem::path& dir,
                                          const SfrImageOptions& options_in) {
  auto folder = image::CaptureFolder::open(dir);
  if (!folder) return folder.error();
  const int count = static_cast<int>(folder->frames().size());
  if (count == 0) return make_error("no_frames", "the capture folder holds no frames");
  // Each frame's luminance (stored DN), and the edges of the frame where most are found
  // (the sharpest, usually), measured on every frame.
  // One frame in memory at a time (a 300-frame capture of 12 MP frames would take 14 GB
  // as float): read once to find the edges, once more to measure them.
  // The frame as stored (for its colour channels) and its luminance as float.
  // A frame with the curve its camera declared (a webcam's YUYV or MJPEG) is decoded to
  // light first: read as light, an sRGB edge's MTF50 is 2-9% low.
  std::string decoded_from;
  auto luminance_of = [&](int i, image::FrameSidecar* side, cv::Mat* stored) -> Result<cv::Mat> {
    CAMLAB_ASSIGN(*side, folder->load_sidecar(i));
    cv::Mat luminance, f;
    CAMLAB_ASSIGN(*stored, folder->load_stored_image(i));
    image::LightFrame light;
    CAMLAB_ASSIGN(light, image::decode_to_light(*stored, *side));
    if (light.decoded) {
      decoded_from = name_of(side->transfer);
      *stored = std::move(light.stored);
      *side = std::move(light.sidecar);
    }
    CAMLAB_ASSIGN(luminance, image::luminance_view(*stored, *side));
    luminance.convertTo(f, CV_32F);
    return f;
  };
  std::vector<EdgeSegment> edges;
  for (int i = 0; i < count; ++i) {
    image::FrameSidecar side;
    cv::Mat stored, frame;
    CAMLAB_ASSIGN(frame, luminance_of(i, &side, &stored));
    std::vector<EdgeSegment> found = edges_in(frame, options_in);
    if (found.size() > edges.size()) edges = std::move(found);
  }
  if (edges.empty()) return no_edges(options_in, dir.string());
  SfrImageOptions options = options_in;
  if (!(options.pixel_pitch_um > 0)) {
    const json& camera =
        folder->manifest().value("source", json::object()).value("camera_spec", json::object());
    const json sensor = camera.is_object() ? camera.value("sensor", json::object()) : json();
    if (sensor.is_object() && sensor.contains("pixel_pitch_um") &&
        sensor["pixel_pitch_um"].is_number())
      options.pixel_pitch_um = sensor["pixel_pitch_um"].get<double>();
  }
  const double lp_per_mm_per_cy_px =
      options.pixel_pitch_um > 0 ? 1000.0 / options.pixel_pitch_um : 0.0;
  SfrImageReport out;
  out.text = "sfr: " + dir.string() + ", " + std::to_string(count) + " frame(s), " +
             std::to_string(edges.size()) + " edge(s) from the frame with the most" +
             (lp_per_mm_per_cy_px > 0 ? "" : " (no pixel pitch: cycles/px only)") + "\n";
  if (!decoded_from.empty())
    out.text += "values: " + decoded_from + " as the camera declared, decoded to light\n";
  Tally tally;
  json frames_json = json::array();
  cv::Size size;
  for (int i = 0; i < count; ++i) {
    image::FrameSidecar side;
    cv::Mat stored, frame;
    CAMLAB_ASSIGN(frame, luminance_of(i, &side, &stored));
    size = frame.size();
    // Pixels at the white level are clipped.
    options.sfr.saturation_level = side.white_level_dn > 0 ? side.white_level_dn : 0;
    const json& settings = side.settings;
    std::string settings_text;
    for (const char* key : {"f_number", "focus_position", "exposure_us"})
      if (settings.contains(key) && settings[key].is_number())
        settings_text += std::string(settings_text.empty() ? "" : ", ") + key + " " +
                         format_significant(settings[key].get<double>(), 4);
    out.text += "frame " + std::to_string(i) +
                (settings_text.empty() ? "" : " (" + settings_text + ")") + "\n" +
                table_header(lp_per_mm_per_cy_px);
    auto list = measure_edges(frame, edges, options, lp_per_mm_per_cy_px, &out.text, &tally);
    if (!list) return list.error();
    auto by_channel = channel_sfr(stored, side, frame, edges, options, &*list, &out.text);
    if (!by_channel) return by_channel.error();
    frames_json.push_back({{"frame", i}, {"settings", settings}, {"edges", std::move(*list)}});
  }
  out.text += summary_line(tally);
  out.report = {
      {"capture", dir.string()},
      {"size_px", {size.width, size.height}},
      {"pixel_pitch_um", options.pixel_pitch_um > 0 ? json(options.pixel_pitch_um) : json(nullptr)},
      {"method", "ISO 12233 slanted edge, " + std::to_string(options.sfr.oversampling) +
                     "x oversampled ESF, cycles per pixel across the edge"},
      {"frames", std::move(frames_json)},
      {"summary", summary_json(tally)},
      // As the frames' sidecars say (the camera's declaration), decoded when not linear.
      {"transfer",
       {{"encoding", decoded_from.empty() ? "linear" : decoded_from}, {"assumed", false}}}};
  return out;
}

Result<SfrImageReport> analyze_sfr_image(const std::string& path, const SfrImageOptions& options) {
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) return make_error("bad_image", "cannot read an image from " + path);
  if (image.depth() != CV_8U && image.depth() != CV_16U)
    return make_error("bad_image", path + ": only 8- and 16-bit images are measured");
  if (image.channels() != 1 && image.channels() != 3 && image.channels() != 4)
    return make_error("bad_image", path + ": unsupported channel count");
  const bool assumed = options.transfer == ImageTransfer::kAuto;
  const bool srgb = options.transfer == ImageTransfer::kSrgb || (assumed && image.depth() == CV_8U);
  // Linear values first (sRGB decoded per channel, before the luminance is formed), in
  // the file's code range so that the finder's thresholds see the same contrast scale.
  const double full_scale = image.depth() == CV_8U ? 255.0 : 65535.0;
  cv::Mat linear;
  image.convertTo(linear, CV_32F, 1.0 / full_scale);
  if (srgb) {
    cv::Mat values = linear.reshape(1);  // every channel's value, in place
    values.forEach<float>([](float& v, const int*) {
      v = static_cast<float>(decode_to_light(TransferFunction::kSrgb, v));
    });
  }
  if (linear.channels() == 4) cv::cvtColor(linear, linear, cv::COLOR_BGRA2BGR);
  if (linear.channels() == 3) cv::cvtColor(linear, linear, cv::COLOR_BGR2GRAY);
  linear *= full_scale;
  auto report = analyze_sfr(linear, path, options);
  if (!report) return report;
  const std::string transfer = srgb ? "srgb" : "linear";
  report->report["transfer"] = {{"encoding", transfer}, {"assumed", assumed}};
  const std::string why =
      !assumed ? "given with --transfer"
      : srgb   ? "assumed for an 8-bit file; --transfer linear if its values are linear"
               : "assumed for a 16-bit file; --transfer srgb if it is sRGB-encoded";
  report->text = "values: " + transfer + " (" + why + ")\n" + report->text;
  return report;
}

}  // namespace camlab::analysis
