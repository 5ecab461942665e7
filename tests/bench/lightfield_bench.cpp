// lightfield_bench: speed against error for light fields (docs/measuring.md), on the
// example light-field camera and scene (mock_device/examples/camera_lightfield_9x9.json,
// scene_lightfield_planes.json) scaled to each resolution (the pixel pitch scales with it,
// so the optics and the field of view stay the same). Errors are against the virtual
// camera's truth, never against camlab's own output.
//  1. Views x resolution: render time; refocus at each slanted edge's distance against the
//     thin-lens render focused there (edge-profile RMS over the edge's contrast) and its
//     time; depth of the textured planes against the depth truth (median and 95th
//     percentile of |error| over the planes' insides, the matching window 7 px at 320 x 240
//     and scaled with the resolution) and its time; decoding the lenslet image against
//     the rendered views (DN RMS) and its time. The illuminance is scaled with the pixel
//     area, so every resolution sees the same signal per pixel.
//  2. Error against depth: textured planes at 0.5 .. 4 m, views 5, 9, 13.
//  3. The blur analyze defocus measures on refocused aperture series against the thin lens
//     for the synthetic aperture.
//  4. Refocus against the lens's own blur (0, 0.4, 0.8 px): the interpolation's share.
//  5. Depth from a refocused focus stack (analyze focus) against depth from disparity.
//  6. Decoding square and hexagonal grids of 5 to 14 views per side.
// Sections by name: views depth defocus blur stack decode (default: all).
// Medians of --repeats runs (default 3) for the times; 2 render threads.
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "analysis/analyze_folder.h"
#include "analysis/focus/focus_report.h"
#include "analysis/lightfield/depth.h"
#include "analysis/lightfield/lenslet_decode.h"
#include "analysis/lightfield/refocus.h"
#include "analysis/lightfield/refocus_capture.h"
#include "capture_fixture.h"  // make_renderer
#include "lightfield_measures.h"
#include "mock_device/render/lightfield_render.h"
#include "optics/optics.h"

namespace {

using namespace camlab;
namespace fs = std::filesystem;
namespace lf = camlab::analysis::lightfield;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

int g_repeats = 3;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

json load_json(const std::string& path) {
  std::ifstream in(path);
  json j = json::parse(in, nullptr, false, /*ignore_comments=*/true);
  if (j.is_discarded()) throw std::runtime_error(path + " is not valid JSON");
  return j;
}

// The example camera at width x (3/4 width) px, the pitch scaled to keep the sensor's
// size; `views` per side; a lens blur of sigma_px (in pixels of this resolution).
json camera_json(int width, int views, const char* grid = "square", double sigma_px = 0.8) {
  json c = load_json(std::string(CAMLAB_SOURCE_DIR) +
                     "/mock_device/examples/camera_lightfield_9x9.json");
  c["sensor"]["width_px"] = width;
  c["sensor"]["height_px"] = width * 3 / 4;
  c["sensor"]["pixel_pitch_um"] = 4.0 * 320 / width;
  c["lens"]["baseline_blur_sigma_px"] = sigma_px;
  c["lightfield"]["views"] = {views, views};
  c["lightfield"]["microlens_grid"] = grid;
  return c;
}

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::temp_directory_path() /
                       ("camlab_lightfield_bench_" + std::to_string(::getpid()) + "_" + name);
  fs::remove_all(dir);
  return dir;
}

struct Rendered {
  fs::path dir;
  lf::LightField field;
  double seconds = 0;
};

