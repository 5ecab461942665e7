// `camlab lightfield render|refocus|stack|depth|decode`: the virtual light-field camera
// and the measurements on light-field folders (src/analysis/lightfield/,
// docs/analysis.md "Light fields", docs/lightfield-folder.md). Parses, calls the
// libraries, prints.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "analysis/lightfield/depth.h"
#include "analysis/lightfield/lenslet_decode.h"
#include "analysis/lightfield/refocus_capture.h"
#include "base/format.h"
#include "command_errors.h"
#include "commands.h"
#include "image/pfm.h"
#include "mock_device/render/lightfield_render.h"
#include "render_settings.h"

namespace camlab::cli {
namespace {

namespace lf = camlab::analysis::lightfield;
using nlohmann::json;

struct LightFieldArgs {
  // render
  std::string camera_path, scene_path;
  std::vector<std::string> sets;
  int view = 0;
  uint64_t seed = 1;
  bool no_noise = false;
  int threads = 0;
  // refocus, stack, depth, decode
  std::string dir, out;
  std::vector<double> focus_m, f_numbers;
  double near_m = 0, far_m = 0;
  int frames = 9;
  int window_px = 7;
  double max_step_px = 2.0;
  double min_confidence = 1.0;
  double min_lit = 0.5;
  bool json = false;
};

// A distance for text: "inf" or metres.
std::string metres(double m) { return std::isfinite(m) ? format_printf("%.4g", m) : "inf"; }
json distance_json(double m) { return std::isfinite(m) ? json(m) : json(nullptr); }

void print_warnings(const std::vector<std::string>& warnings) {
  for (const std::string& w : warnings) std::printf("warning: %s\n", w.c_str());
}

void run_render(const LightFieldArgs& args) {
  const CommandErrors errors("camlab lightfield render", args.json);
  mock::CameraSpec camera = errors.take(mock::load_camera_spec(args.camera_path));
  mock::SceneSpec scene = errors.take(mock::load_scene_spec(args.scene_path));
  if (!camera.lightfield.enabled())
    errors.fail("invalid_argument", args.camera_path +
                                        " has no lightfield block: add \"lightfield\": {\"views\": "
                                        "[9, 9]} (docs/virtual-camera.md, \"Light fields\")");
  auto renderer = mock::Renderer::create(std::move(camera), std::move(scene));
  if (!renderer) errors.fail(renderer.error());
  const mock::RenderSettings settings = settings_from_sets(errors, *renderer, args.sets);
  mock::RenderOptions options;
  options.seed = args.seed;
  options.noise = !args.no_noise;
  options.threads = args.threads;
  const auto frame = errors.take(mock::render_light_field(*renderer, settings, args.view, options));
  errors.check(mock::write_light_field(frame, *renderer, args.out, options));
  const image::LightFieldDescription& d = frame.description;
  if (args.json) {
    json out = {
        {"out_dir", args.out},
        {"views", frame.views.size()},
        {"grid", {d.views_u, d.views_v}},
        {"lattice", d.lattice.layout},
        {"view_size", {frame.views[0].cols, frame.views[0].rows}},
        {"lenslet_size",
         frame.lenslet.empty() ? json(nullptr) : json({frame.lenslet.cols, frame.lenslet.rows})},
        {"focus_distance_m", distance_json(d.optics.focus_distance_m)},
        {"f_number", d.optics.f_number},
        {"seconds", frame.stats.seconds}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf("wrote %zu views of %dx%d (%d x %d cells, %s lattice)%s to %s in %.2f s\n",
              frame.views.size(), frame.views[0].cols, frame.views[0].rows, d.views_u, d.views_v,
              d.lattice.layout.c_str(),
              frame.lenslet.empty() ? ""
                                    : format_printf(", a %dx%d lenslet image and its white image",
                                                    frame.lenslet.cols, frame.lenslet.rows)
                                          .c_str(),
              args.out.c_str(), frame.stats.seconds);
  std::printf("focused at %s m, f/%.3g; views are frame_*.png, their geometry lightfield.json\n",
              metres(d.optics.focus_distance_m).c_str(), d.optics.f_number);
}

void print_refocus_summary(const lf::RefocusCaptureSummary& summary) {
  for (const json& f : summary.frames_json)
    std::printf(
        "focus %s m: sensor at %.4f mm (x%.5f), f/%.3g (effective f/%.3g, %d views), residual "
        "blur %.2f px\n",
        f["focus_m"].is_null() ? "inf" : format_printf("%.4g", f["focus_m"].get<double>()).c_str(),
        f["lens_to_sensor_mm"].get<double>(), f["magnification"].get<double>(),
        f["f_number"].get<double>(), f["effective_f_number"].get<double>(),
        f["views_used"].get<int>(), f["view_step_px"].get<double>());
  if (!summary.frames_json.empty()) {
    const json& range = summary.frames_json[0]["sharp_range_m"];
    std::printf("sharp refocus range (residual blur <= 1 px): %s to %s m\n",
                range[0].is_null() ? "inf" : format_printf("%.4g", range[0].get<double>()).c_str(),
                range[1].is_null() ? "inf" : format_printf("%.4g", range[1].get<double>()).c_str());
  }
  print_warnings(summary.warnings);
  std::printf("wrote %d frame%s to %s in %.2f s\n", summary.frames, summary.frames == 1 ? "" : "s",
              summary.out_dir.c_str(), summary.seconds);
}

void write_refocused(const CommandErrors& errors, const LightFieldArgs& args,
                     const std::vector<double>& focus_m) {
  const lf::LightField field = errors.take(lf::load_light_field(args.dir));
  const auto summary =
      errors.take(lf::write_refocus_capture(field, focus_m, args.f_numbers, args.out));
  if (args.json) {
    json out = {{"out_dir", args.out},
                {"frames", summary.frames_json},
                {"warnings", summary.warnings},
                {"seconds", summary.seconds}};
    std::printf("%s\n", out.dump(2).c_str());
  } else {
    print_refocus_summary(summary);
  }
}

void run_refocus(const LightFieldArgs& args) {
  const CommandErrors errors("camlab lightfield refocus", args.json);
  write_refocused(errors, args, args.focus_m);
}

void run_stack(const LightFieldArgs& args) {
  const CommandErrors errors("camlab lightfield stack", args.json);
  const std::vector<double> focus_m =
      errors.take(lf::focus_sweep_m(args.near_m, args.far_m, args.frames));
  write_refocused(errors, args, focus_m);
}

void run_depth(const LightFieldArgs& args) {
  const CommandErrors errors("camlab lightfield depth", args.json);
  const lf::LightField field = errors.take(lf::load_light_field(args.dir));
  lf::DepthOptions options;
  options.near_m = args.near_m;
  options.far_m = args.far_m;
  options.window_px = args.window_px;
  options.max_view_step_px = args.max_step_px;
  options.min_confidence = args.min_confidence;
  const lf::DepthResult depth = errors.take(lf::estimate_depth(field, options));
  std::vector<float> valid;
  for (int y = 0; y < depth.depth_m.rows; ++y)
    for (int x = 0; x < depth.depth_m.cols; ++x)
      if (depth.status.at<uint8_t>(y, x) == lf::kDepthOk)
        valid.push_back(depth.depth_m.at<float>(y, x));
  std::sort(valid.begin(), valid.end());
  const auto quantile = [&](double p) {
    return valid.empty() ? 0.0 : valid[static_cast<size_t>(p * (valid.size() - 1))];
  };
  json files = json::array();
  if (!args.out.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(args.out, ec);
    if (ec) errors.fail("io_error", "cannot create " + args.out + ": " + ec.message());
    errors.check(image::write_pfm(std::filesystem::path(args.out) / "depth_m.pfm", depth.depth_m));
    errors.check(
        image::write_pfm(std::filesystem::path(args.out) / "confidence.pfm", depth.confidence));
    cv::Mat status_f;
    depth.status.convertTo(status_f, CV_32F);
    errors.check(image::write_pfm(std::filesystem::path(args.out) / "status.pfm", status_f));
    files = {"depth_m.pfm", "confidence.pfm", "status.pfm"};
  }
  if (args.json) {
    json out = {{"size", {depth.depth_m.cols, depth.depth_m.rows}},
                {"near_m", depth.near_m},
                {"far_m", distance_json(depth.far_m)},
                {"candidates", depth.candidates},
                {"candidate_step_px", depth.candidate_step_px},
                {"noise_dn", depth.noise_dn},
                {"ok_share", depth.ok_share},
                {"flat_share", depth.flat_share},
                {"out_of_range_share", depth.out_of_range_share},
                {"depth_m_quantiles",
                 {{"p05", quantile(0.05)}, {"median", quantile(0.5)}, {"p95", quantile(0.95)}}},
                {"files", files},
                {"warnings", depth.warnings}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf(
      "searched %s to %s m in %d steps of %.3f px between neighbouring views (noise %.2f DN)\n",
      metres(depth.near_m).c_str(), metres(depth.far_m).c_str(), depth.candidates,
      depth.candidate_step_px, depth.noise_dn);
  std::printf("depth at %.1f%% of %dx%d pixels: median %.4g m (5%% %.4g m, 95%% %.4g m)\n",
              100 * depth.ok_share, depth.depth_m.cols, depth.depth_m.rows, quantile(0.5),
              quantile(0.05), quantile(0.95));
  print_warnings(depth.warnings);
  if (!args.out.empty())
    std::printf(
        "wrote depth_m.pfm (m, 0 = none), confidence.pfm, status.pfm (0 ok, 1 flat, 2 "
        "out of range) to %s\n",
        args.out.c_str());
}

void run_decode(const LightFieldArgs& args) {
  const CommandErrors errors("camlab lightfield decode", args.json);
  lf::DecodeOptions options;
  options.min_lit_share = args.min_lit;
  const lf::DecodedLightField decoded =
      errors.take(lf::decode_lenslet_folder(args.dir, args.out, options));
  const lf::MicrolensLattice& m = decoded.lattice;
  if (args.json) {
    json out = {{"out_dir", args.out},
                {"views", decoded.light_field.views.size()},
                {"views_per_side", decoded.views_per_side},
                {"cells_left_out", decoded.cells_left_out},
                {"lattice", lf::to_json(m)},
                {"full_white_dn", decoded.full_white_dn},
                {"warnings", decoded.warnings}};
    std::printf("%s\n", out.dump(2).c_str());
    return;
  }
  std::printf(
      "microlens lattice: %s, pitch %.4f px, %d x %d microlenses from (%.2f, %.2f), %d centres "
      "fitted to %.4f px RMS\n",
      m.staggered ? "hexagonal" : "square", m.pitch_px(), m.columns, m.rows, m.origin_px[0],
      m.origin_px[1], m.centres_found, m.fit_rms_px);
  std::printf(
      "wrote %zu views (%d x %d cells; %d left out: outside the disk, reaching the next "
      "microlens, or lit under %.2f) to %s\n",
      decoded.light_field.views.size(), decoded.views_per_side, decoded.views_per_side,
      decoded.cells_left_out, args.min_lit, args.out.c_str());
  print_warnings(decoded.warnings);
}

}  // namespace

void register_lightfield_command(CLI::App& app) {
  auto args = std::make_shared<LightFieldArgs>();
  CLI::App* cmd = app.add_subcommand(
      "lightfield",
      "light fields: render one from the virtual camera, refocus after capture, depth from the\n"
      "views' disparities, a focus stack by refocusing, decode a raw lenslet image");
  cmd->require_subcommand(1);
  const auto add_dir = [&](CLI::App* sub) {
    sub->add_option("DIR", args->dir, "light-field folder (docs/lightfield-folder.md)")
        ->required()
        ->check(CLI::ExistingDirectory);
    sub->add_flag("--json", args->json, "print the result as JSON");
  };

  CLI::App* render = cmd->add_subcommand(
      "render",
      "render a light field: U x V sub-aperture views (and, with a microlens grid, the raw\n"
      "lenslet image and its white image) with the truth (each view's aperture cell, the\n"
      "depth per pixel) into a light-field folder");
  render->add_option("--camera", args->camera_path, "camera spec JSON with a lightfield block")
      ->required()
      ->check(CLI::ExistingFile);
  render->add_option("--scene", args->scene_path, "scene spec JSON")
      ->required()
      ->check(CLI::ExistingFile);
  render->add_option("--out", args->out, "output folder (must not exist or be empty)")->required();
  render->add_option("--set", args->sets,
                     "a setting, e.g. --set focus_m=1.2 --set f_number=2.8 (names as for camlab "
                     "render: exposure_us, gain, f_number, focus_position, focus_m)");
  render->add_option("--view", args->view, "the scene's view (0-based)")
      ->check(CLI::Range(0, 1 << 20));
  render->add_option("--seed", args->seed, "noise and sampling seed");
  render->add_option("--threads", args->threads, "render threads (default: all cores)")
      ->check(CLI::Range(1, 256));
  render->add_flag("--no-noise", args->no_noise, "the expected signal, without noise");
  render->add_flag("--json", args->json, "print the summary as JSON");
  render->callback([args] { run_render(*args); });

  CLI::App* refocus = cmd->add_subcommand(
      "refocus",
      "refocus after capture by shift-and-add: one frame per focus distance and f-number, as a\n"
      "capture folder that camlab analyze reads (a sweep of f-numbers is an aperture series)");
  add_dir(refocus);
  refocus->add_option("--focus-m", args->focus_m, "focus distances in metres (> focal length; inf)")
      ->required()
      ->delimiter(',');
  refocus
      ->add_option("--f-number", args->f_numbers,
                   "synthetic f-numbers (>= the captured one); default: the captured aperture")
      ->delimiter(',');
  refocus->add_option("--out", args->out, "output capture folder")->required();
  refocus->callback([args] { run_refocus(*args); });

  CLI::App* stack = cmd->add_subcommand(
      "stack",
      "a focus stack made by refocusing: frames from --near-m to --far-m evenly in dioptres,\n"
      "which `camlab analyze focus` reads (depth from focus after capture)");
  add_dir(stack);
  stack->add_option("--near-m", args->near_m, "nearest focus distance (m)")->required();
  stack->add_option("--far-m", args->far_m, "farthest focus distance (m; inf allowed)")->required();
  stack->add_option("--frames", args->frames, "frames in the stack")
      ->capture_default_str()
      ->check(CLI::Range(2, 1000));
  stack->add_option("--f-number", args->f_numbers, "synthetic f-number (default: captured)")
      ->delimiter(',');
  stack->add_option("--out", args->out, "output capture folder")->required();
  stack->callback([args] { run_stack(*args); });

  CLI::App* depth = cmd->add_subcommand(
      "depth",
      "depth from the views' disparities (m per pixel); flat regions and depths outside the\n"
      "searched range are flagged, never extrapolated");
  add_dir(depth);
  depth->add_option("--near-m", args->near_m, "nearest depth searched (m; with --far-m)");
  depth->add_option("--far-m", args->far_m, "farthest depth searched (m)");
  depth
      ->add_option("--max-step-px", args->max_step_px,
                   "without --near-m/--far-m: search disparities up to this many px between "
                   "neighbouring views")
      ->capture_default_str()
      ->check(CLI::Range(0.01, 16.0));
  depth->add_option("--window", args->window_px, "matching window in px (odd)")
      ->capture_default_str()
      ->check(CLI::Range(3, 63));
  depth
      ->add_option("--min-confidence", args->min_confidence,
                   "below this the pixel is flat (no texture): (most - least) / (least + noise) of "
                   "the views' variance")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  depth->add_option("--out", args->out, "write depth_m.pfm, confidence.pfm, status.pfm here");
  depth->callback([args] { run_depth(*args); });

  CLI::App* decode = cmd->add_subcommand(
      "decode",
      "decode the raw lenslet image of a light-field folder into sub-aperture views: microlens\n"
      "centres from the white image, a fitted lattice, each view devignetted by the white");
  add_dir(decode);
  decode->add_option("--out", args->out, "output light-field folder")->required();
  decode
      ->add_option("--min-lit", args->min_lit,
                   "leave out cells lit less than this share of a full cell (0..1)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  decode->callback([args] { run_decode(*args); });
}

}  // namespace camlab::cli
