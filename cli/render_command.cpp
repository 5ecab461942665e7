// `camlab render`: frames from the virtual camera into a capture folder.
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <iostream>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "command_errors.h"
#include "commands.h"
#include "mock_device/render/render_capture.h"
#include "render_settings.h"

namespace camlab::cli {

namespace {

struct RenderArgs {
  std::string camera_path;
  std::string scene_path;
  std::string out_dir;
  std::vector<std::string> sweeps;  // at most two: the second varies inside the first
  std::vector<std::string> sets;
  std::vector<int> views;
  int repeats = 1;
  uint64_t seed = 1;
  int aperture_samples = -1;
  int pixel_samples = -1;
  int threads = 0;
  bool no_noise = false;
  bool hold_exposure = false;
  bool json = false;
  bool quiet = false;
};

void run_render(const RenderArgs& args) {
  const CommandErrors errors("camlab render", args.json);
  mock::CameraSpec camera = errors.take(mock::load_camera_spec(args.camera_path));
  mock::SceneSpec scene = errors.take(mock::load_scene_spec(args.scene_path));
  if (!args.quiet)
    std::fprintf(stderr, "camlab render: preparing the lens model (%dx%d)...\n",
                 camera.sensor.width_px, camera.sensor.height_px);
  auto renderer = mock::Renderer::create(std::move(camera), std::move(scene));
  if (!renderer) errors.fail(renderer.error());

  mock::RenderCaptureRequest request;
  request.out_dir = args.out_dir;
  request.base = settings_from_sets(errors, *renderer, args.sets);
  if (args.sweeps.size() > 2)
    errors.fail(make_error("invalid_argument",
                           "--sweep given " + std::to_string(args.sweeps.size()) +
                               " times; at most two (a grid: the second varies inside the first)"));
  if (!args.sweeps.empty()) request.sweep = errors.take(mock::parse_sweep(args.sweeps[0]));
  if (args.sweeps.size() == 2) request.inner_sweep = errors.take(mock::parse_sweep(args.sweeps[1]));
  if (args.hold_exposure) {
    const mock::Sweep* f_sweep = nullptr;
    for (const std::optional<mock::Sweep>* sweep : {&request.sweep, &request.inner_sweep})
      if (*sweep && (*sweep)->parameter == "f_number") f_sweep = &**sweep;
    if (!f_sweep)
      errors.fail(make_error("invalid_argument",
                             "--hold-exposure holds the exposure across f-numbers: it needs "
                             "--sweep f_number=..."));
    // The --set exposure_us is that of the --set f_number, or else of the first stop swept.
    const bool f_number_set = std::any_of(args.sets.begin(), args.sets.end(), [](const auto& s) {
      return s.rfind("f_number=", 0) == 0;
    });
    if (!f_number_set) request.base.f_number = f_sweep->values.front();
    request.hold_exposure = true;
  }
  request.repeats = args.repeats;
  request.views = args.views;
  request.options.seed = args.seed;
  request.options.noise = !args.no_noise;
  request.options.aperture_samples = args.aperture_samples;
  request.options.pixel_samples = args.pixel_samples;
  request.options.threads = args.threads;
  const bool tty = isatty(STDERR_FILENO);
  if (!args.quiet) {
    request.progress = [tty](int done, int total, const mock::RenderedFrame& frame) {
      std::fprintf(stderr, "%sframe %d/%d  %.2f s  %d samples/px  max CoC %.2f px%s",
                   tty ? "\r" : "", done, total, frame.stats.seconds, frame.stats.pixel_samples,
                   frame.stats.max_coc_px, tty ? (done == total ? "\n" : "") : "\n");
      std::fflush(stderr);
    };
  }
  auto summary = mock::render_capture(*renderer, request);
  if (!summary) errors.fail(summary.error());

  if (args.json) {
    nlohmann::json out = {
        {"out_dir", summary->out_dir.string()},
        {"frames", summary->frames},
        {"seconds", summary->seconds},
        {"frames_per_second", summary->frames / std::max(summary->seconds, 1e-9)}};
    std::cout << out.dump(2) << "\n";
  } else {
    std::printf(
        "wrote %d frame%s to %s in %.2f s (manifest.json, frames.jsonl, frame_*.png + .json)\n",
        summary->frames, summary->frames == 1 ? "" : "s", summary->out_dir.c_str(),
        summary->seconds);
  }
}

}  // namespace

void register_render_command(CLI::App& app) {
  auto args = std::make_shared<RenderArgs>();
  CLI::App* cmd = app.add_subcommand(
      "render",
      "Render frames from the virtual camera into a capture folder.\n"
      "Physically based: exact mrcal lens model, thin-lens defocus, exposure H = T x E with\n"
      "irradiance ~ 1/N^2, shot and read noise, quantisation. Every frame carries its truth\n"
      "(camera model, target poses, projected corners, predicted CoC) in its JSON sidecar.\n"
      "Frames: every view of the scene x every sweep value x repeats.");
  cmd->add_option("--camera", args->camera_path, "camera spec JSON (docs/virtual-camera.md)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--scene", args->scene_path, "scene spec JSON (docs/virtual-camera.md)")
      ->required()
      ->check(CLI::ExistingFile);
  cmd->add_option("--out", args->out_dir, "output capture folder (must not exist or be empty)")
      ->required();
  cmd->add_option(
         "--sweep", args->sweeps,
         "vary one setting: exposure_us=1000,2000,4000 | f_number=2:11.4:stops (f/2, 2.83, 4,\n"
         "5.66, 8, 11.3: start:stop:stops, half-stops, third-stops or xRATIO multiply)\n"
         "| exposure_us=1000:16000:stops (x2) | focus_position=0:200:20 (start:stop:step adds)\n"
         "| focus_m=0.5,1,2 | gain=1,2,4 (linear). Twice for a grid, the second inside the first:\n"
         "--sweep f_number=1.4:5.6:stops --sweep focus_position=10:120:5 --hold-exposure\n"
         "(a lens map's capture)")
      ->allow_extra_args(false);
  cmd->add_option("--set", args->sets,
                  "fix a setting for every frame, e.g. --set exposure_us=5000 --set f_number=2.8;\n"
                  "names as for --sweep; defaults come from the camera spec's controls");
  cmd->add_option("--view", args->views, "render only these views of the scene (0-based)");
  cmd->add_option("--repeats", args->repeats, "frames per setting (pairs for noise statistics)")
      ->check(CLI::Range(1, 1000));
  cmd->add_option("--seed", args->seed, "noise and sampling seed (same seed, same frames)");
  cmd->add_option("--aperture-samples", args->aperture_samples,
                  "lens samples per pixel (rounded to a square); default: from the predicted CoC,\n"
                  "none when it is below 0.1 px")
      ->check(CLI::Range(1, 4096));
  cmd->add_option("--pixel-samples", args->pixel_samples,
                  "area samples per pixel when the lens is not sampled (default 16)")
      ->check(CLI::Range(1, 1024));
  cmd->add_option("--threads", args->threads, "render threads (default: all cores)")
      ->check(CLI::Range(1, 256));
  cmd->add_flag("--no-noise", args->no_noise, "render the expected signal without noise");
  cmd->add_flag("--hold-exposure", args->hold_exposure,
                "with an f_number sweep: each stop's exposure time is exposure_us x (N / N0)^2,\n"
                "N0 the --set f_number or else the first stop swept, so that every stop gets\n"
                "the same exposure H (a lens map's capture; at one time f/5.6 is 4 stops under\n"
                "f/1.4)");
  cmd->add_flag("--json", args->json, "print the summary as JSON");
  cmd->add_flag("--quiet", args->quiet, "no progress on stderr");
  cmd->callback([args] { run_render(*args); });
}

}  // namespace camlab::cli