// Renders `repeats` times (the median time), writes the last into a folder and loads it.
Rendered render(mock::Renderer& renderer, const mock::RenderSettings& settings, bool noise,
                const std::string& name, int repeats = 1) {
  mock::RenderOptions options;
  options.noise = noise;
  options.threads = 2;
  Rendered out;
  std::vector<double> times;
  mock::LightFieldFrame frame;
  for (int i = 0; i < repeats; ++i) {
    const auto start = Clock::now();
    auto f = mock::render_light_field(renderer, settings, 0, options);
    times.push_back(seconds_since(start));
    if (!f) throw std::runtime_error(f.error().message);
    frame = std::move(*f);
  }
  out.seconds = median(times);
  out.dir = scratch(name);
  if (Status s = mock::write_light_field(frame, renderer, out.dir, options); !s)
    throw std::runtime_error(s.error().message);
  auto field = lf::load_light_field(out.dir);
  if (!field) throw std::runtime_error(field.error().message);
  out.field = std::move(*field);
  return out;
}

// Refocus at each slanted edge's distance (the focus position nearest it) against the
// thin-lens render focused there; worst edge-profile RMS over the edges and the median
// time of one refocus.
struct RefocusFigures {
  double rms = 0, max = 0, seconds = 0, view_step_px = 0;
};
RefocusFigures refocus_figures(mock::Renderer& renderer, const lf::LightField& field,
                               double scale) {
  RefocusFigures out;
  std::vector<double> times;
  for (auto [name, position] : {std::pair{"edge_0.8m", 81}, std::pair{"edge_1.3m", 50}}) {
    mock::RenderSettings focused = renderer.default_settings();
    focused.focus_position = position;
    mock::RenderOptions options;
    options.noise = false;
    options.threads = 2;
    auto thin = renderer.render(focused, 0, options);
    if (!thin) throw std::runtime_error(thin.error().message);
    const double s_m = thin->settings["focus_distance_m"];
    Result<lf::RefocusResult> r = make_error("internal", "not run");
    for (int i = 0; i < g_repeats; ++i) {
      const auto start = Clock::now();
      r = lf::refocus(field, s_m);
      times.push_back(seconds_since(start));
    }
    if (!r) throw std::runtime_error(r.error().message);
    cv::Mat reference;
    thin->image.convertTo(reference, CV_32F, 1.0, -64);
    const auto d = analysis::testing::edge_profile_difference(
        r->image, reference, analysis::testing::edge_segment(thin->truth, name), 8 * scale);
    out.rms = std::max(out.rms, d.rms_over_contrast);
    out.max = std::max(out.max, d.max_over_contrast);
    out.view_step_px = std::max(out.view_step_px, r->view_step_px);
  }
  out.seconds = median(times);
  return out;
}

// Depth against the truth over the planes' insides (6 px x scale from any change of
// depth): median and 95th percentile of |relative error|, share measured, time.
struct DepthFigures {
  double median = 0, p95 = 0, measured = 0, seconds = 0;
  std::map<int, std::pair<double, double>> by_cm;  // median, p95 per plane
};
DepthFigures depth_figures(const Rendered& r, double scale, const std::vector<int>& planes_cm) {
  DepthFigures out;
  std::vector<double> times;
  Result<lf::DepthResult> depth = make_error("internal", "not run");
  lf::DepthOptions options;  // the window scaled with the resolution: 7 px at 320 x 240
  options.window_px = 2 * static_cast<int>(std::lround(3.5 * scale)) + 1;
  for (int i = 0; i < g_repeats; ++i) {
    const auto start = Clock::now();
    depth = lf::estimate_depth(r.field, options);
    times.push_back(seconds_since(start));
  }
  if (!depth) throw std::runtime_error(depth.error().message);
  out.seconds = median(times);
  auto folder = image::LightFieldFolder::open(r.dir);
  const cv::Mat truth = *folder->load_depth_truth();
  const int k = 2 * static_cast<int>(std::ceil(6 * scale)) + 1;
  cv::Mat lo, hi;
  cv::erode(truth, lo, cv::Mat::ones(k, k, CV_8U));
  cv::dilate(truth, hi, cv::Mat::ones(k, k, CV_8U));
  std::vector<double> errors;
  std::map<int, std::vector<double>> by_cm;
  long inside = 0;
  for (int y = k; y < truth.rows - k; ++y)
    for (int x = k; x < truth.cols - k; ++x) {
      const float z = truth.at<float>(y, x);
      if (z <= 0 || lo.at<float>(y, x) != hi.at<float>(y, x)) continue;
      // The textured planes only: the slanted edges' flat sides have no depth to find.
      const int cm = static_cast<int>(std::lround(z * 100));
      if (std::find(planes_cm.begin(), planes_cm.end(), cm) == planes_cm.end()) continue;
      ++inside;
      if (depth->status.at<uint8_t>(y, x) != lf::kDepthOk) continue;
      const double e = std::fabs(depth->depth_m.at<float>(y, x) / z - 1.0);
      errors.push_back(e);
      by_cm[cm].push_back(e);
    }
  std::sort(errors.begin(), errors.end());
  if (!errors.empty()) {
    out.median = errors[errors.size() / 2];
    out.p95 = errors[errors.size() * 95 / 100];
  }
  out.measured = inside ? static_cast<double>(errors.size()) / inside : 0;
  for (auto& [cm, e] : by_cm) {
    std::sort(e.begin(), e.end());
    out.by_cm[cm] = {e[e.size() / 2], e[e.size() * 95 / 100]};
  }
  return out;
}

// Decode the lenslet image and compare with the views rendered directly: DN RMS, worst
// view's, views kept, time.
struct DecodeFigures {
  double rms = 0, worst = 0, seconds = 0;
  int views = 0;
};
DecodeFigures decode_figures(const Rendered& r) {
  DecodeFigures out;
  auto folder = image::LightFieldFolder::open(r.dir);
  auto images = folder->load_lenslet();
  if (!images) throw std::runtime_error(images.error().message);
  const auto& d = folder->description();
  std::vector<double> times;
  Result<lf::DecodedLightField> decoded = make_error("internal", "not run");
  for (int i = 0; i < g_repeats; ++i) {
    const auto start = Clock::now();
    decoded = lf::decode_lenslet(images->first, images->second, d.lenslet->black_level_dn, d.optics,
                                 d.lenslet->raw_pixel_pitch_um, {});
    times.push_back(seconds_since(start));
  }
  if (!decoded) throw std::runtime_error(decoded.error().message);
  out.seconds = median(times);
  double sq = 0;
  long n = 0;
  const auto& back = decoded->light_field;
  for (size_t k = 0; k < back.views.size(); ++k) {
    size_t j = 0;
    while (d.views[j].u_index != back.description.views[k].u_index ||
           d.views[j].v_index != back.description.views[k].v_index)
      ++j;
    // As written: both rounded to whole DN.
    cv::Mat a, b;
    r.field.views[j].convertTo(a, CV_64F);
    back.views[k].convertTo(b, CV_32S);
    b.convertTo(b, CV_64F);
    const cv::Mat diff = a - b;
    const double s = diff.dot(diff);
    out.worst = std::max(out.worst, std::sqrt(s / diff.total()));
    sq += s;
    n += static_cast<long>(diff.total());
  }
  out.rms = std::sqrt(sq / n);
  out.views = static_cast<int>(back.views.size());

  return out;
}

void table_views_resolution(const json& scene) {
  std::printf("\n1. Views x resolution (example scene, noise on; times median of %d, 2 threads)\n",
              g_repeats);
  std::printf(
      "| views | resolution | render s | refocus s | refocus RMS / max (edge at S) | residual "
      "step px | depth s | depth |err| median / p95 | measured | decode s | decode DN RMS "
      "(worst view) |\n|---|---|---|---|---|---|---|---|---|---|---|\n");
  std::vector<std::pair<int, int>> configs = {{3, 320}, {5, 160}, {5, 320}, {9, 160},
                                              {9, 320}, {9, 640}, {13, 320}};
  for (auto [views, width] : configs) {
    const double scale = width / 320.0;
    // The same signal per pixel at every resolution: a pixel's area goes as 1 / scale^2.
    json lit = scene;
    lit["illuminance_lux"] = scene.value("illuminance_lux", 500.0) * scale * scale;
    mock::Renderer renderer = analysis::testing::make_renderer(camera_json(width, views), lit);
    const Rendered noisy = render(renderer, renderer.default_settings(), true, "noisy", g_repeats);
    // Refocus and decode on the expected signal (the thin-lens reference has no noise).
    const Rendered clean = render(renderer, renderer.default_settings(), false, "clean");
    const RefocusFigures rf = refocus_figures(renderer, clean.field, scale);
    const DepthFigures df = depth_figures(noisy, scale, {60, 100, 160});
    const DecodeFigures dc = decode_figures(clean);
    std::printf(
        "| %d x %d | %dx%d | %.2f | %.3f | %.2f%% / %.1f%% | %.2f | %.2f | %.3f%% / %.3f%% | "
        "%.1f%% | %.2f | %.2f (%.2f) |\n",
        views, views, width, width * 3 / 4, noisy.seconds, rf.seconds, 100 * rf.rms, 100 * rf.max,
        rf.view_step_px, df.seconds, 100 * df.median, 100 * df.p95, 100 * df.measured, dc.seconds,
        dc.rms, dc.worst);
    std::fflush(stdout);
    fs::remove_all(noisy.dir);
    fs::remove_all(clean.dir);
  }
}

void table_depth(int width) {
  std::printf(
      "\n2. Depth error against depth and views (%dx%d, noise on, textured planes side by "
      "side, focus 0.99 m): |err| median / p95\n",
      width, width * 3 / 4);
  const double fx = 8.065 / (4e-3 * 320 / width);
  json targets = json::array();
  const double depths[] = {0.5, 0.7, 1.0, 1.5, 2.5, 4.0};
  for (int i = 0; i < 6; ++i) {
    // Six planes in a row, each a sixth of the width (less a margin), at its depth.
    const double z = depths[i], cx_px = (i + 0.5) * width / 6.0 - width / 2.0;
    const double size = (width / 6.0 - 8) * z / fx;
    targets.push_back({{"type", "texture"},
                       {"name", "plane_" + std::to_string(i)},
                       {"size_m", {size, size}},
                       {"feature_m", 0.0015 * z * 320 / width},
                       {"seed", 20 + i},
                       {"dark_reflectance", 0.1},
                       {"light_reflectance", 0.8},
                       {"pose", {{"position_m", {cx_px * z / fx, 0.0, z}}}}});
  }
  const json scene = {
      {"illuminance_lux", 1000}, {"background_reflectance", 0.18}, {"targets", targets}};
  std::printf("| views | 0.5 m | 0.7 m | 1.0 m | 1.5 m | 2.5 m | 4.0 m | depth s |\n");
  std::printf("|---|---|---|---|---|---|---|---|\n");
  for (int views : {5, 9, 13}) {
    mock::Renderer renderer = analysis::testing::make_renderer(camera_json(width, views), scene);
    const Rendered r = render(renderer, renderer.default_settings(), true, "depth", g_repeats);
    const DepthFigures df = depth_figures(r, width / 320.0, {50, 70, 100, 150, 250, 400});
    std::printf("| %d x %d |", views, views);
    for (double z : depths) {
      auto it = df.by_cm.find(static_cast<int>(std::lround(z * 100)));
      if (it == df.by_cm.end())
        std::printf(" - |");
      else
        std::printf(" %.3f%% / %.3f%% |", 100 * it->second.first, 100 * it->second.second);
    }
    std::printf(" %.2f |\n", df.seconds);
    std::fflush(stdout);
    fs::remove_all(r.dir);
  }
}

void table_defocus() {
  std::printf(
      "\n3. Blur measured by analyze defocus on refocused aperture series (an edge filling the "
      "view at 0.8 m, the light field focused on it, no noise, 320x240, lens blur 0) against "
      "the thin lens at the synthetic f-number\n");
  std::printf(
      "| views | refocus at | f/2 (all views) | f/2.8 | f/4 | f/5.6 | k = C N vs thin lens |\n");
  std::printf("|---|---|---|---|---|---|---|\n");
  const json scene = {{"illuminance_lux", 1000},
                      {"background_reflectance", 0.18},
                      {"targets",
                       {{{"type", "slanted_edge"},
                         {"size_m", {1.0, 1.0}},
                         {"angle_deg", 5},
                         {"dark_reflectance", 0.1},
                         {"light_reflectance", 0.8},
                         {"pose", {{"position_m", {0.0, 0.0, 0.8}}}}}}}};
  for (int views : {5, 9, 13}) {
    mock::Renderer renderer =
        analysis::testing::make_renderer(camera_json(320, views, "none", 0.0), scene);
    mock::RenderSettings settings = renderer.default_settings();
    settings.focus_position = 81;
    const Rendered r = render(renderer, settings, false, "defocus");
    for (double s_m : {0.55, 1.6}) {
      const fs::path out = scratch("series");
      auto summary = lf::write_refocus_capture(r.field, {s_m}, {0, 2.8, 4, 5.6}, out);
      if (!summary) throw std::runtime_error(summary.error().message);
      auto report = analysis::analyze_folder("defocus", out, analysis::AnalyzeOptions{});
      if (!report) throw std::runtime_error(report.error().message);
      const double k_px = *optics::circle_of_confusion_mm(8.0, 1.0, s_m * 1e3, 800.0) / 0.004;
      std::printf("| %d x %d | %.2f m |", views, views, s_m);
      const json& t = (*report)["targets"][0];
      for (const json& f : t["frames"]) {
        if (f["diameter_px"].is_null()) {
          std::printf(" %s |", f["status"].get<std::string>().c_str());
          continue;
        }
        const double n = f["f_number"], d = f["diameter_px"];
        std::printf(" %.2f px (%+.2f%%) |", d, 100 * (d / (k_px / n) - 1));
      }
      if (t["coc_vs_aperture"].contains("k_px"))
        std::printf(" %+.2f%% |\n", 100 * (t["coc_vs_aperture"]["k_px"].get<double>() / k_px - 1));
      else
        std::printf(" - |\n");
      std::fflush(stdout);
      fs::remove_all(out);
    }
    fs::remove_all(r.dir);
  }
}

void table_lens_blur(const json& scene) {
  std::printf(
      "\n4. Refocus against the lens's own blur (9 x 9 views, 320x240, no noise): edge-profile "
      "RMS / max over the edge's contrast, edges at the refocus distance\n");
  std::printf("| lens blur sigma | RMS | max |\n|---|---|---|\n");
  for (double sigma : {0.0, 0.4, 0.8}) {
    mock::Renderer renderer =
        analysis::testing::make_renderer(camera_json(320, 9, "none", sigma), scene);
    const Rendered r = render(renderer, renderer.default_settings(), false, "blur");
    const RefocusFigures rf = refocus_figures(renderer, r.field, 1.0);
    std::printf("| %.1f px | %.2f%% | %.1f%% |\n", sigma, 100 * rf.rms, 100 * rf.max);
    std::fflush(stdout);
    fs::remove_all(r.dir);
  }
}

void table_decode(const json& scene) {
  std::printf(
      "\n6. Decoding the lenslet image against the rendered views (320x240 views, no noise, "
      "12 bits; min_lit_share 0.5; times median of %d)\n",
      g_repeats);
  std::printf("| grid | views per side | views kept | decode s | DN RMS (worst view) |\n");
  std::printf("|---|---|---|---|---|\n");
  for (auto [grid, views] :
       {std::pair{"square", 5}, std::pair{"square", 9}, std::pair{"square", 13},
        std::pair{"hex", 8}, std::pair{"hex", 10}, std::pair{"hex", 14}}) {
    mock::Renderer renderer =
        analysis::testing::make_renderer(camera_json(320, views, grid), scene);
    const Rendered r = render(renderer, renderer.default_settings(), false, "decode");
    const DecodeFigures dc = decode_figures(r);
    std::printf("| %s | %d | %d | %.2f | %.2f (%.2f) |\n", grid, views, dc.views, dc.seconds,
                dc.rms, dc.worst);
    std::fflush(stdout);
    fs::remove_all(r.dir);
  }
}

void table_stack(const json& scene) {
  std::printf(
      "\n5. Depth from a refocused focus stack (analyze focus, 32 px regions) against depth "
      "from disparity (9 x 9 views, 320x240, noise on): regions of each textured plane\n");
  mock::Renderer renderer = analysis::testing::make_renderer(camera_json(320, 9), scene);
  const Rendered r = render(renderer, renderer.default_settings(), true, "stack");
  std::printf("| frames | stack s | analyze s | regions ok | region |err| median / worst |\n");
  std::printf("|---|---|---|---|---|\n");
  auto folder = image::LightFieldFolder::open(r.dir);
  const cv::Mat truth = *folder->load_depth_truth();
  for (int frames : {9, 17, 33}) {
    const fs::path out = scratch("stack_out");
    const auto start = Clock::now();
    auto summary =
        lf::write_refocus_capture(r.field, *lf::focus_sweep_m(0.5, 2.5, frames), {}, out);
    const double stack_s = seconds_since(start);
    if (!summary) throw std::runtime_error(summary.error().message);
    const auto t1 = Clock::now();
    auto report = analysis::analyze_focus(out, analysis::FocusStackOptions{});
    const double analyze_s = seconds_since(t1);
    if (!report) throw std::runtime_error(report.error().message);
    std::vector<double> errors;
    for (const auto& region : report->regions) {
      if (region.focus.status != analysis::kFocusOk || !region.distance_m) continue;
      // Regions wholly inside one textured plane (the truth constant over them).
      double lo = 1e9, hi = 0;
      cv::minMaxLoc(truth(region.focus.rect), &lo, &hi);
      const int cm = static_cast<int>(std::lround(hi * 100));
      if (lo <= 0 || hi - lo > 1e-4 || (cm != 60 && cm != 100 && cm != 160)) continue;
      errors.push_back(std::fabs(*region.distance_m / hi - 1));
    }
    std::sort(errors.begin(), errors.end());
    std::printf("| %d | %.2f | %.2f | %zu | %.2f%% / %.2f%% |\n", frames, stack_s, analyze_s,
                errors.size(), errors.empty() ? 0.0 : 100 * errors[errors.size() / 2],
                errors.empty() ? 0.0 : 100 * errors.back());
    std::fflush(stdout);
    fs::remove_all(out);
  }
  fs::remove_all(r.dir);
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> sections;
  for (int i = 1; i < argc; ++i) {
    if (std::strcmp(argv[i], "--repeats") == 0 && i + 1 < argc)
      g_repeats = std::max(1, std::atoi(argv[++i]));
    else
      sections.emplace_back(argv[i]);
  }
  const auto wanted = [&](const char* name) {
    return sections.empty() || std::find(sections.begin(), sections.end(), name) != sections.end();
  };
  try {
    const json scene = load_json(std::string(CAMLAB_SOURCE_DIR) +
                                 "/mock_device/examples/scene_lightfield_planes.json");
    if (wanted("views")) table_views_resolution(scene);
    if (wanted("depth")) table_depth(320);
    if (wanted("defocus")) table_defocus();
    if (wanted("blur")) table_lens_blur(scene);
    if (wanted("stack")) table_stack(scene);
    if (wanted("decode")) table_decode(scene);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "lightfield_bench: %s\n", e.what());
    return 1;
  }
  return 0;
}
